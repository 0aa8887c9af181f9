#include "optimizer-plugins/framework/evaluator.h"

#include <spdlog/fmt/fmt.h>

#include <chrono>

#include "common/status.h"

namespace yamor::optimizer {

std::string FormatCandidate(const Candidate& candidate) {
  std::string out = "{";
  for (const auto& [name, value] : candidate.parameters) {
    if (out.size() > 1) out += ", ";
    out += fmt::format("{}={}", name, value);
  }
  return out + "}";
}

std::vector<Evaluation> FunctionEvaluator::EvaluateBatch(const std::vector<Candidate>& batch) {
  std::vector<Evaluation> out;
  out.reserve(batch.size());
  for (const Candidate& candidate : batch) {
    if (stop_.load()) throw Error(StatusCode::kCancelled, "evaluation stopped");
    const auto start = std::chrono::steady_clock::now();
    Evaluation e;
    e.velocity = function_(candidate.parameters);
    e.host = "local";
    e.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    ++count_;
    out.push_back(std::move(e));
  }
  return out;
}

}  // namespace yamor::optimizer
