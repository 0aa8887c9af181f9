// The seams between the lifelong runner's decisions (life_cycle.h) and the
// world: the robot it lives in (RobotPort), the optimizer that relearns
// (Relearner) and where its story is written (LifeLog). The daemon-backed
// implementations are daemon_port.h, session_relearner.h and timeline.h;
// tests drive the decisions through fakes.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "cpg/module_graph.h"

namespace yamor::lifelong {

/// One measurement window of the running gait.
struct Window {
  double start_time = 0;  ///< Robot time of its first sample [s].
  double end_time = 0;    ///< Robot time of its last sample [s].
  double velocity = 0;    ///< Ground-plane distance / time [m/s].
  double period = 0;      ///< The CPG period it was measured over [s].
};

/// Something the daemon reported (WatchState events).
struct RobotEvent {
  double time = 0;      ///< Robot time it was reported at [s].
  std::string kind;     ///< "module_connected", "defect_set", ...
  int module_id = -1;   ///< The module concerned, or -1.
  std::string detail;   ///< The daemon's detail text ("motor limp", ...).
};

/// A summary of the central module's accelerometer samples.
struct AccelReading {
  bool valid = false;                 ///< False when the robot gave none.
  std::array<double, 3> mean{};       ///< Mean specific force, module frame [m/s²].
  double spread = 0;                  ///< RMS deviation of the samples from the mean [m/s²].
  int samples = 0;                    ///< Samples averaged.
  std::string error;                  ///< Why not valid.
};

/// How a reattachment went.
struct Reattachment {
  double robot_time = 0;   ///< The daemon's robot time after it [s].
  bool restarted = false;  ///< The daemon lost the robot's state (a restart): it was set up again.
};

/// The robot, as the runner sees it.
///
/// Every call may throw yamor::Error: kUnavailable when the daemon or its
/// link is gone (the runner then calls Reattach), kCancelled after the
/// runner asked to stop, other codes for a refused request.
///
/// Thread safety: the runner calls it from one thread; RequestStop may be
/// called from any thread.
class RobotPort {
 public:
  virtual ~RobotPort() = default;

  /// Robot time now [s].
  virtual double Now() = 0;
  /// Measures the running gait over `periods` CPG periods.
  virtual Window Measure(double periods) = 0;
  /// Lets the running gait run `periods` CPG periods, not measured.
  virtual void Settle(double periods) = 0;
  /// Events reported since the last call, oldest first.
  virtual std::vector<RobotEvent> TakeEvents() = 0;
  /// The central module's accelerometer now.
  virtual AccelReading ReadAccelerometer() = 0;
  /// The body as it is now, every module marked driven (the runner sets
  /// the driven/passive flags), and its morphology XML.
  virtual std::pair<cpg::ModuleGraph, std::string> Body() = 0;
  /// Makes `config_xml` the robot's configuration and lets it walk (load,
  /// send, oscillators and motors on).
  virtual void Walk(const std::string& config_xml) = 0;
  /// Waits until the daemon answers again and the robot walks `config_xml`
  /// (set up again when the daemon lost it). Throws kCancelled once `stop`
  /// returns true.
  virtual Reattachment Reattach(const std::string& config_xml, const std::function<bool()>& stop) = 0;
  /// Ends a running or future Measure/Settle with kCancelled.
  virtual void RequestStop() = 0;
};

/// The robot's condition for `model` mode: what the simulation must copy.
struct RobotCondition {
  std::string morphology_xml;  ///< The body now.
  std::vector<std::pair<int, std::string>> motor_defects;  ///< (module, "limp" | "stuck").
  std::vector<int> module_defects;        ///< Modules whose oscillator is dead.
  std::optional<double> ground_friction;  ///< From the daemon's ground events, when seen.
  std::optional<double> ground_slope;     ///< [rad], likewise.
  std::optional<double> ground_slope_direction;  ///< [rad], likewise.
  bool upside_down = false;               ///< The robot lies on its back.
};

/// What to relearn.
struct RelearnRequest {
  std::string problem_xml;  ///< Optimization configuration (robot = warm start, plus rules).
  std::string out_dir;      ///< Folder for the optimizer's results ("" = none).
  std::uint64_t seed = 1;   ///< The optimizer's seed.
  std::string label;        ///< Names the run in logs ("relearn-3").
  RobotCondition condition; ///< For model mode.
};

/// One trial on the robot during relearning.
struct Trial {
  double time = 0;      ///< Robot time at its end [s].
  double velocity = 0;  ///< Measured [m/s].
  bool verification = false;  ///< A model mode candidate verified on the robot.
};

/// What a relearning produced.
struct RelearnResult {
  bool ok = false;           ///< A gait came out (else see error).
  std::string status;        ///< The session's status ("converged", "budget", "stopped", "failed").
  std::string error;         ///< Why not ok.
  int error_code = 0;        ///< yamor::StatusCode of the failure (kUnavailable: the daemon went away).
  std::string config_xml;    ///< The best gait's robot configuration.
  std::vector<std::pair<std::string, double>> parameters;  ///< Its free parameter values.
  double velocity = 0;       ///< Its velocity measured on the robot [m/s].
  long long evaluations = 0; ///< Evaluations of the optimizer (simulated ones included).
  long long trials = 0;      ///< Trials on the robot.
  double robot_seconds = 0;  ///< Robot time the trials took [s].
};

/// Runs an optimizer for the runner.
///
/// Thread safety: Relearn from one thread; RequestStop from any.
class Relearner {
 public:
  virtual ~Relearner() = default;
  /// Relearns; `on_trial` is called after every trial on the robot. Never
  /// throws for optimizer or evaluation failures (they come back in the
  /// result).
  virtual RelearnResult Relearn(const RelearnRequest& request,
                                const std::function<void(const Trial&)>& on_trial) = 0;
  /// Ends a running or future Relearn early (its best so far is kept).
  virtual void RequestStop() = 0;
  /// "online" or "model".
  virtual std::string mode() const = 0;
};

/// One row of timeline.csv.
struct TimelineRow {
  double time = 0;        ///< Life time [s] (robot time, continued across daemon restarts).
  double velocity = 0;    ///< Measured [m/s]; NaN when the row is an event only.
  double ema = 0;         ///< The monitor's stored velocity [m/s].
  std::string state;      ///< "walking", "anomaly", "recalling", "relearning", "disconnected".
  std::string event;      ///< Short event text ("" for a plain window).
  std::int64_t gait = 0;  ///< The gait walking (database id; 0 when unknown).
};

/// One line of events.jsonl: a kind and fields, each value already JSON.
struct LifeEvent {
  double time = 0;    ///< Life time [s].
  std::string kind;   ///< "start", "anomaly", "recalled", "relearned", ...
  std::vector<std::pair<std::string, std::string>> fields;  ///< Key, JSON value.
};

/// JSON value helpers for LifeEvent fields.
std::string JsonString(const std::string& text);
/// A number (null when not finite).
std::string JsonNumber(double value);

/// Where the runner writes its story.
///
/// Thread safety: called from the runner's thread only.
class LifeLog {
 public:
  virtual ~LifeLog() = default;
  /// Appends a timeline row.
  virtual void Row(const TimelineRow& row) = 0;
  /// Appends an event.
  virtual void Event(const LifeEvent& event) = 0;
};

}  // namespace yamor::lifelong
