#include "optimizer-plugins/lifelong/anomaly_monitor.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "common/status.h"

namespace yamor::lifelong {
namespace {

// The thesis's rule exactly: no noise floor, the first window initialises,
// one window beyond the band either way is a change.
AnomalyOptions Thesis() { return AnomalyOptions{.noise_factor = 0, .increase_confirmations = 1}; }

TEST(AnomalyMonitor, TheFirstWindowInitialises) {
  AnomalyMonitor m(Thesis());
  EXPECT_FALSE(m.initialised());
  const Observation o = m.Observe(0.05);
  EXPECT_EQ(o.verdict, Verdict::kInitialised);
  EXPECT_TRUE(m.initialised());
  EXPECT_DOUBLE_EQ(m.ema(), 0.05);
  EXPECT_DOUBLE_EQ(o.ema, 0.05);
  EXPECT_DOUBLE_EQ(m.Threshold(), 0.3 * 0.05);
}

TEST(AnomalyMonitor, InsideTheBandTheThesisEmaRuleApplies) {
  AnomalyMonitor m(Thesis());
  m.Observe(0.05);
  const Observation o = m.Observe(0.056);  // |0.05 - 0.056| = 0.006 < 0.015
  EXPECT_EQ(o.verdict, Verdict::kNormal);
  EXPECT_DOUBLE_EQ(o.before, 0.05);
  EXPECT_DOUBLE_EQ(o.ema, 0.9 * 0.05 + 0.1 * 0.056);
  EXPECT_DOUBLE_EQ(m.ema(), o.ema);
}

TEST(AnomalyMonitor, ADropBeyondTheThresholdIsAnAnomalyAndKeepsTheExpectation) {
  AnomalyMonitor m(Thesis());
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
  AnomalyMonitor m({.threshold = 0.25, .relative = false, .noise_factor = 0});
  m.Observe(1.0);
  EXPECT_EQ(m.Observe(0.75).verdict, Verdict::kDrop);
}

TEST(AnomalyMonitor, AnIncreaseIsReportedNotAnAnomalyAndBecomesTheExpectation) {
  AnomalyMonitor m(Thesis());
  m.Observe(0.05);
  const Observation o = m.Observe(0.08);
  EXPECT_EQ(o.verdict, Verdict::kIncrease);
  EXPECT_FALSE(IsAnomaly(o.verdict));
  EXPECT_DOUBLE_EQ(m.ema(), 0.08);
  // Falling back to the old level is now a drop.
  EXPECT_EQ(m.Observe(0.05).verdict, Verdict::kDrop);
}

TEST(AnomalyMonitor, AnIncreaseIsAnAnomalyWhenConfigured) {
  AnomalyMonitor m({.increase_is_anomaly = true, .noise_factor = 0});
  m.Observe(0.05);
  EXPECT_EQ(m.Observe(0.08).verdict, Verdict::kSuspect);  // by default a rise must last two windows
  const Observation o = m.Observe(0.08);
  EXPECT_EQ(o.verdict, Verdict::kIncreaseAnomaly);
  EXPECT_TRUE(IsAnomaly(o.verdict));
  EXPECT_DOUBLE_EQ(m.ema(), 0.05);
}

TEST(AnomalyMonitor, ASingleFastWindowIsNotTheNewLevel) {
  AnomalyMonitor m({.noise_factor = 0});
  m.Observe(0.05);
  EXPECT_EQ(m.Observe(0.09).verdict, Verdict::kSuspect);
  EXPECT_DOUBLE_EQ(m.ema(), 0.05);
  EXPECT_EQ(m.Observe(0.05).verdict, Verdict::kNormal);  // no drop after the outlier
  EXPECT_EQ(m.Observe(0.09).verdict, Verdict::kSuspect);
  EXPECT_EQ(m.Observe(0.09).verdict, Verdict::kIncrease);
  EXPECT_DOUBLE_EQ(m.ema(), 0.09);
}

TEST(AnomalyMonitor, AnAbsoluteThresholdDoesNotScaleWithTheVelocity) {
  AnomalyMonitor m({.threshold = 0.01, .relative = false, .noise_factor = 0});
  m.Observe(0.2);
  EXPECT_DOUBLE_EQ(m.Threshold(), 0.01);
  EXPECT_EQ(m.Observe(0.195).verdict, Verdict::kNormal);
  EXPECT_EQ(m.Observe(0.18).verdict, Verdict::kDrop);
}

TEST(AnomalyMonitor, ARelativeThresholdHasAFloorForARobotThatBarelyMoves) {
  AnomalyMonitor m({.threshold = 0.3, .min_reference = 0.01, .noise_factor = 0});
  m.Observe(0.0001);
  EXPECT_DOUBLE_EQ(m.Threshold(), 0.003);
  EXPECT_EQ(m.Observe(0.002).verdict, Verdict::kNormal);
  EXPECT_EQ(m.Observe(-0.004).verdict, Verdict::kDrop);
}

TEST(AnomalyMonitor, ConfirmationsNeedConsecutiveWindowsOnTheSameSide) {
  AnomalyMonitor m({.noise_factor = 0, .confirmations = 2});
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
  AnomalyMonitor m(Thesis());
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
  AnomalyMonitor m(Thesis());
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
  AnomalyMonitor m(Thesis());
  EXPECT_THROW(m.Observe(std::numeric_limits<double>::quiet_NaN()), Error);
  EXPECT_THROW(m.Observe(std::numeric_limits<double>::infinity()), Error);
  EXPECT_THROW(m.Seed(std::numeric_limits<double>::quiet_NaN()), Error);
  EXPECT_FALSE(m.initialised());
  for (const AnomalyOptions& bad :
       {AnomalyOptions{.threshold = 0}, AnomalyOptions{.threshold = -1},
        AnomalyOptions{.threshold = std::numeric_limits<double>::infinity()},
        AnomalyOptions{.min_reference = -0.1}, AnomalyOptions{.smoothing = 1},
        AnomalyOptions{.smoothing = -0.1}, AnomalyOptions{.noise_factor = -1},
        AnomalyOptions{.learn_windows = 0}, AnomalyOptions{.confirmations = 0},
        AnomalyOptions{.increase_confirmations = 0}}) {
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
    AnomalyMonitor m(Thesis());
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
    AnomalyMonitor m(Thesis());
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
  AnomalyMonitor m(Thesis());
  double v = 0.05;
  for (int i = 0; i < 200; ++i, v *= 0.995) {
    ASSERT_FALSE(IsAnomaly(m.Observe(v).verdict)) << "window " << i;
  }
  EXPECT_LT(m.ema(), 0.025);
}

TEST(AnomalyMonitor, ByDefaultTheFirstWindowsLearnTheLevelAndTheNoise) {
  AnomalyMonitor m;  // noise_factor 3, learn_windows 4
  EXPECT_EQ(m.Observe(0.10).verdict, Verdict::kInitialised);
  EXPECT_EQ(m.Observe(0.02).verdict, Verdict::kLearning);  // no alarm while learning
  EXPECT_EQ(m.Observe(0.12).verdict, Verdict::kLearning);
  EXPECT_EQ(m.Observe(0.04).verdict, Verdict::kLearning);
  EXPECT_NEAR(m.ema(), 0.07, 1e-12);  // the mean of the four
  // |deviation| from the running mean before each window: 0.08, 0.06, 0.04.
  EXPECT_NEAR(m.noise(), 0.06, 1e-12);
  EXPECT_NEAR(m.Threshold(), 3 * m.noise(), 1e-12);
  EXPECT_EQ(m.Observe(0.03).verdict, Verdict::kNormal);  // inside 3 d, though > 30 % off
  EXPECT_EQ(m.Observe(-0.15).verdict, Verdict::kDrop);
}

TEST(AnomalyMonitor, ASteadyGaitKeepsTheRelativeThreshold) {
  AnomalyMonitor m;
  for (double v : {0.080, 0.082, 0.079, 0.081}) m.Observe(v);
  EXPECT_NEAR(m.Threshold(), 0.3 * 0.0805, 1e-9);
  EXPECT_EQ(m.Observe(0.05).verdict, Verdict::kDrop);
}

TEST(AnomalyMonitor, AnErraticGaitRaisesNoFalseAlarm) {
  // Window velocities like the configured wheel's (cm/s), over and over.
  const std::vector<double> wheel = {13.19, 4.22, 16.35, 4.34, 9.79, 17.60, 12.72, 14.49, 11.96, 21.61,
                                     3.97, 21.15, 20.28, 21.90, 13.69, 4.47, 5.94, 20.47, 13.43, 13.51,
                                     12.80, 13.95, 21.38, 1.24, 10.81, 20.30, 5.04, 15.21, 3.73, 13.27};
  AnomalyMonitor m;
  for (int round = 0; round < 10; ++round) {
    for (double v : wheel) ASSERT_FALSE(IsAnomaly(m.Observe(v / 100).verdict)) << round << " " << v;
  }
  // The thesis's rule alone alarms at once.
  AnomalyMonitor thesis(Thesis());
  thesis.Observe(wheel[0] / 100);
  EXPECT_TRUE(IsAnomaly(thesis.Observe(wheel[1] / 100).verdict));
}

}  // namespace
}  // namespace yamor::lifelong
