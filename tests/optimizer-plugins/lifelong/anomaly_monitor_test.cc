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
        AnomalyOptions{.noisy_confirmations = 0},
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
  // The noise sets the band: a drop must last two windows.
  EXPECT_EQ(m.Observe(-0.15).verdict, Verdict::kSuspect);
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

// 30 minutes of robot time of the configured wheel walking undisturbed
// (yamord + `yamor-lifelong --config configs/robots/wheel.xml --max-time 1800`,
// world seed 1): its 355 three-period windows [cm/s]. A one-window
// drop rule alarmed on three single dips of this series (the benchmark's
// false alarms); none of them lasts two windows.
const std::vector<double> kWheelHalfHour = {
    13.188, 4.217, 16.345, 4.340, 9.785, 17.599, 12.718, 14.493, 11.964, 21.613, 3.968, 21.153, 20.284,
    21.899, 13.686, 4.465, 5.939, 20.475, 13.432, 13.513, 12.800, 13.954, 21.380, 1.244, 10.812, 20.299,
    5.042, 15.207, 3.730, 13.267, 7.350, 13.685, 21.447, 21.043, 12.929, 7.612, 23.221, 12.932, 13.024,
    5.405, 13.944, 4.894, 20.954, 14.114, 21.505, 4.705, 5.664, 5.907, 13.297, 21.389, 19.575, 6.923, 7.792,
    11.840, 13.119, 6.468, 20.344, 5.954, 22.374, 4.631, 15.074, 4.121, 20.614, 14.512, 6.252, 21.765,
    6.347, 13.562, 13.011, 15.060, 4.613, 5.723, 13.145, 13.797, 9.866, 11.746, 7.898, 19.345, 3.643,
    16.748, 9.896, 20.681, 14.189, 19.969, 3.110, 13.060, 13.830, 6.016, 21.245, 6.905, 21.750, 6.365,
    19.896, 21.963, 4.503, 21.040, 12.810, 14.301, 20.559, 13.991, 22.161, 14.667, 20.340, 20.858, 20.628,
    22.588, 4.152, 13.151, 12.637, 13.313, 22.905, 3.885, 21.400, 0.937, 17.059, 5.526, 21.807, 7.241,
    19.357, 5.074, 22.527, 12.941, 6.643, 19.719, 19.911, 1.263, 21.281, 12.788, 5.451, 21.311, 23.795,
    11.490, 15.574, 4.106, 21.566, 11.871, 20.840, 5.513, 20.957, 12.870, 9.532, 17.331, 6.094, 21.174,
    5.388, 20.938, 6.742, 21.798, 6.863, 20.357, 5.320, 14.923, 10.834, 13.655, 6.552, 22.137, 19.073,
    20.250, 14.444, 17.177, 9.658, 16.841, 9.263, 14.772, 16.021, 14.386, 1.914, 16.604, 4.516, 21.661,
    4.303, 22.243, 4.593, 12.970, 2.084, 13.521, 6.942, 5.007, 20.983, 21.668, 20.898, 13.477, 19.391,
    6.833, 20.681, 6.362, 12.571, 20.697, 1.470, 14.419, 12.652, 22.550, 3.722, 12.992, 14.097, 7.457,
    19.787, 22.115, 12.785, 21.583, 20.140, 6.579, 5.402, 0.467, 15.655, 8.452, 23.369, 13.694, 12.740,
    13.695, 13.668, 12.708, 22.176, 4.456, 13.240, 19.010, 8.050, 13.386, 16.686, 18.051, 12.275, 6.463,
    12.741, 14.277, 22.728, 19.656, 22.258, 0.360, 17.004, 15.170, 6.213, 4.904, 21.661, 4.802, 14.008,
    1.478, 21.966, 12.618, 20.107, 22.233, 4.551, 20.324, 21.095, 5.842, 20.712, 4.818, 15.925, 11.526,
    15.696, 15.987, 17.475, 5.252, 1.714, 18.314, 22.568, 3.934, 14.033, 17.178, 3.394, 20.428, 21.757,
    12.180, 20.332, 21.990, 4.666, 20.385, 10.105, 18.810, 13.948, 19.842, 6.361, 21.373, 20.608, 14.540,
    19.396, 13.856, 21.638, 4.667, 21.431, 20.472, 13.272, 19.890, 21.890, 5.636, 5.796, 1.246, 12.925,
    16.172, 3.488, 21.238, 13.221, 22.478, 14.017, 5.352, 13.236, 13.434, 6.252, 20.723, 5.656, 20.770,
    6.978, 13.489, 19.572, 15.455, 21.326, 19.074, 7.394, 5.460, 13.750, 8.675, 17.775, 13.630, 6.517,
    19.144, 14.093, 20.879, 20.602, 8.073, 4.826, 13.472, 5.389, 20.661, 12.926, 8.814, 12.029, 6.540,
    12.934, 13.011, 14.446, 13.448, 13.338, 12.723, 6.517, 13.312, 20.073, 6.321, 21.051, 20.748, 14.377,
    6.707, 20.757, 11.151, 23.265, 13.897, 5.883, 20.606, 12.909, 13.240, 13.087, 13.265, 13.062, 1.169,
    7.446, 19.172, 5.466};

TEST(AnomalyMonitor, TheConfiguredWheelsHalfHourRaisesNoAnomaly) {
  AnomalyMonitor m;
  int suspects = 0;
  for (std::size_t i = 0; i < kWheelHalfHour.size(); ++i) {
    const Observation o = m.Observe(kWheelHalfHour[i] / 100);
    ASSERT_FALSE(IsAnomaly(o.verdict)) << "window " << i << ": " << kWheelHalfHour[i] << " cm/s, v " << o.before;
    suspects += o.verdict == Verdict::kSuspect;
  }
  EXPECT_GE(suspects, 3);  // the dips are seen, and left out
  // One window was enough before noisy_confirmations.
  AnomalyMonitor one_window(AnomalyOptions{.noisy_confirmations = 1});
  int drops = 0;
  for (double v : kWheelHalfHour) {
    if (one_window.Observe(v / 100).verdict == Verdict::kDrop) {
      ++drops;
      one_window.Reset();  // the runner relearns and starts over
    }
  }
  EXPECT_GE(drops, 1);
}

TEST(AnomalyMonitor, WhileTheNoiseSetsTheBandADropMustLastTwoWindows) {
  AnomalyMonitor m;
  for (double v : {0.10, 0.02, 0.12, 0.04}) m.Observe(v);  // d = 0.06: the noise sets the band
  ASSERT_GT(m.Threshold(), m.RuleThreshold());
  EXPECT_EQ(m.Observe(-0.3).verdict, Verdict::kSuspect);
  EXPECT_EQ(m.Observe(0.07).verdict, Verdict::kNormal);  // back: nothing changed
  EXPECT_EQ(m.Observe(-0.3).verdict, Verdict::kSuspect);
  EXPECT_EQ(m.Observe(-0.3).verdict, Verdict::kDrop);    // it lasts: a change
  // A steady gait's band is the rule's: one window is enough.
  AnomalyMonitor steady;
  for (double v : {0.080, 0.082, 0.079, 0.081}) steady.Observe(v);
  ASSERT_DOUBLE_EQ(steady.Threshold(), steady.RuleThreshold());
  EXPECT_EQ(steady.Observe(0.05).verdict, Verdict::kDrop);
}

// The configured wheel at world seed 3, 130 windows of one gait [cm/s]: it
// alternates between near-stalls and fast windows for minutes. With the
// noise learned from in-band windows only, d shrank and the band with it,
// and the last window was a drop.
const std::vector<double> kWheelSeed3 = {
    16.249, 9.917, 17.137, 8.838, 16.979, 25.215, 16.353, 11.031, 14.871, 13.635, 26.253, 15.811, 24.954,
    12.150, 2.327, 14.363, 13.266, 24.243, 2.915, 26.395, 13.568, 1.186, 25.261, 5.794, 24.279, 16.227,
    25.598, 17.918, 14.972, 12.782, 10.016, 13.999, 0.997, 13.242, 25.959, 3.712, 21.574, 2.892, 25.569,
    15.146, 12.074, 16.285, 25.455, 16.852, 13.601, 23.235, 18.341, 23.689, 0.499, 13.288, 11.897, 3.555,
    13.051, 13.670, 22.052, 8.157, 25.111, 16.860, 8.887, 9.551, 8.478, 16.306, 10.075, 16.530, 25.850,
    17.525, 13.307, 0.889, 26.240, 0.787, 14.233, 12.407, 13.671, 24.824, 1.814, 25.958, 12.607, 12.979,
    14.993, 11.148, 3.025, 23.012, 13.739, 12.649, 14.122, 14.857, 12.873, 12.205, 0.629, 15.275, 12.755,
    25.448, 1.870, 17.064, 22.420, 15.682, 12.288, 10.452, 2.465, 13.509, 11.734, 10.517, 13.916, 2.750,
    10.047, 17.996, 20.030, 18.812, 13.410, 0.407, 13.217, 2.067, 25.671, 1.095, 12.575, 13.375, 12.879,
    16.508, 10.251, 1.050, 23.960, 13.573, 13.953, 16.873, 25.799, 12.299, 11.458, 20.859, 25.226, 12.484};

TEST(AnomalyMonitor, AnOutOfBandWindowCountsInTheNoiseAtTheBandsEdge) {
  AnomalyMonitor m;
  for (double v : {0.10, 0.02, 0.12, 0.04}) m.Observe(v);
  const double d = m.noise();
  const double t = m.Threshold();
  EXPECT_EQ(m.Observe(0.07 - 2 * t).verdict, Verdict::kSuspect);
  EXPECT_NEAR(m.noise(), 0.9 * d + 0.1 * t, 1e-12);
  AnomalyMonitor wheel;
  for (std::size_t i = 0; i < kWheelSeed3.size(); ++i) {
    ASSERT_FALSE(IsAnomaly(wheel.Observe(kWheelSeed3[i] / 100).verdict)) << "window " << i;
  }
}

}  // namespace
}  // namespace yamor::lifelong
