#include "physics/orientation.h"

#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/status.h"
#include "physics/driven_module.h"

namespace yamor::physics {
namespace {

constexpr double kRate = 6400;

std::vector<DrivenSample> Drive(const MotionPath& path, std::uint64_t seed) {
  DrivenModuleOptions options;
  options.sample_rate = kRate;
  options.seed = seed;
  return DrivenModule(path, options).Run();
}

OrientationOptions Window(int samples) {
  OrientationOptions o;
  o.window = samples;
  return o;
}

TEST(OrientationTest, UprightAndTiltedAtRest) {
  OrientationEstimator estimator(Window(4));
  for (int i = 0; i < 3; ++i) EXPECT_FALSE(estimator.Add({0, 0, 9.81}).valid);
  const OrientationEstimate& e = estimator.Add({0, 0, 9.81});
  EXPECT_TRUE(e.valid);
  EXPECT_NEAR(e.tilt, 0, 1e-12);
  EXPECT_FALSE(e.upside_down);
  // Tilted by 30° about x: gravity leans towards +y in the module frame.
  const double a = M_PI / 6;
  for (int i = 0; i < 4; ++i) estimator.Add({0, 9.81 * std::sin(a), 9.81 * std::cos(a)});
  EXPECT_NEAR(estimator.estimate().tilt, a, 1e-12);
  // Strong acceleration: the mean no longer looks like gravity alone.
  for (int i = 0; i < 4; ++i) estimator.Add({8, 0, 9.81});
  EXPECT_FALSE(estimator.estimate().valid);
}

TEST(OrientationTest, HysteresisBetweenEnterAndLeave) {
  OrientationEstimator estimator(Window(1));
  auto at = [&](double tilt) { return estimator.Add({0, 9.81 * std::sin(tilt), 9.81 * std::cos(tilt)}); };
  EXPECT_FALSE(at(M_PI * 0.6).upside_down);  // 108°: not yet
  EXPECT_TRUE(at(M_PI * 0.7).upside_down);   // 126°
  EXPECT_TRUE(at(M_PI * 0.4).upside_down);   // 72°: still
  EXPECT_FALSE(at(M_PI * 0.3).upside_down);  // 54°: upright again
}

TEST(OrientationTest, FlipOfTheDrivenModuleIsDetectedAfterTheTurn) {
  const MotionPath flip = FlipMove();  // turn over t ∈ [1.5, 2.5] s, set down at 3 s
  const int window = static_cast<int>(kRate * 0.25);
  OrientationEstimator estimator(Window(window));
  double detected = -1;
  for (const DrivenSample& s : Drive(flip, 21)) {
    const OrientationEstimate& e = estimator.Add(s.reading.acceleration);
    if (s.time < 1.5) {
      EXPECT_FALSE(e.upside_down) << s.time;
    }
    if (e.upside_down && detected < 0) detected = s.time;
  }
  ASSERT_GT(detected, 0) << "flip never detected";
  EXPECT_GT(detected, 1.9);  // not before the module turned past 120°
  EXPECT_LT(detected, 3.0 + 0.25);  // at the latest one window after it is set down
  EXPECT_TRUE(estimator.estimate().upside_down);
  EXPECT_NEAR(estimator.estimate().tilt, M_PI, 0.05);
}

TEST(OrientationTest, NoFalseDetectionOnTheSineMoveOrTheRandomMove) {
  for (const MotionPath& path : {SineMove(), CircleMove(), RandomAirMove(2)}) {
    OrientationEstimator estimator(Window(static_cast<int>(kRate * 0.25)));
    MotionMonitor monitor;
    for (const DrivenSample& s : Drive(path, 8)) {
      EXPECT_FALSE(estimator.Add(s.reading.acceleration).upside_down) << path.name() << " " << s.time;
      monitor.Add(s.reading.acceleration);
    }
    EXPECT_EQ(monitor.impacts(), 0) << path.name();
  }
}

TEST(MotionMonitorTest, TheDropIsOneImpactAndMovingIsSeen) {
  MotionMonitor monitor;
  const std::vector<DrivenSample> samples = Drive(DropMove(), 3);
  const double fall = std::sqrt(2 * 0.07 / 9.81);
  bool moving_while_at_rest = false, moving_in_the_fall = false;
  for (const DrivenSample& s : samples) {
    if (monitor.Add(s.reading.acceleration)) {
      EXPECT_NEAR(s.time, 1.0 + fall, 0.005) << "impact at the contact";
    }
    if (s.time > 0.1 && s.time < 0.95) moving_while_at_rest |= monitor.moving();
    if (s.time > 1.05 && s.time < 1.0 + fall) moving_in_the_fall |= monitor.moving();
  }
  EXPECT_EQ(monitor.impacts(), 1);
  EXPECT_FALSE(moving_while_at_rest);
  EXPECT_TRUE(moving_in_the_fall);
  EXPECT_FALSE(monitor.moving()) << "at rest after the drop";
}

TEST(MotionMonitorTest, SineMoveIsMovingInTheMiddleOnly) {
  MotionMonitor monitor;
  int moving_mid = 0, mid = 0;
  for (const DrivenSample& s : Drive(SineMove(), 4)) {
    monitor.Add(s.reading.acceleration);
    if (s.time > 1.3 && s.time < 2.7) {
      ++mid;
      moving_mid += monitor.moving();
    }
    if (s.time < 0.95 || s.time > 3.2) {
      EXPECT_FALSE(monitor.moving()) << s.time;
    }
  }
  EXPECT_GT(moving_mid, mid / 2);
}

TEST(MotionMonitorTest, BadOptionsAreRejected) {
  MotionMonitorOptions m;
  m.moving_blocks = 1;
  EXPECT_THROW(MotionMonitor monitor(m), Error);
  OrientationOptions o;
  o.upside_down_enter = 0.5;  // below leave
  try {
    OrientationEstimator estimator(o);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kInvalidArgument);
    EXPECT_NE(std::string(e.what()).find("0.5"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace yamor::physics
