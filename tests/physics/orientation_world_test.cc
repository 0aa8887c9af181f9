// The orientation estimator on simulated robots (physics::World): a gait-like
// oscillation of every servo gives no false "upside down"; after
// TurnUpsideDown() the central module's detector flips within one period.
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "physics/orientation.h"
#include "physics/world.h"

namespace yamor::physics {
namespace {

const std::string kWorlds = std::string(YAMOR_SOURCE_DIR) + "/configs/worlds/";

constexpr double kPeriod = 1.0;  // s, the oscillation ("CPG") period and the low-pass window

// Sets every servo to a sine of one period, phase shifted by module id.
void Oscillate(World& world, double amplitude) {
  const double t = world.Time();
  for (int id : world.ModuleIds()) {
    if (!world.IsConnected(id)) continue;
    world.SetServoTarget(id, amplitude * std::sin(2 * M_PI * t / kPeriod + 0.7 * id));
  }
}

class OrientationWorldTest : public ::testing::TestWithParam<std::string> {};

TEST_P(OrientationWorldTest, WalkingIsNotUpsideDownAndAFlipIsSeenWithinOnePeriod) {
  World world(Morphology::LoadFile(kWorlds + GetParam() + ".xml"));
  const int central = world.CentralModule();
  const double dt = world.options().time_step;
  const int window = static_cast<int>(std::lround(kPeriod / dt));
  // The central module's "up" is what it reads at rest (its body z need not be vertical).
  world.Step(250);
  Eigen::Vector3d rest = Eigen::Vector3d::Zero();
  for (int i = 0; i < 250; ++i) {
    world.Step();
    rest += world.Accelerometer(central).acceleration;
  }
  OrientationOptions options;
  options.window = window;
  options.up_axis = rest.normalized();
  OrientationEstimator estimator(options);
  int valid = 0;
  const int walk_steps = static_cast<int>(6 * kPeriod / dt);
  for (int i = 0; i < walk_steps; ++i) {
    Oscillate(world, 0.6);
    world.Step();
    ASSERT_FALSE(world.Diverged()) << GetParam();
    const OrientationEstimate& e = estimator.Add(world.Accelerometer(central).acceleration);
    ASSERT_FALSE(e.upside_down) << GetParam() << " at " << world.Time() << " s, tilt " << e.tilt;
    valid += e.valid;
  }
  // After the first window, the low-pass should see gravity most of the time.
  EXPECT_GT(valid, (walk_steps - window) / 2) << GetParam();
  world.TurnUpsideDown();
  const double flipped_at = world.Time();
  double detected = -1;
  for (int i = 0; i < walk_steps && detected < 0; ++i) {
    Oscillate(world, 0.6);
    world.Step();
    ASSERT_FALSE(world.Diverged()) << GetParam();
    if (estimator.Add(world.Accelerometer(central).acceleration).upside_down) detected = world.Time();
  }
  ASSERT_GT(detected, 0) << GetParam() << ": flip never detected";
  EXPECT_LE(detected - flipped_at, kPeriod + 1e-9) << GetParam();
}

INSTANTIATE_TEST_SUITE_P(Robots, OrientationWorldTest,
                         ::testing::Values("quadruped", "snake", "tripod", "dog", "wheel",
                                           "trebuchet"));

}  // namespace
}  // namespace yamor::physics
