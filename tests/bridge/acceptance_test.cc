// Issue-3 acceptance: every appendix-A robot and the quadruped, driven by its
// configured gait through SNP frames, moves as the thesis describes; runs are
// bit-identical for a seed; random gaits inside Table 6.1's bounds never
// make the world diverge.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

#include "bridge/robot.h"
#include "cpg/config_xml.h"
#include "proto/snp/snp.h"

namespace yamor::bridge {
namespace {

const std::string kSourceDir = YAMOR_SOURCE_DIR;

struct WalkResult {
  Eigen::Vector3d start;         // central module at the end of the warm-up
  Eigen::Vector3d end;           // ... at the end
  double max_tilt_change = 0.0;  // largest rotation of the central module [rad]
  bool diverged = false;
};

void Configure(Robot& robot, const cpg::RobotConfig& config) {
  std::vector<snp::Frame> replies;
  for (const snp::Frame& frame : ConfigurationFrames(config)) robot.HandleFrame(frame, replies);
  for (const snp::Frame& reply : replies) {
    snp::Message m = snp::DecodeMessage(reply);
    if (const auto* ack = std::get_if<snp::Ack>(&m)) {
      ASSERT_EQ(ack->status, StatusCode::kOk) << snp::MessageTypeName(ack->acked);
    }
  }
}

WalkResult Walk(const std::string& name, const cpg::RobotConfig& config, double warmup, double duration,
         uint64_t seed = 1) {
  RobotOptions options;
  options.world.seed = seed;
  options.phase_seed = seed;
  options.master = config.master_id;
  Robot robot(physics::Morphology::LoadFile(kSourceDir + "/configs/worlds/" + name + ".xml"),
              options);
  Configure(robot, config);
  WalkResult run;
  std::vector<snp::Frame> events;
  const Eigen::Quaterniond q0 = robot.world().CentralOrientation();
  try {
    robot.Advance(warmup, events);
    run.start = robot.world().CentralPosition();
    const int steps = static_cast<int>(std::lround(duration / robot.world().options().time_step));
    for (int i = 0; i < steps; ++i) {
      robot.StepOnce(events);
      if (i % 50 == 0) {
        run.max_tilt_change =
            std::max(run.max_tilt_change, q0.angularDistance(robot.world().CentralOrientation()));
      }
    }
    run.end = robot.world().CentralPosition();
  } catch (const Error&) {
    run.diverged = true;
  }
  return run;
}

cpg::RobotConfig Config(const std::string& name) {
  return cpg::LoadConfigFile(kSourceDir + "/configs/robots/" + name + ".xml");
}

double PlanarDistance(const WalkResult& run) {
  return (run.end - run.start).head<2>().norm();
}

TEST(AcceptanceTest, QuadrupedWalks) {
  const WalkResult run = Walk("quadruped", Config("quadruped"), 8.0, 12.0);
  ASSERT_FALSE(run.diverged);
  const double velocity = PlanarDistance(run) / 12.0;
  RecordProperty("velocity_cm_s", std::to_string(velocity * 100));
  EXPECT_GT(velocity, 0.005) << "quadruped velocity " << velocity * 100 << " cm/s";
  EXPECT_LT(run.max_tilt_change, 1.0) << "the quadruped fell over";
}

TEST(AcceptanceTest, QuadrupedStandsStillWithoutOscillation) {
  cpg::RobotConfig config = Config("quadruped");
  for (auto& m : config.modules) m.amplitude = 0.0;
  const WalkResult run = Walk("quadruped", config, 8.0, 12.0);
  ASSERT_FALSE(run.diverged);
  EXPECT_LT(PlanarDistance(run), 0.005);  // the walking test is not a drift
}

TEST(AcceptanceTest, SnakeUndulatesForward) {
  const WalkResult run = Walk("snake", Config("snake"), 4.0, 16.0);
  ASSERT_FALSE(run.diverged);
  const Eigen::Vector3d d = run.end - run.start;
  RecordProperty("distance_cm", std::to_string(d.head<2>().norm() * 100));
  EXPECT_GT(d.head<2>().norm(), 0.03) << d.transpose();
  // Along its body axis (x in the morphology), not sideways.
  EXPECT_GT(std::fabs(d.x()), 2.0 * std::fabs(d.y())) << d.transpose();
  EXPECT_LT(run.max_tilt_change, 1.6);  // it does not roll over
}

// The thesis's wheel rolls; ours (configs/worlds/wheel.xml, the thesis's
// parameters verbatim) moves forward in its own plane by shape changes but
// does not turn over: a faithful rolling wheel needs A.4's triangle geometry.
TEST(AcceptanceTest, WheelMovesForwardInItsPlane) {
  const WalkResult run = Walk("wheel", Config("wheel"), 4.0, 16.0);
  ASSERT_FALSE(run.diverged);
  const Eigen::Vector3d d = run.end - run.start;
  RecordProperty("distance_cm", std::to_string(PlanarDistance(run) * 100));
  EXPECT_GT(std::fabs(d.x()), 0.05) << d.transpose();
  EXPECT_LT(std::fabs(d.y()), 0.2 * std::fabs(d.x())) << d.transpose();
}

TEST(AcceptanceTest, TrebuchetMoves) {
  const WalkResult run = Walk("trebuchet", Config("trebuchet"), 4.0, 16.0);
  ASSERT_FALSE(run.diverged);
  RecordProperty("distance_cm", std::to_string(PlanarDistance(run) * 100));
  EXPECT_GT(PlanarDistance(run), 0.02);
}

TEST(AcceptanceTest, DogMoves) {
  const WalkResult run = Walk("dog", Config("dog"), 4.0, 16.0);
  ASSERT_FALSE(run.diverged);
  RecordProperty("distance_cm", std::to_string(PlanarDistance(run) * 100));
  EXPECT_GT(PlanarDistance(run), 0.02);
}

TEST(AcceptanceTest, TripodRunsWithoutDiverging) {
  const WalkResult run = Walk("tripod", Config("tripod"), 4.0, 16.0);
  ASSERT_FALSE(run.diverged);
}

TEST(AcceptanceTest, SameSeedIsBitIdentical) {
  const WalkResult a = Walk("quadruped", Config("quadruped"), 2.0, 3.0, 7);
  const WalkResult b = Walk("quadruped", Config("quadruped"), 2.0, 3.0, 7);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(a.end[i], b.end[i]);
    EXPECT_EQ(a.start[i], b.start[i]);
  }
}

// A gait drawn uniformly inside Table 6.1's bounds with its symmetries: one
// amplitude for the hips, one for the knees, one knee offset, one hip->knee
// lag, and lags 0->1, 1->2, 2->3 (3->0 closes the ring).
cpg::RobotConfig RandomQuadrupedGait(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  cpg::RobotConfig config = Config("quadruped");
  const double hip_amplitude = unit(rng) * M_PI / 4;
  const double knee_amplitude = unit(rng) * M_PI / 2;
  const double knee_offset = -unit(rng) * M_PI / 2;
  const double hip_to_knee = unit(rng) * 2 * M_PI;
  const double ring[3] = {unit(rng) * 2 * M_PI, unit(rng) * 2 * M_PI, unit(rng) * 2 * M_PI};
  const double closing = -(ring[0] + ring[1] + ring[2]);
  for (auto& m : config.modules) {
    if (m.id <= 3) m.amplitude = hip_amplitude;
    if (m.id >= 5) {
      m.amplitude = knee_amplitude;
      m.offset = knee_offset;
    }
  }
  for (auto& c : config.couplings) {
    auto ring_lag = [&](int from, int to) -> std::optional<double> {
      if (from == 3 && to == 0) return closing;
      if (from >= 0 && from <= 2 && to == from + 1) return ring[from];
      return std::nullopt;
    };
    if (c.from <= 3 && c.to <= 3) {
      if (auto lag = ring_lag(c.from, c.to)) c.phase = *lag;
      else if (auto back = ring_lag(c.to, c.from)) c.phase = -*back;
    } else if (c.from <= 3 && c.to == c.from + 5) {
      c.phase = hip_to_knee;
    } else if (c.to <= 3 && c.from == c.to + 5) {
      c.phase = -hip_to_knee;
    }
  }
  cpg::Validate(config);
  return config;
}

class RandomGaitTest : public ::testing::TestWithParam<int> {};

// 500 gaits of 20 s each, in 10 shards so ctest spreads them over the cores.
TEST_P(RandomGaitTest, NeverDiverges) {
  const int shard = GetParam();
  std::mt19937_64 rng(1000 + shard);
  for (int i = 0; i < 50; ++i) {
    const cpg::RobotConfig gait = RandomQuadrupedGait(rng);
    const WalkResult run = Walk("quadruped", gait, 8.0, 12.0, shard * 50 + i);
    ASSERT_FALSE(run.diverged) << "gait " << shard * 50 + i << ":\n" << cpg::WriteConfigXml(gait);
    ASSERT_TRUE(run.end.allFinite());
    ASSERT_LT(PlanarDistance(run), 12.0 * 1.0) << "faster than 1 m/s is not a YaMoR gait";
  }
}

INSTANTIATE_TEST_SUITE_P(Shards, RandomGaitTest, ::testing::Range(0, 10));

}  // namespace
}  // namespace yamor::bridge
