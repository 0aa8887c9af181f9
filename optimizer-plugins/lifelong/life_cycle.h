// The lifelong runner's decisions (thesis 7.2, DESIGN.md "Lifelong
// learning"): walk → measure → anomaly? → adapt → recall → relearn → walk,
// for as long as the robot lives. All I/O goes through the seams of
// robot_port.h, so tests run the whole story against fakes.
//
//   walking ──(drop | physical change | turned over)──▶ anomaly
//   anomaly ──▶ recalling: each stored gait for this body, orientation and
//               symptoms, most likely first, gets one short trial (a gait
//               whose stored window noise is large: up to a few windows)
//   recalling ──(a gait reaches its expected velocity, within its noise)──▶ walking
//   recalling ──(none does)──▶ relearning: rebuild the network when the body
//               changed, else the same parameters; warm start from the
//               current gait; store the result ──▶ walking
//   any ──(daemon gone)──▶ disconnected ──(reattached)──▶ the same step again
#pragma once

#include <atomic>
#include <cstdint>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <string>

#include "optimizer-plugins/lifelong/adaptation.h"
#include "optimizer-plugins/lifelong/anomaly_monitor.h"
#include "optimizer-plugins/lifelong/gait_database.h"
#include "optimizer-plugins/lifelong/robot_port.h"

namespace yamor::lifelong {

/// How the runner lives.
struct LifeOptions {
  AnomalyOptions anomaly;          ///< The EMA rule.
  AdaptationOptions adaptation;    ///< Problem generation (its seed is replaced by `seed`).
  double window_periods = 3;       ///< CPG periods per measurement window (thesis 7.3).
  double settle_periods = 1;       ///< Periods after a gait change before measuring.
  double trial_periods = 3;        ///< Periods of one recall trial.
  /// Periods to wait after a physical change for the body to stop changing
  /// (a transformation script takes a while); at most 10 such waits.
  double quiet_periods = 1;
  int max_recall = 10;             ///< Stored gaits tried per anomaly.
  /// A recalled gait is kept when its trial reaches this fraction of its
  /// expected velocity E (or what its window noise allows, below).
  double recall_accept = 0.8;
  /// k: a trial whose mean of n windows reaches
  ///   E − max((1 − recall_accept)·E, min(k·d/√n, (1 − recall_floor)·E))
  /// is accepted, d the gait's stored window noise (GaitRecord::velocity_noise).
  /// 0 (or d unknown) is the plain recall_accept rule.
  double recall_noise_factor = 2;
  /// Whatever its noise, a trial must reach this fraction of E (a gait
  /// that stopped walking is never taken for a noisy one).
  double recall_floor = 0.5;
  /// Windows (each trial_periods long, each counted as a trial) a trial of a
  /// noisy gait (k·d > (1 − recall_accept)·E) may grow to while it is
  /// inconclusive: below the acceptance, but not below E − recall_fail_factor·d/√n.
  /// 1: one window for every gait.
  int recall_max_windows = 4;
  /// F: a trial whose mean of n windows is below E − F·d/√n has failed (a
  /// window that low is beyond the gait's noise; the anomaly rule's band is
  /// 3·d as well), so a gait that does not walk any more is rejected at once.
  double recall_fail_factor = 3;
  /// A gait switched to from a robot that has nearly stopped walks slowly
  /// for a period or two. A clean gait's first trial window below the
  /// acceptance but at or above this fraction of E gets one more window,
  /// judged alone (the first held the start-up); below it, or a second
  /// window that is low too, is rejected. 0 turns the second window off.
  double recall_restart_floor = 0.4;
  /// Walking windows between writes of the current gait's window noise to
  /// the database (besides the write when the gait is left); 0: only then.
  int noise_write_windows = 6;
  /// |cos| between the accelerometer's mean and the upright reference
  /// beyond which the orientation is decided (else it is kept).
  double orientation_cos = 0.5;
  /// Windows after a gait starts whose orientation must be the gait's; if
  /// one is not, the gait's own motion turns the central module (a rolling
  /// wheel) and its orientation is not watched.
  int orientation_learn_windows = 2;
  /// Consecutive flipped windows that make an anomaly when the velocity did
  /// not fall (with a velocity anomaly, one flipped window names the cause).
  int orientation_confirmations = 2;
  /// Modules connected during life that the initial configuration does not
  /// drive get an oscillator when the network is rebuilt.
  bool drive_new_modules = true;
  bool starts_upside_down = false; ///< The robot starts on its back (the reference flips).
  double max_life_seconds = 0;     ///< Stop after this much life time [s]; 0 = never.
  int max_anomalies = 0;           ///< Stop after handling this many anomalies; 0 = never.
  /// Seed of the n-th relearning (seed + n - 1): its budget rule and its optimizer.
  std::uint64_t seed = 1;
  std::string out_dir;             ///< Relearning results go to out_dir/relearn-N ("" = none).
};

/// The gait the robot starts with.
struct InitialGait {
  std::string config_xml;   ///< Robot configuration.
  std::string problem_xml;  ///< Optimization configuration it comes from ("" when none).
  std::string source;       ///< File name, for the log.
};

/// A consistent view for the progress line.
struct LifeStatus {
  std::string state = "starting";  ///< Current state.
  double time = 0;                 ///< Life time [s].
  double velocity = 0;             ///< Last measured [m/s].
  double ema = 0;                  ///< Stored velocity [m/s].
  std::int64_t gait = 0;           ///< Gait walking.
  int anomalies = 0;               ///< Anomalies handled.
  int recalls = 0;                 ///< Anomalies solved from the database.
  int relearns = 0;                ///< Relearning runs.
  long long trials = 0;            ///< Recall and relearning trials on the robot.
  int gaps = 0;                    ///< Times the daemon went away.
  std::string detail;              ///< What is happening ("trial 12", ...).
  double threshold = 0;            ///< The anomaly threshold t now [m/s] (0 while v is unknown).
  long long relearn_trials = 0;    ///< Trials of the relearning in progress (0 outside one).
};

/// What a life ended with.
struct LifeSummary {
  std::string reason;       ///< "stopped", "time limit", "anomaly limit".
  LifeStatus status;        ///< The last status.
};

/// The runner's state machine.
///
/// Thread safety: Run from one thread; RequestStop and Status from any.
class LifeCycle {
 public:
  /// `port`, `relearner`, `db` and `log` outlive the object. Validates the
  /// options (kInvalidArgument naming the field).
  LifeCycle(RobotPort& port, Relearner& relearner, GaitDatabase& db, LifeLog& log, LifeOptions options);

  /// Lives until stopped or a limit is reached. Throws yamor::Error for
  /// what it cannot live with: a start the robot refuses, a database that
  /// fails.
  LifeSummary Run(const InitialGait& initial);
  /// Ends Run at its next step (a relearning keeps its best so far).
  void RequestStop();
  /// A snapshot.
  LifeStatus Status() const;

 private:
  struct Anomaly {
    std::string trigger;         // "velocity_drop", "module_disconnected", "orientation", ...
    double time = 0;
    double velocity_before = 0;  // the expectation
    double velocity_after = 0;   // the window that showed it (0 for events)
    int module_id = -1;
    std::string detail;
    double event_time = -1;      // robot time the daemon reported the event at
  };
  struct Gait {
    std::int64_t id = 0;
    std::string config_xml;
    std::string problem_xml;
    std::string key;
    Orientation orientation = Orientation::kUpright;
    double expected = 0;
  };

  void Start(const InitialGait& initial);
  void Step();
  // `resumed`: the anomaly was logged before a daemon gap interrupted it.
  void Adapt(Anomaly anomaly, bool resumed);
  void HandleLoss(const std::string& error);
  bool Recall(const Anomaly& anomaly, const std::string& key, Orientation orientation,
              const Symptoms& symptoms);
  void Relearn(const Anomaly& anomaly, const cpg::ModuleGraph& graph, const std::string& key,
               Orientation orientation, const Symptoms& symptoms, bool body_changed,
               const std::string& morphology_xml);
  // A new gait walks: its orientation is learned again.
  void NewGait();
  // Writes the current gait's window noise and EMA (a snapshot from its
  // last in-band window) when they changed since the last write.
  void StoreNoise();
  // How a recall trial of `gait` stands after n windows of mean `mean`.
  struct TrialVerdict {
    bool accepted = false;
    bool longer = false;    // inconclusive: another window
    double accept_level = 0;
    double fail_level = 0;
    double velocity = 0;    // what was judged: the mean (a noisy gait) or the last window
  };
  // `last` is the n-th window's velocity.
  TrialVerdict JudgeTrial(const GaitRecord& gait, double mean, double last, int n) const;
  // Handles the events that came in; returns the first physical change.
  std::optional<Anomaly> TakeEvents();
  void Note(const RobotEvent& event);
  std::optional<Orientation> Classify(const AccelReading& reading) const;
  std::pair<cpg::ModuleGraph, std::string> CurrentBody(std::string* key);
  std::vector<std::string> Defects() const;
  bool Stopping() const { return stop_.load(); }
  double LifeTime(double robot_time) const { return robot_time + offset_; }
  void SetState(const std::string& state, const std::string& detail = "");
  void Row(double robot_time, double velocity, const std::string& event);
  void Event(double robot_time, const std::string& kind,
             std::vector<std::pair<std::string, std::string>> fields = {});
  bool LimitReached(std::string* reason) const;

  RobotPort& port_;
  Relearner& relearner_;
  GaitDatabase& db_;
  LifeLog& log_;
  LifeOptions options_;
  AnomalyMonitor monitor_;
  std::atomic<bool> stop_{false};

  // Only the Run thread touches these.
  Gait current_;
  std::set<int> driven_;         // modules with an oscillator unless dead
  std::set<int> dead_;           // module defects
  std::map<int, std::string> motor_defects_;  // module -> "limp" | "stuck"
  std::optional<double> friction_, slope_, slope_direction_;  // last ground events
  std::optional<std::array<double, 3>> up_;  // accelerometer reference, unit
  Orientation orientation_ = Orientation::kUpright;
  bool orientation_watched_ = false;  // this gait's orientation is watched
  int orientation_seen_ = 0;          // windows of this gait seen while learning
  int orientation_flips_ = 0;         // consecutive flipped windows
  AccelReading last_accel_;
  std::optional<Anomaly> pending_;  // an anomaly being handled (resumed after a gap)
  std::optional<Anomaly> next_;     // an anomaly found while reattaching, not yet handled
  // What the first window of a gait also does.
  enum class FirstWindow { kNothing, kRecordUse, kUpdateExpected };
  FirstWindow first_window_ = FirstWindow::kNothing;
  // The current gait's window noise as of its last in-band window.
  struct NoiseSnapshot {
    std::int64_t gait = 0;
    double noise = 0;
    double ema = 0;  // the velocity the noise is measured around
    int windows = 0;
    bool valid = false;        // learned in this stint of the gait
    int written_windows = -1;  // `windows` at the last write (-1: none)
  };
  NoiseSnapshot noise_;
  double offset_ = 0;     // life time = robot time + offset
  double last_robot_time_ = 0;
  int relearn_count_ = 0;

  mutable std::mutex mu_;
  LifeStatus status_;  // guarded by mu_
};

}  // namespace yamor::lifelong
