// The live-robot evaluator (DESIGN.md "Stateless and stateful evaluation";
// thesis 6.3 and 7.3): the host pool's contract (a batch of candidates in,
// velocities out, in order) on one robot that cannot be cloned. Each
// candidate is applied to the robot through the stateful API (Set* + Flush),
// the oscillators settle, and the velocity is measured from RobotPosition
// samples over a whole number of CPG periods — in virtual time on a
// simulation (Sleep steps the world), in real time on a real robot.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "optimizer-plugins/framework/evaluator.h"
#include "optimizer-plugins/framework/host_pool.h"

namespace grpc {
class Channel;
}  // namespace grpc

namespace yamor::optimizer {

/// How a live trial runs.
struct LiveOptions {
  double settle_periods = 1;     ///< CPG periods after applying a candidate, not measured.
  double measure_periods = 3;    ///< CPG periods measured (thesis 7.3).
  double sample_interval = 0.1;  ///< [s] of robot time between RobotPosition samples.
  double rpc_deadline = 10;      ///< [s] deadline of one RPC (a Sleep adds its own length).
  /// [s] CPG period used when neither the candidate nor the robot gives a
  /// speed (every driven speed is 0); also the cap of one period.
  double max_period = 10;
};

/// What one live measurement saw.
struct LiveMeasurement {
  double velocity = 0;        ///< Straight-line ground distance / measured time [m/s].
  double distance = 0;        ///< [m] on the ground plane (x, y).
  double start_time = 0;      ///< Robot time of the first sample [s].
  double end_time = 0;        ///< Robot time of the last sample [s].
  double period = 0;          ///< CPG period used [s].
  int samples = 0;            ///< RobotPosition samples taken.
  std::string position_source;  ///< "simulation" or "led-tracker".
};

/// What PrepareLiveRobot did.
struct LivePreparation {
  std::string backend;          ///< The daemon's backend ("simulation", "serial").
  bool connected_now = false;   ///< ConnectRobot ran (else the robot was connected: Refresh).
  int links = 0;                ///< Bluetooth links ConnectRobot built.
};

/// Readies the robot of the daemon at `address` for live trials of the
/// robot configuration `config_xml` (yamor-optimize --live): LoadConfig
/// (named `source_name`); then ConnectRobot (links and the whole
/// configuration) when GetInfo says no robot is connected, else Refresh
/// (the whole configuration again); then SendControlMessage to all modules:
/// UART, CPG and motors on (inactive modules and defective motors stay
/// off, as the daemon rules). Each call has `deadline` seconds. A failed
/// call throws by the rule of host_rpc.h, naming the call: the daemon's code
/// for a caller error (kInvalidArgument for a configuration the world cannot
/// hold), kUnavailable when the daemon is unreachable or gone.
LivePreparation PrepareLiveRobot(const HostAddress& address, const std::string& config_xml,
                                 const std::string& source_name, double deadline = 60);

/// Evaluates candidates one at a time on the robot of one yamord.
///
/// The daemon must have a robot connected with its configuration loaded;
/// a trial leaves the robot running the last candidate applied. Parameter
/// names are DESIGN.md's (amplitude.3, phase.2.5, ...); a candidate is first
/// checked against a copy of the daemon's configuration (SaveConfig), so a
/// refused one leaves the robot unchanged, then each parameter becomes the
/// matching Set* call (a module's limits ordered so min < max holds at every
/// step), then one Flush. Robot time advances with virtual-time Sleep calls
/// on a simulation, and on the wall clock on a real robot or a simulation in
/// free run (GetInfo.free_run_factor f > 0: one robot second per 1/f wall
/// seconds); velocity = ground-plane distance between the first and last
/// RobotPosition samples / the difference of their `time` fields. The CPG
/// period of a trial is 1 / (smallest non-zero driven speed): the
/// candidate's speed.N values where it sets them, the robot's current speeds
/// otherwise. Evaluation::robot_seconds is the ElapsedTime a trial spent.
///
/// Errors from EvaluateBatch and Measure (a failed RPC by the rule of
/// host_rpc.h): kCancelled after RequestStop; kUnavailable when the daemon
/// or its link is gone (naming it);
/// kFailedPrecondition when no robot is connected; the daemon's own code
/// (kNotFound, kOutOfRange, kInvalidArgument) when it refuses a parameter,
/// naming the candidate and the parameter (checked locally with the
/// daemon's own rules, cpg::ApplyParameters); kUnimplemented when the
/// daemon cannot give a position (a real robot without an LED tracker).
///
/// Thread safety: EvaluateBatch and Measure serialize on an internal mutex
/// (one robot, capacity 1); RequestStop, Trials and RobotSeconds may be
/// called from any thread.
class LiveEvaluator final : public Evaluator {
 public:
  /// Attaches to the daemon at `address` (checks GetInfo: reachable and a
  /// robot connected). Throws kUnavailable or kFailedPrecondition;
  /// kInvalidArgument for options that are not finite and positive
  /// (settle_periods may be 0).
  explicit LiveEvaluator(const HostAddress& address, LiveOptions options = {});
  /// Uses an existing channel; `name` names the daemon in errors and
  /// Evaluation::host.
  LiveEvaluator(std::shared_ptr<grpc::Channel> channel, std::string name, LiveOptions options = {});
  ~LiveEvaluator() override;
  LiveEvaluator(const LiveEvaluator&) = delete;
  LiveEvaluator& operator=(const LiveEvaluator&) = delete;

  /// Runs each candidate in turn on the robot (apply, settle, measure).
  std::vector<Evaluation> EvaluateBatch(const std::vector<Candidate>& batch) override;
  /// Ends the running trial (at its next sample) and every later one with kCancelled.
  void RequestStop() override;
  /// One robot: 1.
  int Capacity() const override { return 1; }

  /// Measures the gait running now, changing nothing: `periods` CPG periods
  /// (0: options.measure_periods) after no settling.
  LiveMeasurement Measure(double periods = 0);
  /// Applies `candidate`'s parameters (Set* + Flush) without measuring.
  void Apply(const Candidate& candidate);

  /// True when the daemon runs a simulation (virtual time), false on a real robot.
  bool Simulated() const;
  /// Trials run so far.
  long long Trials() const;
  /// Robot time spent in trials and measurements so far [s].
  double RobotSeconds() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace yamor::optimizer
