// Recording and replay in process: RecordingBackend over the simulation
// backend records exactly what was sent and received, and replaying a
// recorded simulation session reproduces its position samples bit for bit.
#include <unistd.h>

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <memory>

#include "bridge/replay.h"
#include "common/format.h"
#include "common/status.h"
#include "host/builtin_robots.h"
#include "host/driver.h"
#include "host/recording_backend.h"
#include "host/sim_factory.h"
#include "host/worlds.h"
#include "physics/morphology.h"
#include "proto/snp/messages.h"
#include "proto/snp/recording.h"
#include "tests/host/test_util.h"

namespace yamor::host {
namespace {

using snp::Address;
using snp::Direction;

std::string TempPath(const std::string& name) {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  return (std::filesystem::temp_directory_path() /
          (name + "_" + info->name() + "_" + std::to_string(getpid()) + ".rec"))
      .string();
}

physics::Morphology QuadrupedMorphology() {
  return ResolveWorld(WorldRequest{.world = "quadruped"}, kDefaultWorld, false).morphology;
}

bridge::ReplayOptions ReplayFromSourceWorlds() {
  bridge::ReplayOptions options;
  options.load_world = [](const std::string& name) {
    return physics::Morphology::LoadFile(testing::kSourceDir + "/configs/worlds/" + name + ".xml");
  };
  return options;
}

// What yamord's backend wrapper records for a simulation.
snp::RecordAttributes SimulationAttributes(const physics::Morphology& morphology, uint64_t seed) {
  return {{"world", "quadruped"},
          {"seed", std::to_string(seed)},
          {"time_step", FormatDouble(DefaultSimulationTimeStep())},
          {"master", std::to_string(morphology.central())},
          {"morphology", morphology.ToXml()}};
}

TEST(RecordingBackendTest, RecordsEveryFrameSentAndReceivedInOrder) {
  const std::string path = TempPath("recording_backend");
  auto writer = std::make_shared<snp::RecordingWriter>(path, snp::RecordAttributes{{"backend", "sim"}});
  const physics::Morphology morphology = QuadrupedMorphology();
  RecordingBackend backend(MakeSimBackend(morphology, SimulationOptions{.seed = 5}), writer,
                           {{"world", "quadruped"}});
  EXPECT_TRUE(backend.IsSimulation());
  EXPECT_EQ(backend.Name(), "simulation");

  std::vector<snp::RecordedFrame> expected;
  const auto send = [&](const snp::Message& message) {
    const snp::Frame frame = snp::MakeFrame(Address::Host(), Address::Bridge(), message);
    backend.Send(frame);
    expected.push_back({0.0, Direction::kHostToRobot, frame});
    while (std::optional<snp::Frame> reply = backend.Receive(std::chrono::milliseconds(0))) {
      expected.push_back({0.0, Direction::kRobotToHost, *reply});
    }
  };
  send(snp::GetSimInfo{});
  send(snp::Step{0.25});
  send(snp::GetRobotPosition{});
  // A frame the codec refuses is not sent, so it is not recorded either.
  snp::Frame bad = snp::MakeFrame(Address::Host(), Address::Bridge(), snp::GetSimTime{});
  bad.payload.PushBack(1);
  EXPECT_THROW(backend.Send(bad), Error);
  EXPECT_EQ(backend.frames_recorded(), 6u);
  EXPECT_EQ(backend.write_failures(), 0u);

  const snp::Recording recording = snp::LoadRecordingFile(path);
  ASSERT_EQ(recording.entries.size(), 1 + expected.size());
  const auto& open = std::get<snp::RecordedOpen>(recording.entries[0]);
  EXPECT_EQ(snp::FindAttribute(open.attributes, "backend"), "simulation");
  EXPECT_EQ(snp::FindAttribute(open.attributes, "world"), "quadruped");
  for (std::size_t i = 0; i < expected.size(); ++i) {
    const auto& got = std::get<snp::RecordedFrame>(recording.entries[i + 1]);
    EXPECT_EQ(got.direction, expected[i].direction) << i;
    EXPECT_EQ(got.frame, expected[i].frame) << i;
  }
  const auto& step_done = std::get<snp::RecordedFrame>(recording.entries[4]).frame;
  EXPECT_EQ(std::get<snp::StepDone>(snp::DecodeMessage(step_done)).time, 0.25);
  std::filesystem::remove(path);
}

// The thesis session through the driver, recorded; returns the poses read.
std::vector<RobotPose> RecordSession(const std::string& path, uint64_t seed) {
  auto writer = std::make_shared<snp::RecordingWriter>(path, snp::RecordAttributes{{"backend", "sim"}});
  const physics::Morphology morphology = QuadrupedMorphology();
  RobotDriver driver({}, testing::QuadrupedConfig());
  driver.AttachBackend(
      std::make_unique<RecordingBackend>(MakeSimBackend(morphology, SimulationOptions{.seed = seed}),
                                         writer, SimulationAttributes(morphology, seed)),
      "quadruped");
  driver.ConnectRobot(0.0, false, nullptr);
  driver.SendControlMessage(ControlMessage{.uart = snp::Tristate::kOn,
                                           .cpg = snp::Tristate::kOn,
                                           .motors = snp::Tristate::kOn,
                                           .all = true});
  for (int hip = 0; hip < 4; ++hip) driver.SetModuleValue(hip, ModuleField::kSpeed, 0.35);
  driver.Flush();
  std::vector<RobotPose> poses;
  driver.Sleep(2.5, false, nullptr);
  poses.push_back(driver.RobotPosition());
  driver.Sleep(1.5, false, nullptr);
  poses.push_back(driver.RobotPosition());
  return poses;
}

TEST(ReplayTest, ASimulationRecordingReplaysBitForBit) {
  const std::string path = TempPath("replay");
  const std::vector<RobotPose> poses = RecordSession(path, 3);
  ASSERT_GT(std::hypot(poses[1].position[0] - poses[0].position[0],
                       poses[1].position[1] - poses[0].position[1]),
            1e-4)
      << "the quadruped walks, so a drifting replay would show";
  const snp::Recording recording = snp::LoadRecordingFile(path);

  const bridge::ReplayResult result = bridge::Replay(recording, ReplayFromSourceWorlds());
  ASSERT_EQ(result.sessions.size(), 1u);
  const bridge::ReplaySessionSummary& session = result.sessions[0];
  EXPECT_EQ(session.timing, bridge::ReplayTiming::kStepped);
  EXPECT_EQ(session.seed, 3u);
  EXPECT_EQ(session.replies_differing, 0u) << session.first_difference;
  EXPECT_EQ(session.replies_recorded, session.replies_replayed);
  EXPECT_NEAR(session.end_time, 4.0, 1e-9);
  ASSERT_EQ(result.samples.size(), 2u);
  EXPECT_EQ(result.unmatched_samples, 0u);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(result.samples[i].recorded.position, poses[i].position) << "what the driver read";
    EXPECT_EQ(result.samples[i].replayed.position, result.samples[i].recorded.position) << i;
    EXPECT_EQ(result.samples[i].replayed.time, result.samples[i].recorded.time) << i;
    EXPECT_EQ(result.samples[i].difference, 0.0);
  }
  EXPECT_EQ(result.max_difference, 0.0);
  EXPECT_EQ(result.mean_difference, 0.0);
  // One row per simulated second, each next to the nearest recorded sample.
  ASSERT_EQ(result.rows.size(), 4u);
  for (std::size_t r = 0; r < result.rows.size(); ++r) {
    EXPECT_NEAR(result.rows[r].simulated.time, r + 1.0, 1e-9);
    ASSERT_TRUE(result.rows[r].nearest.has_value());
  }
  EXPECT_EQ(result.rows[1].nearest->recorded.time, result.samples[0].recorded.time);
  EXPECT_EQ(result.rows[3].nearest->recorded.time, result.samples[1].recorded.time);
  EXPECT_EQ(result.rows[3].simulated.position, result.samples[1].recorded.position)
      << "the row at 4 s is the sample at 4 s";
  const std::string csv = bridge::FormatReplayCsv(result);
  EXPECT_EQ(csv.rfind("session,time,sim_x,sim_y,sim_z,sample_time,", 0), 0u) << csv;
  EXPECT_NE(bridge::FormatReplayReport(result).find("max difference 0 m"), std::string::npos)
      << bridge::FormatReplayReport(result);

  // A replay that drifts is caught: another seed starts the oscillators elsewhere.
  bridge::ReplayOptions drift = ReplayFromSourceWorlds();
  drift.seed = 4;
  const bridge::ReplayResult drifted = bridge::Replay(recording, drift);
  EXPECT_GT(drifted.max_difference, 0.0);
  EXPECT_GT(drifted.sessions[0].replies_differing, 0u);
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace yamor::host
