#include "physics/world.h"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "common/status.h"
#include "tests/support/code_of.h"

#if defined(__SANITIZE_ADDRESS__)
#include <sanitizer/lsan_interface.h>
#endif

namespace yamor::physics {
namespace {

using ::testing::HasSubstr;

const std::string kWorlds = std::string(YAMOR_SOURCE_DIR) + "/configs/worlds/";

Morphology Load(const std::string& robot) { return Morphology::LoadFile(kWorlds + robot + ".xml"); }

using ::yamor::testing::CodeOf;

// Exact bitwise equality of doubles (NaN-safe, distinguishes -0.0).
bool SameBits(double a, double b) { return std::memcmp(&a, &b, sizeof(double)) == 0; }

// Drives the quadruped with a fixed open-loop gait and records, per step, the
// central position and every servo angle.
std::vector<double> QuadrupedTrace(World& world, int steps) {
  std::vector<double> trace;
  for (int s = 0; s < steps; ++s) {
    const double t = world.Time();
    for (int hip = 0; hip < 4; ++hip) {
      world.SetServoTarget(hip, 0.6 * std::sin(2 * M_PI * t + hip * 1.3));
      world.SetServoTarget(hip + 5, -0.8 + 0.5 * std::sin(2 * M_PI * t + hip * 1.3 + 2.0));
    }
    world.Step();
    const Eigen::Vector3d p = world.CentralPosition();
    trace.insert(trace.end(), {p.x(), p.y(), p.z()});
    for (int id : world.ModuleIds()) trace.push_back(world.ServoAngle(id));
    const AccelerometerReading a = world.Accelerometer(4);
    trace.insert(trace.end(), {double(a.counts[0]), double(a.counts[1]), double(a.counts[2])});
  }
  return trace;
}

void ExpectSameBits(const std::vector<double>& a, const std::vector<double>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    ASSERT_TRUE(SameBits(a[i], b[i])) << "first difference at " << i << ": " << a[i] << " vs "
                                      << b[i];
  }
}

TEST(WorldTest, EveryRobotRestsOnTheGround) {
  int worlds = 0;
  for (const auto& entry : std::filesystem::directory_iterator(kWorlds)) {
    if (entry.path().extension() != ".xml") continue;
    ++worlds;
    SCOPED_TRACE(entry.path().filename().string());
    World world(Morphology::LoadFile(entry.path()));
    EXPECT_NEAR(world.LowestPoint(), world.options().drop_gap, 1e-9);
    EXPECT_NEAR(world.CentralPosition().head<2>().norm(), 0, 1e-9);
    const double dt = world.options().time_step;
    world.Step(static_cast<int>(std::lround(1.5 / dt)));
    const Eigen::Vector3d before = world.CentralPosition();
    world.Step(static_cast<int>(std::lround(0.5 / dt)));
    ASSERT_FALSE(world.Diverged()) << world.Divergence().reason;
    EXPECT_NEAR(world.Time(), 2.0, 1e-9);
    // Settled: the central module no longer moves and the robot sits on the
    // ground (contacts are soft: a fraction of a millimetre of penetration).
    EXPECT_LT((world.CentralPosition() - before).norm(), 1e-4);
    EXPECT_GT(world.LowestPoint(), -1e-3);
    EXPECT_LT(world.LowestPoint(), 1e-3);
    for (int id : world.ModuleIds()) {
      EXPECT_NEAR(world.ServoAngle(id), world.morphology().Module(id).StartAngle(), 0.02) << id;
    }
  }
  EXPECT_GE(worlds, 6);
}

TEST(WorldTest, ServoReachesItsTargetWithinItsSpeedLimit) {
  World world(Load("snake"));
  const ServoSpec& servo = world.options().servo;
  world.SetServoTarget(8, 0.5);  // the tail lifts only its own body
  double previous = world.ServoAngle(8);
  double fastest = 0;
  for (int s = 0; s < 500; ++s) {
    world.Step();
    const double angle = world.ServoAngle(8);
    fastest = std::max(fastest, std::abs(angle - previous) / world.options().time_step);
    previous = angle;
  }
  EXPECT_NEAR(world.ServoAngle(8), 0.5, 0.01);
  EXPECT_LE(fastest, servo.max_speed * 1.05);
  EXPECT_GE(fastest, servo.max_speed * 0.5);  // it did move at speed, not creep
  // 0.5 rad at no more than max_speed takes at least this long.
  World again(Load("snake"));
  again.SetServoTarget(8, 0.5);
  again.Step(static_cast<int>(0.5 / servo.max_speed / again.options().time_step * 0.9));
  EXPECT_LT(again.ServoAngle(8), 0.5 - 0.02);
}

TEST(WorldTest, HandlePoseFollowsTheServoAngle) {
  World world(Load("snake"));
  world.SetServoTarget(8, -0.4);
  world.Step(400);
  const Eigen::Isometry3d expected = world.ModulePose(8) * HandleInBody(world.ServoAngle(8));
  const Eigen::Isometry3d actual = world.HandlePose(8);
  EXPECT_LT((expected.translation() - actual.translation()).norm(), 1e-4);
  EXPECT_LT(Eigen::AngleAxisd(expected.linear().transpose() * actual.linear()).angle(), 1e-3);
  EXPECT_NEAR(world.ServoAngle(8), -0.4, 0.01);
}

TEST(WorldTest, ServoTargetsAreValidatedAndClamped) {
  World world(Load("snake"));
  world.SetServoTarget(3, 3.0);
  EXPECT_DOUBLE_EQ(world.ServoTarget(3), module::kServoLimit);
  world.SetServoTarget(3, -2.0);
  EXPECT_DOUBLE_EQ(world.ServoTarget(3), -module::kServoLimit);
  EXPECT_EQ(CodeOf([&] { world.SetServoTarget(3, std::nan("")); }), StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf([&] { world.SetServoTarget(3, INFINITY); }), StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf([&] { world.SetServoTarget(42, 0.1); }), StatusCode::kNotFound);
  EXPECT_EQ(CodeOf([&] { world.ServoAngle(42); }), StatusCode::kNotFound);
  EXPECT_EQ(CodeOf([&] { world.ModulePose(42); }), StatusCode::kNotFound);
  EXPECT_EQ(CodeOf([&] { world.Accelerometer(42); }), StatusCode::kNotFound);
  EXPECT_EQ(CodeOf([&] { world.SetMotorFault(42, MotorFault::kLimp); }), StatusCode::kNotFound);
  EXPECT_EQ(CodeOf([&] { world.SetGroundFriction(-1); }), StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf([&] { world.SetGroundFriction(std::nan("")); }),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf([&] { world.SetSlope(2.0); }), StatusCode::kOutOfRange);
  EXPECT_EQ(CodeOf([&] { world.SetSlope(std::nan("")); }), StatusCode::kInvalidArgument);
  // None of it reached ODE: the world still runs and the targets are intact.
  EXPECT_DOUBLE_EQ(world.ServoTarget(3), -module::kServoLimit);
  world.Step(10);
  EXPECT_FALSE(world.Diverged());
}

TEST(WorldTest, BadOptionsAreRejected) {
  WorldOptions options;
  options.time_step = 0;
  EXPECT_EQ(CodeOf([&] { World(Load("snake"), options); }), StatusCode::kInvalidArgument);
  options = WorldOptions();
  options.ground_friction = std::nan("");
  EXPECT_EQ(CodeOf([&] { World(Load("snake"), options); }), StatusCode::kInvalidArgument);
  options = WorldOptions();
  options.servo.stall_torque = -1;
  EXPECT_EQ(CodeOf([&] { World(Load("snake"), options); }), StatusCode::kInvalidArgument);
}

TEST(WorldTest, RigidlyConnectedPartsShareOneBody) {
  World world(Load("quadruped"));
  // 18 parts; central body + 4 hip handles, 4 × (hip body + knee handle),
  // 4 knee bodies and the central's free handle: 10 bodies.
  EXPECT_EQ(world.BodyCount(), 10);
  EXPECT_NEAR(world.TotalMass(), 9 * ModuleMass(), 1e-12);
  EXPECT_NEAR(world.GroupMass(4, Part::kBody), module::kBodyMass + 4 * module::kHandleMass, 1e-12);
  EXPECT_NEAR(world.GroupMass(0, Part::kHandle), world.GroupMass(4, Part::kBody), 1e-15);
  EXPECT_NEAR(world.GroupMass(0, Part::kBody), module::kBodyMass + module::kHandleMass, 1e-12);
  EXPECT_NEAR(world.GroupMass(5, Part::kBody), module::kBodyMass, 1e-12);

  World snake(Load("snake"));
  // Each body carries the next handle: 8 such pairs, the tail body and the
  // head's free handle.
  EXPECT_EQ(snake.BodyCount(), 10);
  EXPECT_NEAR(snake.TotalMass(), 9 * ModuleMass(), 1e-12);
}

TEST(WorldTest, ResetReplaysBitIdentically) {
  World fresh(Load("quadruped"));
  const std::vector<double> first = QuadrupedTrace(fresh, 1500);
  ASSERT_FALSE(fresh.Diverged());
  // Change everything that Reset() must restore.
  fresh.SetGroundFriction(0.1);
  fresh.SetSlope(0.2, 1.0);
  fresh.SetMotorFault(5, MotorFault::kStuck);
  fresh.SetModuleDefect(6, true);
  fresh.SetMotorEnabled(7, false);
  fresh.Step(100);
  fresh.Reset();
  EXPECT_EQ(fresh.StepCount(), 0u);
  EXPECT_EQ(fresh.GroundFriction(), fresh.options().ground_friction);
  EXPECT_EQ(fresh.GetMotorFault(5), MotorFault::kNone);
  EXPECT_FALSE(fresh.ModuleDefective(6));
  EXPECT_TRUE(fresh.MotorEnabled(7));
  ExpectSameBits(QuadrupedTrace(fresh, 1500), first);
}

TEST(WorldTest, StartAnglesAreTheInitialPoseAndSetPointAndResetRestoresThem) {
  World world(Load("wheel"));
  const Morphology& m = world.morphology();
  for (int id : world.ModuleIds()) {
    const double start = m.Module(id).StartAngle();
    ASSERT_NE(start, 0.0) << id;
    EXPECT_NEAR(world.ServoAngle(id), start, 1e-9) << id;
    EXPECT_EQ(world.ServoTarget(id), start) << id;
    EXPECT_TRUE(world.HandlePose(id).isApprox(
        PartPose(world.ModulePose(id), Part::kHandle, start), 1e-9))
        << id;
  }
  // Every motor holding its start: the hexagon stands still.
  world.Step(500);
  for (int id : world.ModuleIds()) {
    EXPECT_NEAR(world.ServoAngle(id), m.Module(id).StartAngle(), 0.02) << id;
  }
  const std::vector<double> first = [&] {
    World fresh(Load("wheel"));
    fresh.Step(200);
    std::vector<double> angles;
    for (int id : fresh.ModuleIds()) angles.push_back(fresh.ServoAngle(id));
    return angles;
  }();
  // With the corners free (as the wheel runs), 6 straightens.
  for (int id : {1, 2, 3}) world.SetMotorEnabled(id, false);
  world.SetServoTarget(6, 0.0);
  world.Step(300);
  EXPECT_GT(std::fabs(world.ServoAngle(6) - m.Module(6).StartAngle()), 0.1);
  world.Reset();
  EXPECT_EQ(world.ServoTarget(6), m.Module(6).StartAngle());
  EXPECT_NEAR(world.ServoAngle(6), m.Module(6).StartAngle(), 1e-9);
  world.Step(200);
  std::vector<double> again;
  for (int id : world.ModuleIds()) again.push_back(world.ServoAngle(id));
  ExpectSameBits(again, first);
}

TEST(WorldTest, SameSeedGivesBitIdenticalWorlds) {
  WorldOptions options;
  options.seed = 99;
  World a(Load("quadruped"), options);
  World b(Load("quadruped"), options);
  // Interleaved in one thread and concurrently in two threads.
  std::vector<double> ta, tb;
  for (int chunk = 0; chunk < 5; ++chunk) {
    const auto pa = QuadrupedTrace(a, 200);
    const auto pb = QuadrupedTrace(b, 200);
    ta.insert(ta.end(), pa.begin(), pa.end());
    tb.insert(tb.end(), pb.begin(), pb.end());
  }
  ExpectSameBits(ta, tb);

  std::vector<double> tc, td;
  std::thread first([&] {
    World c(Load("quadruped"), options);
    tc = QuadrupedTrace(c, 1000);
  });
  std::thread second([&] {
    World d(Load("quadruped"), options);
    td = QuadrupedTrace(d, 1000);
  });
  first.join();
  second.join();
  ExpectSameBits(tc, ta);
  ExpectSameBits(td, ta);

  // Another seed changes the sensor noise only.
  options.seed = 100;
  World e(Load("quadruped"), options);
  const auto te = QuadrupedTrace(e, 1000);
  int differing_counts = 0;
  const size_t stride = ta.size() / 1000;
  for (size_t s = 0; s < 1000; ++s) {
    for (size_t k = 0; k + 3 < stride; ++k) {
      ASSERT_TRUE(SameBits(ta[s * stride + k], te[s * stride + k])) << "step " << s;
    }
    for (size_t k = stride - 3; k < stride; ++k) {
      differing_counts += ta[s * stride + k] != te[s * stride + k];
    }
  }
  EXPECT_GT(differing_counts, 1000);
}

TEST(WorldTest, IterativeStepsAreDeterministicAcrossThreads) {
  WorldOptions options;
  options.step_method = StepMethod::kIterative;
  World reference(Load("quadruped"), options);
  const std::vector<double> expected = QuadrupedTrace(reference, 800);
  ASSERT_FALSE(reference.Diverged());
  std::vector<double> a, b;
  std::thread first([&] {
    World world(Load("quadruped"), options);
    a = QuadrupedTrace(world, 800);
  });
  std::thread second([&] {
    World world(Load("quadruped"), options);
    b = QuadrupedTrace(world, 800);
  });
  first.join();
  second.join();
  ExpectSameBits(a, expected);
  ExpectSameBits(b, expected);
  reference.Reset();
  ExpectSameBits(QuadrupedTrace(reference, 800), expected);
  // And it is a different solver from the exact one.
  World exact(Load("quadruped"));
  const std::vector<double> other = QuadrupedTrace(exact, 800);
  EXPECT_NE(std::memcmp(other.data(), expected.data(), other.size() * sizeof(double)), 0);
}

// A chain of n modules like configs/worlds/snake.xml (n + 1 bodies).
Morphology Chain(int n) {
  std::vector<MorphologyModule> modules;
  std::vector<MorphologyConnection> connections;
  for (int id = 0; id < n; ++id) {
    modules.push_back({.id = id});
    if (id > 0) {
      connections.push_back({.from = id,
                             .from_connector = ConnectorId::kFront,
                             .to = id - 1,
                             .to_connector = ConnectorId::kRear});
    }
  }
  return Morphology::Build(0, std::move(modules), std::move(connections),
                           Eigen::Vector3d::Zero(), "chain" + std::to_string(n));
}

TEST(WorldTest, IterativeSolverOptionsAreValidatedNamingTheValue) {
  auto rejected = [](const WorldOptions& options, const std::string& name) {
    std::string message;
    EXPECT_EQ(CodeOf([&] { World(Load("snake"), options); }, &message),
              StatusCode::kInvalidArgument)
        << name;
    EXPECT_THAT(message, HasSubstr(name));
  };
  for (double w : {0.0, -0.5, 2.0, 2.5, std::nan(""), HUGE_VAL}) {
    WorldOptions options;
    options.over_relaxation = w;
    rejected(options, "over_relaxation");
  }
  for (int n : {0, -3, 10001}) {
    WorldOptions options;
    options.iterations = n;
    rejected(options, "iterations");
  }
  WorldOptions options;
  options.auto_max_exact_bodies = -1;
  rejected(options, "auto_max_exact_bodies");
  options = WorldOptions();
  options.step_method = static_cast<StepMethod>(7);
  rejected(options, "step_method");
  // The edges of the valid ranges are accepted.
  options = WorldOptions();
  options.step_method = StepMethod::kIterative;
  options.over_relaxation = 1.99;
  options.iterations = 1;
  options.auto_max_exact_bodies = 0;
  EXPECT_NO_THROW(World(Load("snake"), options));
}

TEST(WorldTest, IterativeOrderFollowsTheSeedAndReplays) {
  WorldOptions options;
  options.step_method = StepMethod::kIterative;
  options.seed = 5;
  World a(Load("quadruped"), options);
  World b(Load("quadruped"), options);
  const std::vector<double> ta = QuadrupedTrace(a, 600);
  ExpectSameBits(QuadrupedTrace(b, 600), ta);
  a.Reset();
  ExpectSameBits(QuadrupedTrace(a, 600), ta);
  // Another seed draws another constraint order: the motion itself changes
  // (not only the sensor noise), slightly.
  options.seed = 6;
  World c(Load("quadruped"), options);
  const std::vector<double> tc = QuadrupedTrace(c, 600);
  const size_t stride = ta.size() / 600;
  double largest = 0;
  for (size_t k = 0; k < ta.size(); k += stride) largest = std::max(largest, std::fabs(ta[k] - tc[k]));
  EXPECT_GT(largest, 0.0);
  EXPECT_LT(largest, 0.01);  // m: the same gait, not another robot
}

TEST(WorldTest, OverRelaxationAndIterationsReachTheSolver) {
  WorldOptions options;
  options.step_method = StepMethod::kIterative;
  World reference(Load("quadruped"), options);
  const std::vector<double> expected = QuadrupedTrace(reference, 300);
  options.over_relaxation = 1.0;
  World sor(Load("quadruped"), options);
  EXPECT_NE(QuadrupedTrace(sor, 300), expected);
  options = WorldOptions();
  options.step_method = StepMethod::kIterative;
  options.iterations = 5;
  World few(Load("quadruped"), options);
  EXPECT_NE(QuadrupedTrace(few, 300), expected);
  // The exact solver ignores both.
  WorldOptions exact;
  exact.step_method = StepMethod::kExact;
  World e1(Load("quadruped"), exact);
  exact.over_relaxation = 1.0;
  exact.iterations = 5;
  World e2(Load("quadruped"), exact);
  ExpectSameBits(QuadrupedTrace(e2, 300), QuadrupedTrace(e1, 300));
}

TEST(WorldTest, AutoPicksTheExactSolverForSmallRobotsAndIterativeForLargeOnes) {
  WorldOptions options;
  // The default is kAuto: up to 16 bodies exact (every robot of configs/worlds,
  // the quadruped with 10, the extended quadruped with its spares), a chain of
  // 16 modules (17 bodies) and anything larger iterative.
  EXPECT_EQ(options.step_method, StepMethod::kAuto);
  EXPECT_EQ(World(Load("wheel"), options).ActiveStepMethod(), StepMethod::kExact);
  EXPECT_EQ(World(Load("tripod"), options).ActiveStepMethod(), StepMethod::kExact);
  EXPECT_EQ(World(Load("quadruped"), options).ActiveStepMethod(), StepMethod::kExact);
  EXPECT_EQ(World(Load("snake"), options).ActiveStepMethod(), StepMethod::kExact);
  World extended(Morphology::LoadFile(std::string(YAMOR_SOURCE_DIR) +
                                      "/configs/lifelong/quadruped-extended-table.xml"),
                 options);
  EXPECT_EQ(extended.ActiveStepMethod(), StepMethod::kExact) << extended.BodyCount() << " bodies";
  World largest_exact(Chain(15), options);
  EXPECT_EQ(largest_exact.BodyCount(), 16);
  EXPECT_EQ(largest_exact.ActiveStepMethod(), StepMethod::kExact);
  World smallest_iterative(Chain(16), options);
  EXPECT_EQ(smallest_iterative.BodyCount(), 17);
  EXPECT_EQ(smallest_iterative.ActiveStepMethod(), StepMethod::kIterative);
  World big(Chain(32), options);
  EXPECT_EQ(big.BodyCount(), 33);
  EXPECT_EQ(big.ActiveStepMethod(), StepMethod::kIterative);
  // So a default world of the quadruped moves bit for bit like an exact one:
  // every result measured with kExact on it (learning, lifelong) still holds.
  WorldOptions exact;
  exact.step_method = StepMethod::kExact;
  World by_default(Load("quadruped")), exactly(Load("quadruped"), exact);
  ExpectSameBits(QuadrupedTrace(by_default, 300), QuadrupedTrace(exactly, 300));
  // The threshold is the body count, inclusive.
  options.auto_max_exact_bodies = 10;
  EXPECT_EQ(World(Load("quadruped"), options).ActiveStepMethod(), StepMethod::kExact);
  options.auto_max_exact_bodies = 9;
  EXPECT_EQ(World(Load("quadruped"), options).ActiveStepMethod(), StepMethod::kIterative);
  // Explicit choices are kept whatever the size.
  options.step_method = StepMethod::kExact;
  EXPECT_EQ(World(Chain(32), options).ActiveStepMethod(), StepMethod::kExact);
  options.step_method = StepMethod::kIterative;
  EXPECT_EQ(World(Load("wheel"), options).ActiveStepMethod(), StepMethod::kIterative);
}

TEST(WorldTest, AutoChoiceStepsLikeTheChosenSolverAndFollowsReconfiguration) {
  WorldOptions options;
  options.step_method = StepMethod::kAuto;
  options.auto_max_exact_bodies = 9;  // the quadruped (10 bodies) is "large"
  World automatic(Load("quadruped"), options);
  ASSERT_EQ(automatic.ActiveStepMethod(), StepMethod::kIterative);
  options.step_method = StepMethod::kIterative;
  World iterative(Load("quadruped"), options);
  ExpectSameBits(QuadrupedTrace(automatic, 300), QuadrupedTrace(iterative, 300));
  // Putting a knee away leaves 9 bodies: the rebuilt world steps exactly.
  automatic.Disconnect(8);
  EXPECT_EQ(automatic.BodyCount(), 9);
  EXPECT_EQ(automatic.ActiveStepMethod(), StepMethod::kExact);
  automatic.Step(100);
  EXPECT_FALSE(automatic.Diverged());
  // Reset restores the initial robot and with it the iterative choice.
  automatic.Reset();
  EXPECT_EQ(automatic.ActiveStepMethod(), StepMethod::kIterative);
  iterative.Reset();
  ExpectSameBits(QuadrupedTrace(automatic, 300), QuadrupedTrace(iterative, 300));
}

TEST(WorldTest, AccelerometerAtRestReadsGravityAndFlipsUpsideDown) {
  World world(Load("snake"));
  world.Step(1000);
  const AccelerometerSpec& spec = world.options().accelerometer;
  const double g = world.options().gravity;
  auto expect_reading = [&](int id, const Eigen::Vector3d& expected) {
    for (int s = 0; s < 50; ++s) {
      world.Step();
      const AccelerometerReading r = world.Accelerometer(id);
      for (int axis = 0; axis < 3; ++axis) {
        // Quantised: a whole number of counts.
        EXPECT_NEAR(r.acceleration[axis] / spec.count_size,
                    std::round(r.acceleration[axis] / spec.count_size), 1e-9);
        // Within the noise band plus half a count (plus settling jitter).
        const double error = r.acceleration[axis] - expected[axis];
        EXPECT_GE(error, spec.noise_min[axis] - spec.count_size / 2 - 0.05) << axis;
        EXPECT_LE(error, spec.noise_max[axis] + spec.count_size / 2 + 0.05) << axis;
      }
    }
  };
  expect_reading(0, Eigen::Vector3d(0, 0, g));
  expect_reading(5, Eigen::Vector3d(0, 0, g));

  world.TurnUpsideDown();
  EXPECT_NEAR(world.LowestPoint(), world.options().drop_gap, 1e-9);
  EXPECT_LT((world.CentralOrientation() * Eigen::Vector3d::UnitZ()).z(), -0.999);
  world.Step(1000);
  ASSERT_FALSE(world.Diverged());
  expect_reading(0, Eigen::Vector3d(0, 0, -g));
  expect_reading(5, Eigen::Vector3d(0, 0, -g));
}

TEST(WorldTest, AccelerometerSeesASlope) {
  World world(Load("snake"));
  world.SetGroundFriction(2.0);  // no sliding
  world.SetSlope(0.3, 0.0);      // downhill towards +x
  EXPECT_TRUE(world.Gravity().isApprox(
      world.options().gravity * Eigen::Vector3d(std::sin(0.3), 0, -std::cos(0.3)), 1e-12));
  world.Step(1000);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (int s = 0; s < 200; ++s) {
    world.Step();
    mean += world.Accelerometer(0).acceleration / 200;
  }
  const AccelerometerSpec& spec = world.options().accelerometer;
  const Eigen::Vector3d noise_centre = (spec.noise_min + spec.noise_max) / 2;
  const Eigen::Vector3d expected =
      world.options().gravity * Eigen::Vector3d(-std::sin(0.3), 0, std::cos(0.3)) + noise_centre;
  EXPECT_LT((mean - expected).norm(), 0.1) << mean.transpose();
}

TEST(WorldTest, FrictionAndSlopeChangeAtRuntime) {
  World grippy(Load("snake"));
  grippy.SetSlope(0.2);  // tan(0.2) ≈ 0.2 < μ = 0.6: holds
  grippy.Step(1000);
  const Eigen::Vector3d start = grippy.CentralPosition();
  grippy.Step(1000);
  EXPECT_LT((grippy.CentralPosition() - start).norm(), 2e-3);

  grippy.SetGroundFriction(0.0);  // ice: slides downhill (+x)
  grippy.Step(1000);
  EXPECT_GT(grippy.CentralPosition().x() - start.x(), 0.3);
  EXPECT_FALSE(grippy.Diverged());
}

// Lifts the snake's tail with module 8, then applies `fault`.
double TailAngleAfterFault(MotorFault fault, double new_target) {
  World world(Load("snake"));
  world.SetServoTarget(8, 0.6);
  world.Step(600);
  EXPECT_NEAR(world.ServoAngle(8), 0.6, 0.01);
  world.SetMotorFault(8, fault);
  world.SetServoTarget(8, new_target);
  world.Step(800);
  EXPECT_FALSE(world.Diverged());
  return world.ServoAngle(8);
}

TEST(WorldTest, LimpMotorSwingsFreelyAndStuckMotorHolds) {
  // Limp: the lifted tail falls back to the ground whatever the set-point.
  EXPECT_NEAR(TailAngleAfterFault(MotorFault::kLimp, 0.6), 0.0, 0.05);
  // Stuck: it stays at the angle it had, whatever the set-point.
  EXPECT_NEAR(TailAngleAfterFault(MotorFault::kStuck, -0.6), 0.6, 0.01);
  // Healthy: follows the new set-point.
  EXPECT_NEAR(TailAngleAfterFault(MotorFault::kNone, -0.3), -0.3, 0.02);
}

// The driver switches a defective motor off (thesis C.2.6): a jammed gearbox
// still holds, so "stuck" is not "limp" once the power is gone.
TEST(WorldTest, StuckMotorHoldsWithoutPower) {
  World world(Load("snake"));
  world.SetServoTarget(8, 0.6);
  world.Step(600);
  world.SetMotorFault(8, MotorFault::kStuck);
  world.SetMotorEnabled(8, false);
  world.Step(800);
  EXPECT_NEAR(world.ServoAngle(8), 0.6, 0.01);
}

TEST(WorldTest, MotorOffAndModuleDefectGoLimp) {
  for (int variant = 0; variant < 2; ++variant) {
    World world(Load("snake"));
    world.SetServoTarget(8, 0.6);
    world.Step(600);
    if (variant == 0) {
      world.SetMotorEnabled(8, false);
      EXPECT_FALSE(world.MotorEnabled(8));
    } else {
      world.SetModuleDefect(8, true);
      EXPECT_TRUE(world.ModuleDefective(8));
      EXPECT_TRUE(world.MotorEnabled(8));  // the flag is separate from the SNP motor state
    }
    world.Step(800);
    EXPECT_NEAR(world.ServoAngle(8), 0.0, 0.05) << variant;
  }
}

TEST(WorldTest, DivergenceIsDetectedAndStepRefusesUntilReset) {
  World world(Load("quadruped"));
  world.Step(10);
  world.InjectNonFiniteForTesting(4);
  world.Step();
  ASSERT_TRUE(world.Diverged());
  const DivergenceInfo& info = world.Divergence();
  EXPECT_EQ(info.count, 1u);
  EXPECT_EQ(info.module_id, 4);
  EXPECT_EQ(info.step, 10u);  // found before ODE stepped the bad state
  EXPECT_FALSE(info.reason.empty());
  try {
    world.Step();
    FAIL() << "a diverged world stepped";
  } catch (const Error& error) {
    EXPECT_EQ(error.code(), StatusCode::kFailedPrecondition);
    EXPECT_THAT(error.what(), HasSubstr("diverged"));
  }
  EXPECT_EQ(world.StepCount(), 10u);
  world.Reset();
  EXPECT_FALSE(world.Diverged());
  EXPECT_EQ(world.Divergence().count, 1u);  // history survives the reset
  world.Step(100);
  EXPECT_FALSE(world.Diverged());
}

TEST(WorldTest, FailureInsideOdeIsADivergenceNotACrash) {
#if defined(__SANITIZE_ADDRESS__)
  // ODE loses track of the job it was thrown out of (80 bytes, allocated when
  // the world first steps): expected here, so not reported.
  __lsan::ScopedDisabler leak_of_the_aborted_step;
#endif
  World world(Load("quadruped"));
  world.Step(10);
  world.InjectNonFiniteForTesting(4, /*reach_ode=*/true);
  world.Step();  // ODE's own checks fail inside the step and throw out of it
  ASSERT_TRUE(world.Diverged());
  EXPECT_THAT(world.Divergence().reason, HasSubstr("ODE"));
  EXPECT_EQ(CodeOf([&] { world.Step(); }), StatusCode::kFailedPrecondition);
  world.Reset();
  world.Step(100);
  EXPECT_FALSE(world.Diverged());
  EXPECT_EQ(world.Divergence().count, 1u);
}

TEST(WorldTest, ExplodingSpeedCountsAsDivergence) {
  WorldOptions options;
  options.max_linear_speed = 0.05;  // any real motion "explodes"
  World world(Load("snake"), options);
  world.SetServoTarget(8, 1.0);
  world.Step(500);
  EXPECT_TRUE(world.Diverged());
  EXPECT_THAT(world.Divergence().reason, HasSubstr("speed"));
}

TEST(WorldTest, FreeModulesAreNotInTheWorld) {
  World world(Morphology::Parse(
      "<morphology central=\"0\"><module id=\"0\"/><module id=\"1\"/><module id=\"9\" "
      "free=\"true\"/><connect idfrom=\"1\" connfrom=\"front\" idto=\"0\" connto=\"rear\"/>"
      "</morphology>",
      "free.xml"));
  EXPECT_EQ(world.ModuleIds(), (std::vector<int>{0, 1, 9}));
  EXPECT_TRUE(world.IsConnected(1));
  EXPECT_FALSE(world.IsConnected(9));
  EXPECT_EQ(world.BodyCount(), 3);
  EXPECT_EQ(CodeOf([&] { world.ModulePose(9); }), StatusCode::kFailedPrecondition);
  EXPECT_EQ(world.ServoAngle(9), 0.0);
  world.SetServoTarget(9, 0.3);  // remembered for when it is connected
  EXPECT_DOUBLE_EQ(world.ServoTarget(9), 0.3);
  world.Step(100);
  EXPECT_FALSE(world.Diverged());
}

}  // namespace
}  // namespace yamor::physics
