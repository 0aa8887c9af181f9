// Test helpers shared by the plugin tests: boxes of plain parameters and an
// evaluator that records the size of every batch a plugin submits.
#pragma once

#include <cstddef>
#include <map>
#include <string>
#include <vector>

#include "tests/optimizer-plugins/plugin_test_util.h"

namespace yamor::optimizer::testing {

/// Parameters x0..x{n-1}, each in [lo, hi], starting at `start[i]`.
inline std::vector<ProblemParameter> Box(double lo, double hi, const std::vector<double>& start) {
  std::vector<ProblemParameter> out;
  for (std::size_t i = 0; i < start.size(); ++i) {
    std::string name = "x";  // not "x" + ...: g++ 12 -Wrestrict false positive
    name += std::to_string(i);
    out.push_back({name, lo, hi, start[i]});
  }
  return out;
}

/// Evaluates a PointFunction and remembers each batch's size. Not
/// thread-safe (sessions call it from one thread).
class BatchRecorder final : public Evaluator {
 public:
  /// Evaluates `f`.
  explicit BatchRecorder(PointFunction f) : f_(std::move(f)) {}
  std::vector<Evaluation> EvaluateBatch(const std::vector<Candidate>& batch) override {
    sizes_.push_back(batch.size());
    std::vector<Evaluation> out;
    for (const Candidate& c : batch) {
      std::vector<double> x;
      for (const auto& [name, value] : c.parameters) x.push_back(value);
      Evaluation e;
      e.velocity = f_(x);
      e.host = "local";
      out.push_back(e);
    }
    return out;
  }
  void RequestStop() override {}
  int Capacity() const override { return 1; }
  /// Every batch's size, in order.
  const std::vector<std::size_t>& sizes() const { return sizes_; }

 private:
  PointFunction f_;
  std::vector<std::size_t> sizes_;
};

/// Runs `plugin` through a session on a BatchRecorder; returns the batch sizes.
inline std::vector<std::size_t> BatchSizes(const LoadedPlugin& plugin, std::vector<ProblemParameter> parameters,
                                           const PointFunction& f, std::map<std::string, std::string> set,
                                           SessionResult* result = nullptr, std::uint64_t seed = 1) {
  Problem problem = PlainProblem(std::move(parameters));
  BatchRecorder evaluator(f);
  Session session(plugin, problem, evaluator, {.seed = seed, .set = std::move(set)});
  SessionResult r = session.Run();
  if (result != nullptr) *result = r;
  return evaluator.sizes();
}

/// True when both runs evaluated the same points with the same values.
inline bool SameRecords(const std::vector<EvaluationRecord>& a, const std::vector<EvaluationRecord>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t k = 0; k < a.size(); ++k) {
    if (a[k].point != b[k].point || a[k].evaluation.velocity != b[k].evaluation.velocity) return false;
  }
  return true;
}

/// True when every recorded point lies inside its parameter's bounds.
inline bool AllInside(const std::vector<EvaluationRecord>& records, const std::vector<ProblemParameter>& p) {
  for (const auto& r : records) {
    for (std::size_t i = 0; i < p.size(); ++i) {
      if (!(r.point[i] >= p[i].min && r.point[i] <= p[i].max)) return false;
    }
  }
  return true;
}

}  // namespace yamor::optimizer::testing
