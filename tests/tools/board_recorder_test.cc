// yamor-characterize record: a board's raw counts read through a real yamord
// (a simulation here; the serial backend's readback is the same RPC).
#include <gtest/gtest.h>
#include <grpcpp/grpcpp.h>

#include <filesystem>
#include <memory>
#include <string>

#include "common/status.h"
#include "tests/support/code_of.h"
#include "tests/support/host_call.h"
#include "tests/support/yamord_process.h"
#include "tools/characterize/board_recorder.h"
#include "tools/characterize/characterize.h"
#include "yamor/v1/host.grpc.pb.h"

namespace yamor::characterize {
namespace {

using ::yamor::testing::Call;
using ::yamor::testing::CodeOf;

struct Daemon {
  Daemon() : process(YAMORD_PATH, {"--listen", "127.0.0.1:0", "--log-level", "warn"}) {
    port = process.WaitForPort();
    host = "127.0.0.1:" + std::to_string(port);
    stub = v1::Host::NewStub(grpc::CreateChannel(host, grpc::InsecureChannelCredentials()));
  }
  // Connects the quadruped and switches every sensor board's UART `uart`,
  // oscillators and motors off: the central module rests.
  void Connect(v1::Switch uart) {
    v1::ConnectRobotRequest connect;
    ASSERT_OK(Call(*stub, &v1::Host::Stub::ConnectRobot, connect));
    v1::ControlMessageRequest control;
    control.set_uart(uart);
    control.set_all(true);
    ASSERT_OK(Call(*stub, &v1::Host::Stub::SendControlMessage, control));
  }
  ::yamor::testing::YamordProcess process;
  int port = 0;
  std::string host;
  std::unique_ptr<v1::Host::Stub> stub;
};

TEST(BoardRecorderTest, RecordsEverySampleOfARestingBoardOnASimulation) {
  Daemon d;
  ASSERT_GT(d.port, 0);
  d.Connect(v1::SWITCH_ON);
  BoardRecording r{.host = d.host, .module_id = 4, .seconds = 2.0};
  const std::vector<LoggedReading> readings = RecordBoard(r);
  // Every 10-ms sample once: 2 s plus at most one reply of 16.
  ASSERT_GE(readings.size(), 200u);
  ASSERT_LE(readings.size(), 217u);
  for (size_t i = 1; i < readings.size(); ++i) {
    EXPECT_NEAR(readings[i].time - readings[i - 1].time, 0.01, 1e-9) << "reading " << i;
  }
  // At rest the counts sit in Table 4.1's noise band around their mean.
  const NoiseResult noise = NoiseFromLog(readings);
  for (int axis = 0; axis < 3; ++axis) {
    EXPECT_GT(noise.axes[axis].n_ampl, 0.0) << "axis " << axis;
    EXPECT_LT(noise.axes[axis].n_ampl, 1.5) << "axis " << axis;
  }
  // The CSV reads back as a logged file.
  std::istringstream csv(LoggedReadingsCsv(readings));
  EXPECT_EQ(ParseLoggedReadings(csv, "recorded.csv").size(), readings.size());
}

TEST(BoardRecorderTest, ABoardThatDoesNotAnswerIsNamed) {
  Daemon d;
  ASSERT_GT(d.port, 0);
  d.Connect(v1::SWITCH_OFF);
  std::string message;
  EXPECT_EQ(CodeOf([&] { RecordBoard({.host = d.host, .module_id = 4, .seconds = 1}); }, &message),
            StatusCode::kFailedPrecondition);
  EXPECT_NE(message.find("module 4"), std::string::npos) << message;
  EXPECT_NE(message.find("UART"), std::string::npos) << message;
  EXPECT_EQ(CodeOf([&] { RecordBoard({.host = d.host, .module_id = 99, .seconds = 1}); }, &message),
            StatusCode::kNotFound);
  EXPECT_EQ(CodeOf([&] { RecordBoard({.host = d.host, .module_id = 4, .seconds = 0}); }, &message),
            StatusCode::kInvalidArgument);
  const std::string host = d.host;
  d.process.Kill();
  EXPECT_EQ(CodeOf([&] {
              RecordBoard({.host = host, .module_id = 4, .seconds = 1, .rpc_deadline = 2});
            }, &message),
            StatusCode::kUnavailable);
  EXPECT_NE(message.find(host), std::string::npos) << message;
}

// The program writes nothing when the board cannot be read.
TEST(BoardRecorderTest, TheProgramLeavesNoFileOnError) {
  const std::filesystem::path out =
      std::filesystem::temp_directory_path() / ("yamor-record-" + std::to_string(getpid()) + ".csv");
  std::filesystem::remove(out);
  ::yamor::testing::YamordProcess program(
      YAMOR_CHARACTERIZE_PATH, {"record", "--host", "127.0.0.1:1", "--module", "4", "--seconds",
                                "1", "--out", out.string()});
  EXPECT_EQ(program.WaitForExit(std::chrono::seconds(30)), 1);
  EXPECT_FALSE(std::filesystem::exists(out));
}

}  // namespace
}  // namespace yamor::characterize
