// bridge::Replay on recordings made by driving an emulated robot directly:
// a stepped (simulation) recording replays bit for bit, a different seed is
// caught as drift, and bad options are refused.
#include "bridge/replay.h"

#include <gtest/gtest.h>

#include "bridge/robot.h"
#include "common/status.h"
#include "proto/snp/messages.h"

namespace yamor::bridge {
namespace {

using snp::Address;
using snp::Direction;

const std::string kSourceDir = YAMOR_SOURCE_DIR;

physics::Morphology Quadruped() {
  return physics::Morphology::LoadFile(kSourceDir + "/configs/worlds/quadruped.xml");
}

// Drives a robot with `seed` like a host would and records every frame.
snp::Recording RecordDirectly(uint64_t seed) {
  RobotOptions options;
  options.world.seed = seed;
  options.phase_seed = seed;
  const physics::Morphology morphology = Quadruped();
  Robot robot(morphology, options);
  const uint8_t master = static_cast<uint8_t>(robot.master());
  snp::Recording recording;
  recording.header = {{"start", "2026-12-02T00:00:00Z"}, {"backend", "sim"}};
  recording.entries.push_back(snp::RecordedOpen{
      0.0, {{"backend", "simulation"}, {"seed", std::to_string(seed)},
            {"morphology", morphology.ToXml()}}});
  double t = 0.0;
  const auto send = [&](snp::Address to, const snp::Message& message) {
    const snp::Frame frame = snp::MakeFrame(Address::Host(), to, message);
    recording.entries.push_back(snp::RecordedFrame{t += 0.001, Direction::kHostToRobot, frame});
    std::vector<snp::Frame> out;
    robot.HandleFrame(frame, out);
    for (const snp::Frame& reply : out) {
      recording.entries.push_back(snp::RecordedFrame{t += 0.001, Direction::kRobotToHost, reply});
    }
  };
  send(Address::Module(master), snp::SetOscillator{.amplitude = 0.6f, .speed = 1.0f});
  send(Address::Module(master), snp::Control{.cpg = snp::Tristate::kOn, .motors = snp::Tristate::kOn});
  for (int i = 0; i < 50; ++i) {
    send(Address::Bridge(), snp::Step{0.05});
    if (i % 20 == 9) send(Address::Bridge(), snp::GetRobotPosition{});
  }
  return recording;
}

ReplayOptions NoLoader() { return ReplayOptions{}; }

ReplayOptions SourceWorlds() {
  ReplayOptions options;
  options.load_world = [](const std::string& name) {
    return physics::Morphology::LoadFile(kSourceDir + "/configs/worlds/" + name + ".xml");
  };
  return options;
}

TEST(BridgeReplayTest, AStepRecordingReplaysBitForBitAndDriftIsCaught) {
  const snp::Recording recording = RecordDirectly(7);
  const ReplayResult result = Replay(recording, NoLoader());
  ASSERT_EQ(result.sessions.size(), 1u);
  EXPECT_EQ(result.sessions[0].timing, ReplayTiming::kStepped);
  EXPECT_EQ(result.sessions[0].replies_differing, 0u) << result.sessions[0].first_difference;
  EXPECT_EQ(result.sessions[0].replies_recorded, result.sessions[0].replies_replayed);
  EXPECT_NEAR(result.sessions[0].end_time, 2.5, 1e-9);
  ASSERT_EQ(result.samples.size(), 3u);
  EXPECT_EQ(result.max_difference, 0.0);
  EXPECT_EQ(result.rows.size(), 2u) << "rows at 1 s and 2 s";
  ASSERT_TRUE(result.rows[0].nearest.has_value());
  EXPECT_NEAR(result.rows[0].nearest->recorded.time, 0.5, 1e-9);
  EXPECT_NE(result.samples[0].recorded.position, result.samples[2].recorded.position)
      << "the robot moves, so drift would show";

  ReplayOptions other_seed;
  other_seed.seed = 8;
  const ReplayResult drifted = Replay(recording, other_seed);
  EXPECT_GT(drifted.max_difference, 0.0);
  EXPECT_GT(drifted.mean_difference, 0.0);
  EXPECT_GT(drifted.sessions[0].replies_differing, 0u);
  EXPECT_FALSE(drifted.sessions[0].first_difference.empty());
}

TEST(BridgeReplayTest, RefusesWhatItCannotReplay) {
  snp::Recording recording = RecordDirectly(1);
  ReplayOptions bad_period;
  bad_period.row_period = 0.0;
  EXPECT_THROW(Replay(recording, bad_period), Error);
  std::get<snp::RecordedOpen>(recording.entries[0]).attributes = {{"backend", "simulation"},
                                                                   {"world", "quadruped"}};
  try {
    Replay(recording, NoLoader());
    ADD_FAILURE() << "replayed without a world loader";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kInvalidArgument);
  }
  std::get<snp::RecordedOpen>(recording.entries[0]).attributes = {{"seed", "x7"},
                                                                   {"world", "quadruped"}};
  try {
    ReplayOptions options;
    options.load_world = [](const std::string&) { return Quadruped(); };
    Replay(recording, options);
    ADD_FAILURE() << "accepted seed=x7";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("seed='x7'"), std::string::npos) << e.what();
  }
}

TEST(BridgeReplayTest, ARecordingWithoutStepsIsReplayedOnTheRecordedClock) {
  // A real robot's recording: no Step specials, frames at wall-clock times.
    const auto line = [](double t, const snp::Frame& f) {
    return snp::FormatRecordLine(snp::RecordedFrame{t, Direction::kHostToRobot, f}) + "\n";
  };
  std::string text = snp::FormatRecordHeader({{"start", "2026-12-02T00:00:00Z"}, {"backend", "serial"}}) + "\n";
  text += snp::FormatRecordLine(snp::RecordedOpen{10.0, {{"backend", "serial"}}}) + "\n";
  text += line(10.5, snp::MakeFrame(Address::Host(), Address::Broadcast(),
                                    snp::Control{.cpg = snp::Tristate::kOn}));
  text += line(12.75, snp::MakeFrame(Address::Host(), Address::Bridge(), snp::GetRobotPosition{}));
  const snp::Recording recording = snp::ParseRecording(text, "real.rec");

  EXPECT_THROW(Replay(recording, SourceWorlds()), Error)
      << "a real robot's session names no world";
  ReplayOptions options = SourceWorlds();
  options.world = "quadruped";
  const ReplayResult result = Replay(recording, options);
  ASSERT_EQ(result.sessions.size(), 1u);
  EXPECT_EQ(result.sessions[0].timing, ReplayTiming::kClocked);
  EXPECT_NEAR(result.sessions[0].end_time, 2.75, 1e-9) << "advanced to 12.75 s - 10 s";
  ASSERT_EQ(result.rows.size(), 2u);
  EXPECT_NEAR(result.rows[0].simulated.time, 1.0, 1e-9);
  EXPECT_NEAR(result.rows[1].simulated.time, 2.0, 1e-9);
  EXPECT_FALSE(result.rows[0].nearest.has_value()) << "no recorded samples";
  EXPECT_EQ(result.samples.size(), 0u);
  EXPECT_EQ(result.unmatched_samples, 1u) << "the replay answered a position nobody recorded";
  EXPECT_EQ(FormatReplayCsv(result).find(",,,,,\n") != std::string::npos, true);
}

}  // namespace
}  // namespace yamor::bridge
