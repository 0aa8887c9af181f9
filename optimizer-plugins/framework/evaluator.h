// The evaluation seam of the optimizer framework: a plugin's batches become
// Candidates (every named parameter value, optimized and constrained), and an
// Evaluator turns them into Evaluations. The HostPool (host_pool.h) evaluates
// over yamord hosts; FunctionEvaluator evaluates an analytic function
// in-process, for tests and benchmarks.
#pragma once

#include <atomic>
#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace yamor::optimizer {

/// One candidate gait: named parameter values (DESIGN.md names) to apply
/// over the optimization's robot configuration.
struct Candidate {
  std::vector<std::pair<std::string, double>> parameters;  ///< Name, value.
};

/// "{name=value, ...}" of a candidate, for error messages.
std::string FormatCandidate(const Candidate& candidate);

/// What one evaluation produced.
struct Evaluation {
  double velocity = 0.0;     ///< [m/s] (thesis 6.2.1); 0 when diverged.
  double distance = 0.0;     ///< [m].
  bool diverged = false;     ///< The simulated world diverged.
  std::string divergence;    ///< Why, when diverged.
  std::string host;          ///< "host:port" that ran it ("local" in-process).
  double wall_seconds = 0.0; ///< Wall time of the evaluation on its host.
  /// Robot time the evaluation spent on a live robot [s] (LiveEvaluator:
  /// applying, settling, measuring); 0 for simulated evaluations.
  double robot_seconds = 0.0;
};

/// Evaluates batches of candidates.
///
/// Thread safety: implementations accept concurrent EvaluateBatch calls
/// (batch start runs several optimizer instances over one evaluator).
class Evaluator {
 public:
  virtual ~Evaluator() = default;

  /// Evaluates every candidate, blocking until all are done; results in
  /// submission order. Throws yamor::Error: kCancelled once RequestStop() was
  /// called (in-flight work is abandoned), kUnavailable when no host can run
  /// the work any more, kInvalidArgument when a host refuses a candidate as
  /// malformed (naming it).
  virtual std::vector<Evaluation> EvaluateBatch(const std::vector<Candidate>& batch) = 0;

  /// Asks every current and future EvaluateBatch to end with kCancelled.
  /// Safe from any thread (and from a signal-watching thread).
  virtual void RequestStop() = 0;

  /// How many evaluations can run at once (for progress estimates).
  virtual int Capacity() const = 0;
};

/// Evaluates a function of the named values in-process, one thread.
class FunctionEvaluator final : public Evaluator {
 public:
  /// The function to maximize, of the candidate's parameters.
  using Function = std::function<double(const std::vector<std::pair<std::string, double>>&)>;

  /// Evaluates `function`.
  explicit FunctionEvaluator(Function function) : function_(std::move(function)) {}

  std::vector<Evaluation> EvaluateBatch(const std::vector<Candidate>& batch) override;
  void RequestStop() override { stop_.store(true); }
  int Capacity() const override { return 1; }

  /// Evaluations made so far.
  long long Count() const { return count_.load(); }

 private:
  Function function_;
  std::atomic<bool> stop_{false};
  std::atomic<long long> count_{0};
};

}  // namespace yamor::optimizer
