// Issue-3 acceptance: every appendix-A robot and the quadruped, driven by its
// configured gait through SNP frames, moves as the thesis describes; runs are
// bit-identical for a seed; random gaits inside Table 6.1's bounds never
// make the world diverge.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

#include "bridge/robot.h"
#include "host/config_frames.h"
#include "cpg/config_xml.h"
#include "proto/snp/snp.h"

namespace yamor::bridge {
namespace {

// The host builds configuration frames (host/config_frames.h).
using host::ConfigurationFrames;
using host::IsInactive;

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

struct RollResult {
  double rotation = 0.0;      // cumulative turn of the central module about the axle [rad]
  double travel = 0.0;        // displacement along the rolling direction [m]
  double sideways = 0.0;      // displacement along the axle [m]
  double max_axle_tilt = 0.0; // largest angle between the axle and its start [rad]
  bool diverged = false;
};

// Runs the wheel for `duration` from power-on, tracking how far the central
// module has turned about the axle (its hinge axis at the start, horizontal).
RollResult Roll(uint64_t seed, double duration, double time_step = 0.002,
                double ground_friction = 0.6) {
  const cpg::RobotConfig config = Config("wheel");
  RobotOptions options;
  options.world.seed = seed;
  options.world.time_step = time_step;
  options.world.ground_friction = ground_friction;
  options.phase_seed = seed;
  options.master = config.master_id;
  Robot robot(physics::Morphology::LoadFile(kSourceDir + "/configs/worlds/wheel.xml"), options);
  Configure(robot, config);
  const int central = robot.world().CentralModule();
  const Eigen::Matrix3d r0 = robot.world().ModulePose(central).linear();
  const Eigen::Vector3d axle = r0.col(1);
  const Eigen::Vector3d forward = Eigen::Vector3d::UnitZ().cross(axle).normalized();
  auto heading = [&](const Eigen::Matrix3d& r) {
    const Eigen::Vector3d x = r.col(0);
    return std::atan2(x.dot(Eigen::Vector3d::UnitZ()), x.dot(forward));
  };
  RollResult run;
  double previous = heading(r0);
  const Eigen::Vector3d start = robot.world().CentralPosition();
  std::vector<snp::Frame> events;
  const int steps = static_cast<int>(std::lround(duration / time_step));
  try {
    for (int i = 1; i <= steps; ++i) {
      robot.StepOnce(events);
      if (i % 10 != 0) continue;  // the wheel turns far less than 180° in 10 steps
      const Eigen::Matrix3d r = robot.world().ModulePose(central).linear();
      const double now = heading(r);
      run.rotation += std::remainder(now - previous, 2 * M_PI);
      previous = now;
      run.max_axle_tilt =
          std::max(run.max_axle_tilt, std::acos(std::min(1.0, std::fabs(r.col(1).dot(axle)))));
    }
  } catch (const Error&) {
    run.diverged = true;
  }
  const Eigen::Vector3d d = robot.world().CentralPosition() - start;
  run.travel = d.dot(forward);
  run.sideways = d.dot(axle);
  return run;
}

// Appendix A.4: the wheel rolls. Three active modules drive the triangle of
// configs/worlds/wheel.xml with the thesis's parameters (configs/robots/
// wheel.xml verbatim); the inactive corners are free hinges. In 20 s the
// central module turns over at least twice (about 2-5 turns in our runs),
// always the same way round, and the wheel travels forward in its own plane.
TEST(AcceptanceTest, WheelRolls) {
  for (uint64_t seed : {1, 2, 3}) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const RollResult run = Roll(seed, 20.0);
    ASSERT_FALSE(run.diverged);
    RecordProperty("turns_seed_" + std::to_string(seed),
                   std::to_string(run.rotation / (2 * M_PI)));
    RecordProperty("distance_cm_seed_" + std::to_string(seed), std::to_string(run.travel * 100));
    // Rolling towards +forward turns the central module negatively about the
    // axle (atan2(x·z, x·forward) decreases).
    EXPECT_LT(run.rotation, -2 * 2 * M_PI) << run.rotation * 180 / M_PI << " degrees";
    EXPECT_GT(run.travel, 1.0) << run.travel << " m";
    // Rolling, not sliding: about one wheel circumference (≈ 0.65 m) per turn.
    EXPECT_NEAR(run.travel / (-run.rotation / (2 * M_PI)), 0.65, 0.15);
    EXPECT_LT(std::fabs(run.sideways), 0.1 * run.travel);
    EXPECT_LT(run.max_axle_tilt, 0.2);  // it stays upright
  }
}

// The rolling does not hinge on the default step or floor: a 1 ms step and a
// grippy floor (μ = 1) roll it too.
TEST(AcceptanceTest, WheelRollsWithAFinerStepAndMoreFriction) {
  const RollResult run = Roll(1, 20.0, 0.001, 1.0);
  ASSERT_FALSE(run.diverged);
  EXPECT_LT(run.rotation, -2 * 2 * M_PI) << run.rotation * 180 / M_PI << " degrees";
  EXPECT_GT(run.travel, 1.0) << run.travel << " m";
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
