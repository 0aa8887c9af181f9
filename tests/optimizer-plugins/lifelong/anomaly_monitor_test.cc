#include "optimizer-plugins/lifelong/anomaly_monitor.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "common/status.h"

namespace yamor::lifelong {
namespace {

TEST(AnomalyMonitor, TheFirstWindowInitialises) {
  AnomalyMonitor m;
  EXPECT_FALSE(m.initialised());
  const Observation o = m.Observe(0.05);
  EXPECT_EQ(o.verdict, Verdict::kInitialised);
  EXPECT_TRUE(m.initialised());
  EXPECT_DOUBLE_EQ(m.ema(), 0.05);
  EXPECT_DOUBLE_EQ(o.ema, 0.05);
  EXPECT_DOUBLE_EQ(m.Threshold(), 0.3 * 0.05);
}

TEST(AnomalyMonitor, InsideTheBandTheThesisEmaRuleApplies) {
  AnomalyMonitor m;
  m.Observe(0.05);
  const Observation o = m.Observe(0.056);  // |0.05 - 0.056| = 0.006 < 0.015
  EXPECT_EQ(o.verdict, Verdict::kNormal);
  EXPECT_DOUBLE_EQ(o.before, 0.05);
  EXPECT_DOUBLE_EQ(o.ema, 0.9 * 0.05 + 0.1 * 0.056);
  EXPECT_DOUBLE_EQ(m.ema(), o.ema);
}

TEST(AnomalyMonitor, ADropBeyondTheThresholdIsAnAnomalyAndKeepsTheExpectation) {
  AnomalyMonitor m;
  m.Observe(0.05);
  const Observation o = m.Observe(0.03);  // 0.02 >= 0.015
  EXPECT_EQ(o.verdict, Verdict::kDrop);
  EXPECT_TRUE(IsAnomaly(o.verdict));
  EXPECT_DOUBLE_EQ(o.measured, 0.03);
  EXPECT_DOUBLE_EQ(o.ema, 0.05);
  EXPECT_DOUBLE_EQ(o.threshold, 0.015);
}

TEST(AnomalyMonitor, ExactlyTheThresholdIsOutsideTheBand) {
  // The rule is |v - v+| < t; equality is an anomaly. Absolute threshold so
  // the numbers are exact in binary.
  AnomalyMonitor m({.threshold = 0.25, .relative = false});
  m.Observe(1.0);
  EXPECT_EQ(m.Observe(0.75).verdict, Verdict::kDrop);
}

TEST(AnomalyMonitor, AnIncreaseIsReportedNotAnAnomalyAndBecomesTheExpectation) {
  AnomalyMonitor m;
  m.Observe(0.05);
  const Observation o = m.Observe(0.08);
  EXPECT_EQ(o.verdict, Verdict::kIncrease);
  EXPECT_FALSE(IsAnomaly(o.verdict));
  EXPECT_DOUBLE_EQ(m.ema(), 0.08);
  // Falling back to the old level is now a drop.
  EXPECT_EQ(m.Observe(0.05).verdict, Verdict::kDrop);
}

TEST(AnomalyMonitor, AnIncreaseIsAnAnomalyWhenConfigured) {
  AnomalyMonitor m({.increase_is_anomaly = true});
  m.Observe(0.05);
  const Observation o = m.Observe(0.08);
  EXPECT_EQ(o.verdict, Verdict::kIncreaseAnomaly);
  EXPECT_TRUE(IsAnomaly(o.verdict));
  EXPECT_DOUBLE_EQ(m.ema(), 0.05);
}

TEST(AnomalyMonitor, AnAbsoluteThresholdDoesNotScaleWithTheVelocity) {
  AnomalyMonitor m({.threshold = 0.01, .relative = false});
  m.Observe(0.2);
  EXPECT_DOUBLE_EQ(m.Threshold(), 0.01);
  EXPECT_EQ(m.Observe(0.195).verdict, Verdict::kNormal);
  EXPECT_EQ(m.Observe(0.18).verdict, Verdict::kDrop);
}

TEST(AnomalyMonitor, ARelativeThresholdHasAFloorForARobotThatBarelyMoves) {
  AnomalyMonitor m({.threshold = 0.3, .min_reference = 0.01});
  m.Observe(0.0001);
  EXPECT_DOUBLE_EQ(m.Threshold(), 0.003);
  EXPECT_EQ(m.Observe(0.002).verdict, Verdict::kNormal);
  EXPECT_EQ(m.Observe(-0.004).verdict, Verdict::kDrop);
}

TEST(AnomalyMonitor, ConfirmationsNeedConsecutiveWindowsOnTheSameSide) {
  AnomalyMonitor m({.confirmations = 2});
  m.Observe(0.05);
  EXPECT_EQ(m.Observe(0.02).verdict, Verdict::kSuspect);
  EXPECT_DOUBLE_EQ(m.ema(), 0.05);                      // not updated while suspect
  EXPECT_EQ(m.Observe(0.05).verdict, Verdict::kNormal);  // an outlier only
  EXPECT_EQ(m.Observe(0.02).verdict, Verdict::kSuspect);
  EXPECT_EQ(m.Observe(0.09).verdict, Verdict::kSuspect);  // the other side starts over
  EXPECT_EQ(m.Observe(0.02).verdict, Verdict::kSuspect);
  EXPECT_EQ(m.Observe(0.02).verdict, Verdict::kDrop);
}

TEST(AnomalyMonitor, PhysicalChangeEventsAreAnomaliesAtOnce) {
  AnomalyMonitor m;
  // Even before any window.
  Observation o = m.OnEvent("module_disconnected");
  EXPECT_EQ(o.verdict, Verdict::kPhysicalChange);
  EXPECT_EQ(o.event, "module_disconnected");
  m.Observe(0.05);
  for (const char* kind : {"module_connected", "defect_set", "defect_cleared"}) {
    EXPECT_EQ(m.OnEvent(kind).verdict, Verdict::kPhysicalChange) << kind;
  }
  // Other events are not physical changes (a slippery ground shows in the velocity).
  for (const char* kind : {"ground_changed", "config_loaded", "turned_upside_down", "reset"}) {
    EXPECT_EQ(m.OnEvent(kind).verdict, Verdict::kNormal) << kind;
  }
  EXPECT_DOUBLE_EQ(m.ema(), 0.05);
}

TEST(AnomalyMonitor, ThePhysicalEventKindsAreConfigurable) {
  AnomalyMonitor m({.physical_events = {"ground_changed"}});
  EXPECT_EQ(m.OnEvent("ground_changed").verdict, Verdict::kPhysicalChange);
  EXPECT_EQ(m.OnEvent("module_connected").verdict, Verdict::kNormal);
}

TEST(AnomalyMonitor, ResetAndSeed) {
  AnomalyMonitor m;
  m.Observe(0.05);
  m.Reset();
  EXPECT_FALSE(m.initialised());
  EXPECT_EQ(m.Observe(0.01).verdict, Verdict::kInitialised);
  m.Seed(0.04);
  EXPECT_TRUE(m.initialised());
  EXPECT_EQ(m.Observe(0.041).verdict, Verdict::kNormal);
  EXPECT_EQ(m.Observe(0.01).verdict, Verdict::kDrop);
}

TEST(AnomalyMonitor, BadInputIsRefused) {
  AnomalyMonitor m;
  EXPECT_THROW(m.Observe(std::numeric_limits<double>::quiet_NaN()), Error);
  EXPECT_THROW(m.Observe(std::numeric_limits<double>::infinity()), Error);
  EXPECT_THROW(m.Seed(std::numeric_limits<double>::quiet_NaN()), Error);
  EXPECT_FALSE(m.initialised());
  for (const AnomalyOptions& bad :
       {AnomalyOptions{.threshold = 0}, AnomalyOptions{.threshold = -1},
        AnomalyOptions{.threshold = std::numeric_limits<double>::infinity()},
        AnomalyOptions{.min_reference = -0.1}, AnomalyOptions{.smoothing = 1},
        AnomalyOptions{.smoothing = -0.1}, AnomalyOptions{.confirmations = 0}}) {
    try {
      AnomalyMonitor refused(bad);
      ADD_FAILURE() << "accepted";
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), StatusCode::kInvalidArgument);
    }
  }
}

// A gait's window velocities: 5 cm/s with seeded Gaussian noise of the given
// relative standard deviation.
std::vector<double> Noisy(double mean, double relative_sd, int n, unsigned seed) {
  std::mt19937 random(seed);
  std::normal_distribution<double> noise(0.0, relative_sd * mean);
  std::vector<double> out;
  for (int i = 0; i < n; ++i) out.push_back(mean + noise(random));
  return out;
}

TEST(AnomalyMonitor, NoFalseAlarmOnNoisyUndisturbedWalking) {
  // 5 % noise per window is about 6 standard deviations inside the default
  // 30 % band: no alarm in 10 seeds of 1000 windows.
  for (unsigned seed = 1; seed <= 10; ++seed) {
    AnomalyMonitor m;
    for (double v : Noisy(0.05, 0.05, 1000, seed)) {
      const Observation o = m.Observe(v);
      ASSERT_FALSE(IsAnomaly(o.verdict)) << "seed " << seed << " v " << v << " ema " << o.before;
      ASSERT_NE(o.verdict, Verdict::kIncrease) << "seed " << seed;
    }
    EXPECT_NEAR(m.ema(), 0.05, 0.005);
  }
}

TEST(AnomalyMonitor, ASuddenHalvingIsDetectedInTheFirstWindowAfterIt) {
  for (unsigned seed = 1; seed <= 10; ++seed) {
    AnomalyMonitor m;
    std::vector<double> series = Noisy(0.05, 0.05, 30, seed);
    const std::vector<double> after = Noisy(0.025, 0.05, 5, seed + 100);
    series.insert(series.end(), after.begin(), after.end());
    int detected = -1;
    for (int i = 0; i < static_cast<int>(series.size()); ++i) {
      if (m.Observe(series[i]).verdict == Verdict::kDrop) {
        detected = i;
        break;
      }
    }
    EXPECT_EQ(detected, 30) << "seed " << seed;
  }
}

TEST(AnomalyMonitor, ASlowDriftIsFollowedNotAlarmed) {
  // The thesis's point of the EMA: small variations along the robot's life.
  AnomalyMonitor m;
  double v = 0.05;
  for (int i = 0; i < 200; ++i, v *= 0.995) {
    ASSERT_FALSE(IsAnomaly(m.Observe(v).verdict)) << "window " << i;
  }
  EXPECT_LT(m.ema(), 0.025);
}

}  // namespace
}  // namespace yamor::lifelong
