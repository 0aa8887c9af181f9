// The lifelong runner's decisions (thesis 7.2, DESIGN.md "Lifelong
// learning"): walk → measure → anomaly? → adapt → recall → relearn → walk,
// for as long as the robot lives. All I/O goes through the seams of
// robot_port.h, so tests run the whole story against fakes.
//
//   walking ──(drop | physical change | turned over)──▶ anomaly
//   anomaly ──▶ recalling: each stored gait for this body, orientation and
//               symptoms, most likely first, gets one short trial
//   recalling ──(a gait reaches its expected velocity)──▶ walking
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
  /// expected velocity.
  double recall_accept = 0.8;
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
  double offset_ = 0;     // life time = robot time + offset
  double last_robot_time_ = 0;
  int relearn_count_ = 0;

  mutable std::mutex mu_;
  LifeStatus status_;  // guarded by mu_
};

}  // namespace yamor::lifelong
