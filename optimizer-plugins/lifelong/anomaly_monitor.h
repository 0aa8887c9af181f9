// Anomaly detection of lifelong learning (thesis 7.3): the gait's velocity,
// measured over three CPG periods per window, is smoothed with the EMA rule
//
//   |v − v⁺| < t  ⇒  v := 0.9·v + 0.1·v⁺,   otherwise an anomaly,
//
// where v is the stored velocity, v⁺ the window just measured and t the
// threshold. Physical changes the robot is told about (a module connected or
// disconnected, a defect) are anomalies at once, without waiting for the
// velocity to show them.
//
// Beyond the thesis, t has a noise floor: some gaits measure very unevenly
// from window to window (the configured dog and wheel: 0 to 23 cm/s), and a
// threshold relative to v alone alarms on them all the time. The first
// learn_windows windows of a gait only learn v (their mean) and the window
// noise d (their mean absolute deviation); from then on
// t = max(threshold·max(|v|, min_reference), noise_factor·d), and d follows
// the windows with the same EMA as v (an out-of-band window counted as a
// deviation of t). While the noise sets t, a drop
// must last noisy_confirmations windows. noise_factor = 0 is the
// thesis's rule exactly (the first window initialises v, the next one may
// alarm).
#pragma once

#include <set>
#include <string>

namespace yamor::lifelong {

/// How the monitor judges a window.
struct AnomalyOptions {
  /// The threshold t. Relative (a fraction of the stored velocity |v|) by
  /// default; in m/s when `relative` is false.
  double threshold = 0.3;
  /// t = threshold·max(|v|, min_reference) instead of t = threshold.
  bool relative = true;
  /// [m/s] Floor of the reference of a relative threshold, so a robot that
  /// barely moves does not alarm on noise.
  double min_reference = 0.01;
  /// The EMA weight of the stored velocity (the thesis's 0.9).
  double smoothing = 0.9;
  /// A window faster than v + t is an anomaly too (by default it is only
  /// reported, and v takes the new value: the robot got better).
  bool increase_is_anomaly = false;
  /// t is at least noise_factor times the window noise d (0: off, the
  /// thesis's rule).
  double noise_factor = 3;
  /// Windows of a gait that only learn v and d (with noise_factor > 0).
  int learn_windows = 4;
  /// Consecutive out-of-band windows needed before a change is reported
  /// (1: the thesis's rule, every such window). While fewer were seen the
  /// verdict is kSuspect and v is not updated.
  int confirmations = 1;
  /// Consecutive windows below the band needed before a drop is reported
  /// while the window noise sets the band (noise_factor·d above the relative
  /// rule; at least `confirmations`). A gait that measures that unevenly
  /// dips below the band now and then without anything having changed (the
  /// configured wheel: 3 drops in 30 min at 1 window, none at 2); a real
  /// change lasts. A steady gait, whose band the rule sets, keeps
  /// `confirmations`.
  int noisy_confirmations = 2;
  /// Consecutive windows above the band needed before an increase is
  /// reported (at least `confirmations`): a single fast window is kept out.
  int increase_confirmations = 2;
  /// WatchState event kinds that are physical changes (anomalies at once).
  std::set<std::string> physical_events = {"module_connected", "module_disconnected",
                                           "defect_set", "defect_cleared"};
};

/// Checks `options` and throws yamor::Error kInvalidArgument naming the bad
/// field (threshold <= 0 or not finite, smoothing outside [0, 1),
/// min_reference < 0, noise_factor < 0, learn_windows < 1, confirmations,
/// noisy_confirmations or increase_confirmations < 1).
void ValidateAnomalyOptions(const AnomalyOptions& options);

/// What one observation meant.
enum class Verdict {
  kInitialised,     ///< First window after a reset: v := v⁺.
  kLearning,        ///< A learning window: v and the noise learned, never an anomaly.
  kNormal,          ///< Inside the band: v updated by the EMA rule.
  kSuspect,         ///< Outside the band, not yet confirmed; v kept.
  kIncrease,        ///< Faster than v + t (not an anomaly unless configured); v := v⁺.
  kDrop,            ///< Slower than v − t: an anomaly; v kept (the expectation).
  kIncreaseAnomaly, ///< Faster than v + t with increase_is_anomaly: an anomaly; v kept.
  kPhysicalChange,  ///< A physical-change event: an anomaly at once.
};

/// Lower-case name of a verdict ("drop", "physical_change", ...).
const char* VerdictName(Verdict verdict);

/// True for the verdicts that call for adaptation.
bool IsAnomaly(Verdict verdict);

/// The outcome of one observation.
struct Observation {
  Verdict verdict = Verdict::kInitialised;  ///< What it meant.
  double measured = 0;   ///< v⁺ [m/s] (0 for an event).
  double before = 0;     ///< v before the observation [m/s] (0 when uninitialised).
  double ema = 0;        ///< v after it [m/s].
  double threshold = 0;  ///< The absolute t used [m/s] (0 when uninitialised).
  std::string event;     ///< The event kind, for kPhysicalChange.
};

/// The EMA anomaly rule over a stream of velocity windows and events.
///
/// Thread safety: not thread-safe; one thread at a time.
class AnomalyMonitor {
 public:
  /// Validates `options` (see ValidateAnomalyOptions).
  explicit AnomalyMonitor(AnomalyOptions options = {});

  /// Judges one window's velocity v⁺ [m/s]. Throws kInvalidArgument for a
  /// non-finite value.
  Observation Observe(double velocity);

  /// Judges a WatchState event: kPhysicalChange for a kind in
  /// options.physical_events, otherwise nothing (nullopt-like: verdict
  /// kNormal with the state unchanged). Never changes v.
  Observation OnEvent(const std::string& kind);

  /// Forgets v: the next window initialises it.
  void Reset();
  /// Sets v to a known velocity (a verified gait), as if a first window had
  /// measured it (the noise is learned again).
  void Seed(double velocity);

  /// True once v holds a value.
  bool initialised() const { return initialised_; }
  /// The stored velocity v [m/s] (0 before initialisation).
  double ema() const { return ema_; }
  /// The absolute threshold for the current v [m/s].
  double Threshold() const;
  /// The threshold the EMA rule alone gives (no noise floor) [m/s].
  double RuleThreshold() const;
  /// The window noise d [m/s] (0 while unknown).
  double noise() const { return noise_; }
  /// Windows observed since the last Reset or Seed (the seed counts as one).
  int windows() const { return seen_; }
  /// True once d is learned: noise_factor > 0 and learn_windows windows seen.
  bool noise_learned() const {
    return initialised_ && options_.noise_factor > 0 && seen_ >= options_.learn_windows;
  }
  /// The options in use.
  const AnomalyOptions& options() const { return options_; }

 private:
  AnomalyOptions options_;
  bool initialised_ = false;
  double ema_ = 0;
  int seen_ = 0;        // windows since the reset (or seed)
  double noise_ = 0;    // mean absolute deviation of the windows from v
  int pending_ = 0;     // consecutive out-of-band windows not yet reported
  int pending_sign_ = 0;  // -1 below the band, +1 above
};

}  // namespace yamor::lifelong
