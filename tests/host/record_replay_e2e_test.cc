// End to end: the real `yamord --record FILE` driven over gRPC, stopped, and
// the real `yamor-bridge --replay FILE` reproducing its position samples
// with zero difference (docs/snp.md, "Recorded sessions").
#include <signal.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "proto/snp/recording.h"
#include "tests/support/host_call.h"
#include "tests/support/yamord_process.h"
#include "yamor/v1/host.grpc.pb.h"

namespace yamor::host {
namespace {

namespace v1 = yamor::v1;
using google::protobuf::Empty;
using ::yamor::testing::Call;
using ::yamor::testing::YamordProcess;

std::vector<std::string> SplitCsv(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream in(line);
  std::string cell;
  while (std::getline(in, cell, ',')) cells.push_back(cell);
  if (!line.empty() && line.back() == ',') cells.push_back("");
  return cells;
}

TEST(RecordReplayE2eTest, YamordRecordsAndYamorBridgeReplaysWithZeroDifference) {
  const std::string dir = ::testing::TempDir() + "/record_replay_" + std::to_string(getpid());
  std::filesystem::create_directories(dir);
  const std::string recording = dir + "/session.rec";
  const std::string csv = dir + "/gap.csv";
  std::vector<v1::RobotPositionResponse> positions(2);
  {
    YamordProcess daemon(YAMORD_PATH, {"--listen", "127.0.0.1:0", "--log-level", "warn",
                                       "--record", recording, "--seed", "11"});
    const int port = daemon.WaitForPort();
    ASSERT_GT(port, 0) << "yamord did not report its port";
    auto channel = grpc::CreateChannel("127.0.0.1:" + std::to_string(port),
                                       grpc::InsecureChannelCredentials());
    auto stub = v1::Host::NewStub(channel);
    ASSERT_OK(Call(*stub, &v1::Host::Stub::ConnectRobot, v1::ConnectRobotRequest()));
    v1::ControlMessageRequest control;
    control.set_uart(v1::SWITCH_ON);
    control.set_cpg(v1::SWITCH_ON);
    control.set_motors(v1::SWITCH_ON);
    control.set_all(true);
    ASSERT_OK(Call(*stub, &v1::Host::Stub::SendControlMessage, control));
    v1::SleepRequest sleep;
    sleep.set_seconds(3.0);
    ASSERT_OK(Call(*stub, &v1::Host::Stub::Sleep, sleep));
    ASSERT_OK(Call(*stub, &v1::Host::Stub::RobotPosition, Empty(), &positions[0]));
    sleep.set_seconds(1.5);
    ASSERT_OK(Call(*stub, &v1::Host::Stub::Sleep, sleep));
    ASSERT_OK(Call(*stub, &v1::Host::Stub::RobotPosition, Empty(), &positions[1]));
    // A simulation opened over the API is recorded as a second session.
    v1::OpenSimulationRequest open;
    open.set_world("snake");
    open.set_seed(5);
    ASSERT_OK(Call(*stub, &v1::Host::Stub::OpenSimulation, open));
    ASSERT_OK(Call(*stub, &v1::Host::Stub::ConnectRobot, v1::ConnectRobotRequest()));
    ASSERT_OK(Call(*stub, &v1::Host::Stub::SendControlMessage, control));
    sleep.set_seconds(2.0);
    ASSERT_OK(Call(*stub, &v1::Host::Stub::Sleep, sleep));
    ASSERT_OK(Call(*stub, &v1::Host::Stub::RobotPosition, Empty()));
    daemon.Signal(SIGTERM);
    ASSERT_EQ(daemon.WaitForExit(std::chrono::seconds(20)), 0);
  }
  // The file is a valid recording of one session of the world opened at start.
  const snp::Recording parsed = snp::LoadRecordingFile(recording);
  EXPECT_EQ(parsed.torn_lines, 0);
  ASSERT_FALSE(parsed.entries.empty());
  const auto* open = std::get_if<snp::RecordedOpen>(&parsed.entries[0]);
  ASSERT_NE(open, nullptr);
  EXPECT_EQ(snp::FindAttribute(open->attributes, "world"), "quadruped");
  EXPECT_EQ(snp::FindAttribute(open->attributes, "seed"), "11");
  int opens = 0;
  for (const snp::RecordEntry& entry : parsed.entries) opens += std::holds_alternative<snp::RecordedOpen>(entry);
  EXPECT_EQ(opens, 2) << "the world at start and the OpenSimulation";

  YamordProcess bridge(YAMOR_BRIDGE_PATH, {"--replay", recording, "--csv", csv});
  const std::string report = bridge.ReadAll();
  ASSERT_EQ(bridge.WaitForExit(std::chrono::seconds(60)), 0) << report;
  std::cerr << report;
  EXPECT_NE(report.find("session 0 (opened at"), std::string::npos) << report;
  EXPECT_NE(report.find("world snake, seed 5"), std::string::npos) << report;
  EXPECT_EQ(report.find("differing (first"), std::string::npos) << "every reply as recorded";
  EXPECT_NE(report.find("stepped timing"), std::string::npos) << report;
  EXPECT_NE(report.find(", 0 differing"), std::string::npos) << report;
  EXPECT_NE(report.find("summary: 3 recorded position samples compared, mean difference 0 m, "
                        "max difference 0 m"),
            std::string::npos)
      << report;

  std::ifstream in(csv);
  std::string line;
  ASSERT_TRUE(std::getline(in, line));
  EXPECT_EQ(line, "session,time,sim_x,sim_y,sim_z,sample_time,sample_x,sample_y,sample_z,difference");
  int rows = 0;
  int snake_rows = 0;
  bool saw_last_sample = false;
  while (std::getline(in, line)) {
    const std::vector<std::string> cells = SplitCsv(line);
    ASSERT_EQ(cells.size(), 10u) << line;
    (cells[0] == "1" ? snake_rows : rows) += 1;
    EXPECT_EQ(cells[9], "0") << "row " << line;
    if (std::stod(cells[5]) == positions[1].time()) {
      saw_last_sample = true;
      EXPECT_EQ(std::stod(cells[6]), positions[1].position().x()) << line;
      EXPECT_EQ(std::stod(cells[7]), positions[1].position().y()) << line;
    }
  }
  EXPECT_EQ(rows, 4) << "one row per simulated second of 4.5 s";
  EXPECT_EQ(snake_rows, 2) << "the snake session: 2 s";
  EXPECT_TRUE(saw_last_sample) << "the RobotPosition read over gRPC is in the table";
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace yamor::host
