// GetOrientation (issue 16 §3): a module's orientation from its accelerometer
// samples, on every built-in robot walking in the in-process simulation.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <string>

#include "common/status.h"
#include "host/builtin_robots.h"
#include "host/driver.h"
#include "host/worlds.h"
#include "tests/support/code_of.h"

namespace yamor::host {
namespace {

using snp::Tristate;
using ::yamor::testing::CodeOf;

// Walking time per robot [s of robot time]; YAMOR_ORIENTATION_WALK overrides
// it (the 10-minute run: YAMOR_ORIENTATION_WALK=600).
double WalkSeconds() {
  const char* text = std::getenv("YAMOR_ORIENTATION_WALK");
  return text != nullptr ? std::atof(text) : 60.0;
}

struct Walker {
  explicit Walker(const std::string& name)
      : world(ResolveWorld(WorldRequest{.world = name}, kDefaultWorld, false)),
        driver({}, *world.config) {
    const OpenedSimulation opened = driver.OpenSimulation(SimulationSpec{
        .morphology = world.morphology, .world_name = world.name, .config = world.config});
    central = opened.central_module;
    driver.ConnectRobot(0.0, false, nullptr);
    driver.SendControlMessage(
        ControlMessage{Tristate::kOn, Tristate::kOn, Tristate::kOn, {}, true});
  }
  ResolvedWorld world;
  RobotDriver driver;
  int central = 0;
};

class OrientationTest : public ::testing::TestWithParam<std::string> {};

// No false "upside down" while a robot walks, and a flip is seen within one
// CPG period (the slowest oscillator's).
TEST_P(OrientationTest, WalkingIsUprightAndAFlipIsSeenWithinAPeriod) {
  Walker w(GetParam());
  double period = 0;
  for (const cpg::ModuleParams& m : w.world.config->modules) {
    if (m.speed > 0) period = std::max(period, 1.0 / m.speed);
  }
  ASSERT_GT(period, 0.0);
  w.driver.Sleep(0.5, false, nullptr);
  // The upright reference: the central module's up as the robot stands.
  const ModuleOrientation start = w.driver.GetOrientation(w.central, 0, {0, 0, 0});
  ASSERT_TRUE(start.valid) << "at rest: |mean| " << start.magnitude;
  EXPECT_EQ(start.samples, 16);
  EXPECT_NEAR(start.magnitude, 9.81, 1.0);
  const std::array<double, 3> reference = start.up;

  int readings = 0, valid = 0, upside_down = 0;
  double max_tilt = 0;
  for (double t = 0.5; t < WalkSeconds(); t += 0.25) {
    w.driver.Sleep(0.25, false, nullptr);
    const ModuleOrientation o = w.driver.GetOrientation(w.central, 0, reference);
    ++readings;
    if (!o.valid) continue;
    ++valid;
    max_tilt = std::max(max_tilt, o.tilt);
    if (o.upside_down) ++upside_down;
  }
  EXPECT_EQ(upside_down, 0) << GetParam() << ": largest tilt " << max_tilt;
  EXPECT_GT(valid, readings / 2) << GetParam() << ": too few readings looked like gravity";
  std::printf("[ %s ] %d readings, %d valid, largest tilt %.1f deg\n", GetParam().c_str(),
              readings, valid, max_tilt * 180 / M_PI);

  w.driver.TurnUpsideDown();
  double seen_after = -1;
  for (double t = 0; t <= period + 1e-9; t += 0.05) {
    if (t > 0) w.driver.Sleep(0.05, false, nullptr);
    const ModuleOrientation o = w.driver.GetOrientation(w.central, 0, reference);
    if (o.upside_down) {
      seen_after = t;
      break;
    }
  }
  EXPECT_GE(seen_after, 0.0) << GetParam() << ": flip not seen within one period (" << period
                             << " s)";
}

// The wheel is left out on purpose: it rolls, so every module, the central
// one included, really turns over each revolution (see the test below).
INSTANTIATE_TEST_SUITE_P(BuiltinRobots, OrientationTest,
                         ::testing::Values("quadruped", "snake", "dog", "tripod", "trebuchet"),
                         [](const auto& info) { return info.param; });

// A rolling wheel's central module does turn over: the readings say so.
TEST(OrientationApiTest, TheRollingWheelTurnsOver) {
  Walker w("wheel");
  int upside_down = 0, upright = 0;
  for (double t = 0; t < 20; t += 0.05) {
    w.driver.Sleep(0.05, false, nullptr);
    const ModuleOrientation o = w.driver.GetOrientation(w.central, 0, {0, 0, 0});
    if (!o.valid) continue;
    (o.upside_down ? upside_down : upright) += 1;
  }
  EXPECT_GT(upside_down, 0);
  EXPECT_GT(upright, 0);
}

TEST(OrientationApiTest, BadRequestsNameTheValue) {
  Walker w("quadruped");
  std::string message;
  EXPECT_EQ(CodeOf([&] { w.driver.GetOrientation(w.central, 17, {0, 0, 0}); }, &message),
            StatusCode::kOutOfRange);
  EXPECT_NE(message.find("17"), std::string::npos) << message;
  EXPECT_EQ(CodeOf([&] { w.driver.GetOrientation(99, 0, {0, 0, 0}); }, &message),
            StatusCode::kNotFound);
  EXPECT_NE(message.find("99"), std::string::npos) << message;
  EXPECT_EQ(CodeOf([&] { w.driver.GetOrientation(w.central, 0, {NAN, 0, 1}); }, &message),
            StatusCode::kInvalidArgument);
  EXPECT_NE(message.find("reference_up"), std::string::npos) << message;
  // With the sensor boards' UART off there is nothing to read.
  w.driver.SendControlMessage(ControlMessage{Tristate::kOff, Tristate::kUnchanged,
                                             Tristate::kUnchanged, {}, true});
  EXPECT_EQ(CodeOf([&] { w.driver.GetOrientation(w.central, 0, {0, 0, 0}); }, &message),
            StatusCode::kFailedPrecondition);
  EXPECT_NE(message.find("UART"), std::string::npos) << message;
}

// A robot whose central module lies on its back reads "upside down" against
// +z; with the upright reference the same reading is upright.
TEST(OrientationApiTest, TiltIsAgainstTheReference) {
  Walker w("quadruped");
  w.driver.Sleep(0.5, false, nullptr);
  const ModuleOrientation o = w.driver.GetOrientation(w.central, 0, {0, 0, 0});
  ASSERT_TRUE(o.valid);
  const ModuleOrientation flipped =
      w.driver.GetOrientation(w.central, 0, {-o.up[0], -o.up[1], -o.up[2]});
  EXPECT_NEAR(flipped.tilt, M_PI, 1e-6);
  EXPECT_TRUE(flipped.upside_down);
  const ModuleOrientation same = w.driver.GetOrientation(w.central, 0, o.up);
  EXPECT_NEAR(same.tilt, 0.0, 1e-6);
  EXPECT_FALSE(same.upside_down);
}

}  // namespace
}  // namespace yamor::host
