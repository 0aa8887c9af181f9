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

/// Evaluates candidates one at a time on the robot of one yamord.
///
/// The daemon must have a robot connected with its configuration loaded;
/// a trial leaves the robot running the last candidate applied. Parameter
/// names are DESIGN.md's (amplitude.3, phase.2.5, ...); each becomes the
/// matching Set* call, then one Flush. The CPG period of a trial is
/// 1 / (smallest non-zero driven speed): the candidate's speed.N values where
/// it sets them, the robot's current speeds otherwise.
///
/// Errors from EvaluateBatch and Measure: kCancelled after RequestStop;
/// kUnavailable when the daemon or its link is gone (naming it);
/// kFailedPrecondition when no robot is connected; the daemon's own code
/// (kNotFound, kOutOfRange, kInvalidArgument) when it refuses a parameter,
/// naming the candidate and the parameter.
///
/// Thread safety: EvaluateBatch and Measure serialize on an internal mutex
/// (one robot, capacity 1); RequestStop, Trials and RobotSeconds may be
/// called from any thread.
class LiveEvaluator final : public Evaluator {
 public:
  /// Attaches to the daemon at `address` (checks GetInfo: reachable and a
  /// robot connected). Throws kUnavailable or kFailedPrecondition.
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
