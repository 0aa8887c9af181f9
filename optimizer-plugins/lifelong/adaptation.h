// Adaptation (thesis 7.4): what to relearn after an anomaly. When the body
// changed, the CPG network is rebuilt from the current module graph
// (cpg/problem.h: network, loop constraints, symmetries, at most seven free
// parameters), warm-started from the current gait projected onto the new
// body's symmetry ties; when it did not, the same parameters are relearned,
// starting from the current gait.
#pragma once

#include <cstdint>
#include <set>
#include <string>
#include <vector>

#include "cpg/module_graph.h"

namespace yamor::lifelong {

/// How problems are generated.
struct AdaptationOptions {
  int max_free = 7;            ///< Budget of free parameters of a rebuilt network.
  std::uint64_t seed = 1;      ///< Seed of the budget rule.
  bool use_symmetry = true;    ///< Tie parameters across the body's symmetries.
  /// A rebuilt network imposes every tie of the new body's symmetries, the
  /// current gait projected onto them (cpg::ProblemOptions::impose_symmetry).
  /// The old gait was learned on another body, so its asymmetries are no
  /// reason to leave the new body's ties out: with them left out the
  /// transformed quadruped relearned 3.7 cm/s in 100 evaluations, with them
  /// 6.5 (docs/benchmarks.md, "Lifelong learning"). False: the ties the
  /// current gait satisfies only, the start point exactly the current gait.
  bool impose_symmetry = true;
  bool couple_across_passive = true;  ///< cpg::NetworkOptions.
};

/// The problem to relearn.
struct AdaptationPlan {
  /// "rebuilt" (network from the body), "same parameters" (the current
  /// gait's rules) or "generated" (the current gait had no rules, or they
  /// no longer fit: a problem from the body, network kept as the body gives it).
  std::string how;
  std::string problem_xml;       ///< Optimization configuration (robot + rules).
  std::string start_config_xml;  ///< The robot configuration at the start point.
  std::vector<std::string> free; ///< The free parameters, in order.
  std::string explanation;       ///< One paragraph for the event log.
};

/// The module graph `body` with driven/passive flags: a module is driven
/// when it is in `driven` and not in `dead`.
cpg::ModuleGraph WithKnownActivity(const cpg::ModuleGraph& body, const std::set<int>& driven,
                                   const std::set<int>& dead);

/// The rules of `problem_xml` over the robot of `robot_xml`: the same
/// parameters optimized from another start. Throws yamor::Error
/// kInvalidArgument when a rule does not fit the robot.
std::string RulesOver(const std::string& problem_xml, const std::string& robot_xml);

/// Plans the relearning. `graph` carries the driven/passive flags;
/// `current_problem_xml` may be empty. Throws yamor::Error when no problem
/// can be made (no driven module in the largest piece).
AdaptationPlan PlanAdaptation(const cpg::ModuleGraph& graph, const std::string& current_config_xml,
                              const std::string& current_problem_xml, bool body_changed,
                              const AdaptationOptions& options);

}  // namespace yamor::lifelong
