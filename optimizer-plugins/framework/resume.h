// What `yamor-optimize --resume DIR` needs from a results folder: the run's
// identity (run.toml, written when the run starts: plugin, its file,
// configuration, seeds, fields, evaluation settings) and the evaluations
// already recorded (evaluations.csv), read back exactly, with a torn last
// line (the process was killed mid-write) detected and dropped.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "optimizer-plugins/framework/evaluator.h"
#include "optimizer-plugins/framework/host_pool.h"
#include "optimizer-plugins/framework/optimization_config.h"

namespace yamor::optimizer {

/// What determines a run's path: keys and values compared on resume.
using RunIdentity = std::map<std::string, std::string>;

/// A 64-bit FNV-1a fingerprint of `bytes` as "fnv1a64:<16 hex digits>", for
/// noticing a changed file (not a cryptographic hash). Thread-safe.
std::string Fingerprint(std::string_view bytes);

/// Fingerprint of the file at `path`; kNotFound when it cannot be read.
std::string FileFingerprint(const std::string& path);

/// Writes `identity` (compared on resume) and `info` (for people: the
/// command line, the start time) as TOML to `path`, atomically.
void WriteRunFile(const std::string& path, const RunIdentity& identity,
                  const std::map<std::string, std::string>& info);

/// Reads the [identity] table of a run file; kNotFound when unreadable,
/// kDataLoss when malformed. `info`, when not null, receives the [info] table.
RunIdentity ReadRunFile(const std::string& path,
                        std::map<std::string, std::string>* info = nullptr);

/// Why `recorded` and `current` differ ("seed: recorded 3, now 4; ..."), or
/// "" when they are equal.
std::string IdentityDifferences(const RunIdentity& recorded, const RunIdentity& current);

/// What an evaluation's result depends on beyond the session (compared when
/// resuming): "configuration", a fingerprint of the canonical robot XML and
/// the rules (so comments and layout do not count), and "evaluation", every
/// setting an Evaluate request carries (world, a fingerprint of the
/// morphology, warm-up, duration, seed, time step).
RunIdentity EvaluationIdentity(const OptimizationConfig& config,
                               const EvaluationSettings& settings);

/// One evaluation read back from evaluations.csv.
struct RecordedEvaluation {
  long long index = 0;        ///< Its index column (= its row number).
  std::vector<double> values; ///< The candidate's values, in column order.
  Evaluation evaluation;      ///< velocity, distance, diverged, host, wall_seconds.
};

/// The readable part of an evaluations.csv.
struct EvaluationRecordFile {
  std::vector<std::string> columns;        ///< Candidate parameter names; empty without a header.
  std::vector<RecordedEvaluation> rows;    ///< Complete rows, index 0, 1, ...
  std::uintmax_t valid_bytes = 0;          ///< Length of the file up to the last good line.
  bool torn = false;                       ///< A torn last line was dropped.
  std::string torn_reason;                 ///< Why that line was dropped.
};

/// Parses evaluations.csv text as Session writes it. The last line may be
/// torn (no newline, a wrong field count, unparsable numbers, an unexpected
/// index): it is dropped and reported. Any other damaged line throws
/// kDataLoss naming `source`:LINE. Numbers are read back exactly.
EvaluationRecordFile ParseEvaluationRecord(std::string_view text, const std::string& source);

/// Reads and parses the file at `path`; a missing file is an empty record.
EvaluationRecordFile ReadEvaluationRecord(const std::string& path);

/// Splits one CSV line as Session writes them (quoted fields with doubled
/// quotes). Returns false for an unterminated quote.
bool SplitCsvLine(std::string_view line, std::vector<std::string>& fields);

}  // namespace yamor::optimizer
