// One optimizer instance run: a loaded plugin against a problem and an
// evaluator. The session implements the plugin's context (fields, batches,
// budget, progress, log, stop, seeded random numbers), records every
// evaluation, and writes the results folder as it goes.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <fstream>
#include <functional>
#include <map>
#include <mutex>
#include <random>
#include <string>
#include <vector>

#include "optimizer-plugins/framework/evaluator.h"
#include "optimizer-plugins/framework/plugin_loader.h"
#include "optimizer-plugins/framework/resume.h"

namespace yamor::optimizer {

/// One optimized parameter.
struct ProblemParameter {
  std::string name;    ///< DESIGN.md name, e.g. "phase.0.1".
  double min = 0.0;    ///< Lower bound.
  double max = 0.0;    ///< Upper bound (> min).
  double start = 0.0;  ///< Start value in [min, max].
};

/// What a plugin optimizes: the parameters, and how a point becomes a
/// candidate (constraints applied).
struct Problem {
  std::vector<ProblemParameter> parameters;  ///< Optimized parameters.
  /// The candidate for a point inside the bounds (may throw yamor::Error).
  std::function<Candidate(const std::vector<double>&)> to_candidate;
  /// Optional: the robot configuration XML with a point applied (best.xml).
  std::function<std::string(const std::vector<double>&)> config_xml;
  /// Where the problem came from (summary.json).
  std::string source;
};

/// A problem of plain named parameters: each candidate carries exactly the
/// optimized values (for analytic functions in tests and benchmarks).
Problem PlainProblem(std::vector<ProblemParameter> parameters);

/// How one session runs.
struct SessionOptions {
  std::string label = "run";  ///< Names the instance in logs (batch start).
  std::uint64_t seed = 0;     ///< The plugin's random generator seed.
  std::map<std::string, std::string> set;  ///< --set values (validated here).
  std::string out_dir;        ///< Results folder; empty = write nothing.
  std::string evaluator_description;  ///< E.g. the host list (summary.json).
  /// Evaluations run on a live robot (LiveEvaluator): evaluations.csv gets a
  /// robot_seconds column, summary.json says "live": true.
  bool live = false;
  /// Continue the run recorded in out_dir (yamor-optimize --resume): its
  /// evaluations are answered from evaluations.csv, the rest are evaluated
  /// and appended. A folder that does not exist yet starts afresh.
  bool resume = false;
  /// What else the evaluations depend on (configuration, evaluation
  /// settings), beside what the session knows (plugin and its file, seed,
  /// fields, parameters): written to run.toml, compared on resume.
  RunIdentity identity;
  /// Written to run.toml for people (e.g. "command"), never compared.
  std::map<std::string, std::string> info;
};

/// One recorded evaluation.
struct EvaluationRecord {
  long long index = 0;       ///< 0-based, in submission order.
  std::vector<double> point; ///< Optimized values.
  Evaluation evaluation;     ///< What the evaluator returned.
};

/// A consistent view of a running session (for progress lines).
struct SessionSnapshot {
  long long evaluations = 0;     ///< Done so far.
  long long budget = 0;          ///< max_evaluations.
  double best_velocity = 0.0;    ///< Best so far (0 before the first).
  bool has_best = false;         ///< At least one evaluation done.
  double plugin_fraction = -1;   ///< Plugin-reported progress (< 0: unknown).
  std::string plugin_status;     ///< Plugin-reported status.
  double elapsed_seconds = 0.0;  ///< Since Run started.
};

/// How a session ended.
struct SessionResult {
  /// "converged" (the plugin finished), "budget" (max_evaluations spent),
  /// "stopped" (stop requested) or "failed".
  std::string status;
  std::string error;               ///< Why, when failed.
  long long evaluations = 0;       ///< Evaluations recorded.
  bool has_best = false;           ///< At least one evaluation.
  double best_velocity = 0.0;      ///< Best value.
  long long best_index = -1;       ///< Its record index.
  std::vector<double> best_point;  ///< Its optimized values.
  double wall_seconds = 0.0;       ///< Duration of Run.
  double robot_seconds = 0.0;      ///< Sum of the evaluations' robot time (live runs).
};

/// Runs one plugin instance.
///
/// Thread safety: Run is called once, from one thread; Snapshot,
/// RequestStop and Records may be called from any thread meanwhile.
class Session {
 public:
  /// Validates the problem and the --set values (yamor::Error
  /// kInvalidArgument naming what is wrong); `plugin`, `problem` and
  /// `evaluator` outlive the session. With options.resume, reads the
  /// recorded run: kFailedPrecondition naming every difference when the
  /// plugin, its file, the seed, the fields, the parameters or
  /// options.identity differ from run.toml's, or when the folder holds
  /// evaluations but no run.toml; kDataLoss for a damaged record (a torn
  /// last line is not damage: Run drops it).
  Session(const LoadedPlugin& plugin, const Problem& problem, Evaluator& evaluator,
          SessionOptions options);
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

  /// Runs the plugin to its end; writes run.toml first (unless resuming),
  /// evaluations.csv as evaluations arrive, best.xml whenever the best
  /// improves (when the problem has a configuration), and summary.json at
  /// the end. Resuming, the recorded evaluations answer the plugin's first
  /// requests (a request that differs from the record fails the run) and a
  /// torn last line is cut off before new rows are appended. Never throws
  /// for plugin or evaluation failures (they end as status "failed").
  SessionResult Run();

  /// Asks the plugin to stop: its next evaluate returns STOPPED.
  void RequestStop() { stop_.store(true); }

  /// The current state.
  SessionSnapshot Snapshot() const;

  /// Every evaluation so far, in order.
  std::vector<EvaluationRecord> Records() const;

  /// The resolved field values (defaults with --set applied).
  const std::map<std::string, std::string>& fields() const { return fields_; }

  /// What run.toml records and resume compares: options.identity plus the
  /// plugin, its file's fingerprint, the seed, the fields and parameters.
  RunIdentity Identity() const;

  /// Evaluations a resumed session answers from the record (0 otherwise).
  std::size_t RecordedCount() const { return replay_.size(); }

 private:
  struct Callbacks;
  friend struct Callbacks;

  int32_t EvaluatePoints(const double* points, std::size_t count, double* values,
                         std::size_t* evaluated);
  void Record(const std::vector<std::vector<double>>& points, const std::vector<Candidate>& batch,
              const std::vector<Evaluation>& results, double* values, std::size_t replayed);
  void LoadRecord();
  std::string CheckRecorded(const Candidate& candidate, const RecordedEvaluation& row) const;
  void WriteSummary(const SessionResult& result) const;
  void WriteBest(const std::vector<double>& point) const;

  const LoadedPlugin& plugin_;
  const Problem& problem_;
  Evaluator& evaluator_;
  SessionOptions options_;
  std::map<std::string, std::string> fields_;
  long long budget_ = 0;
  std::vector<YamorParameter> parameters_;  // point into problem_'s names
  std::mt19937_64 random_;                  // only the plugin's thread uses it
  std::string last_error_;                  // only the plugin's thread uses it
  std::atomic<bool> stop_{false};
  // Resuming: the recorded evaluations (read-only after construction).
  std::vector<RecordedEvaluation> replay_;
  std::vector<std::string> replay_columns_;
  std::uintmax_t replay_valid_bytes_ = 0;
  bool replay_torn_ = false;
  std::string replay_torn_reason_;
  bool replay_has_run_file_ = false;

  mutable std::mutex mu_;
  std::chrono::steady_clock::time_point start_;  // guarded by mu_ (written by Run)
  std::vector<EvaluationRecord> records_;  // guarded by mu_
  SessionResult best_;                     // guarded by mu_ (best_* fields only)
  double plugin_fraction_ = -1.0;          // guarded by mu_
  std::string plugin_status_;              // guarded by mu_
  std::ofstream csv_;                      // guarded by mu_
  std::vector<std::string> csv_columns_;   // guarded by mu_
};

/// Writes `text` to `path` atomically (temporary file, then rename).
void WriteFileAtomically(const std::string& path, const std::string& text);

/// Escapes `text` for a JSON string literal (without the quotes).
std::string JsonEscape(const std::string& text);

}  // namespace yamor::optimizer
