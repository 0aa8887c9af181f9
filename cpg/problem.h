// From body to brain (thesis 7.4, 7.8.1): a robot configuration and an
// optimization problem generated from a module graph. The CPG network comes
// from the graph (network_builder.h); the loop constraints from a spanning
// tree and its fundamental cycles (polynomial, not the thesis's loop
// enumeration); parameters are tied across the robot's symmetries
// (symmetry.h) instead of fixed at random; a documented, seeded rule fixes
// what is still above the budget. docs/cpg_build.md explains every rule;
// cpg/problem_steps.h lists the steps that implement them, one per rule.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "cpg/module_graph.h"
#include "cpg/network_builder.h"
#include "cpg/phase_system.h"
#include "cpg/robot_config.h"
#include "cpg/symmetry.h"

namespace yamor::cpg {

/// How a problem is generated.
struct ProblemOptions {
  NetworkOptions network;           ///< Network construction.
  bool use_symmetry = true;         ///< Tie parameters across symmetries.
  /// Impose every symmetry tie even where the base contradicts it (a gait
  /// learned on another body): the start point is then the base projected
  /// onto the ties (each class at its first configured member's value, loops
  /// closed without the base's sums), not the base itself. Off: only the
  /// ties the base satisfies (docs/cpg_build.md, "The base is the start point").
  bool impose_symmetry = false;
  SymmetryOptions symmetry;         ///< Which symmetries count.
  int max_free = 7;                 ///< Budget of free parameters (>= 1).
  uint64_t seed = 1;                ///< Seed of the reduction rule.
  /// Couplings (either order) whose phase must stay a free parameter of its
  /// own: never constrained by a loop, never tied to another.
  std::vector<std::pair<ModuleId, ModuleId>> keep_free;
  double default_amplitude = 0.5;   ///< Amplitude [rad] of a module nothing else gives one.
  double default_speed = 0.5;       ///< Speed [Hz] when no module gives one.
};

/// A free parameter with its bounds.
struct FreeParameter {
  std::string param;  ///< e.g. "amplitude.0".
  double min = 0;     ///< Lower bound.
  double max = 0;     ///< Upper bound.
  std::string note;   ///< What it stands for ("amplitude of modules 0 1 2 3").
};

/// A parameter the budget rule took out of the free set.
struct FixedParameter {
  std::string param;  ///< The parameter.
  double value = 0;   ///< The value it keeps (the warm start's).
};

/// A generated problem.
struct GeneratedProblem {
  std::string key;                   ///< MorphologyKey of the graph.
  CpgNetwork network;                ///< The oscillator network.
  SymmetryGroup symmetry;            ///< Symmetries used (empty when off).
  RobotConfig robot;                 ///< The robot configuration, warm-started.
  std::vector<FreeParameter> free;   ///< Optimized parameters, in order.
  std::vector<TiedParameter> tied;   ///< Constrain rules, in evaluation order.
  std::vector<FixedParameter> fixed; ///< Taken out by the budget rule.
  std::vector<std::string> loops;    ///< Fundamental cycles, "0-1-2-3-0".
  std::vector<std::string> notes;    ///< Ignored modules, untied orbits, ...
  std::string graph_text;            ///< ModuleGraph::Describe() of the input.

  /// The optimization configuration (robot XML plus <optimize>/<constrain>
  /// rules) that optimizer::OptimizationConfig loads.
  std::string OptimizationXml() const;
  /// A human-readable account: graph, network, orbits, loops, constraints,
  /// the free set and what was fixed.
  std::string Explain() const;
};

/// Generates the problem for `graph`. `base` (may be null) is the
/// configuration to warm-start from and to take limit angles from: modules
/// and couplings that survive keep their values, new ones take their orbit's
/// value, else a neighbour's, else the defaults. Errors (yamor::Error
/// kInvalidArgument, naming the module or edge): no driven module in the
/// largest piece, a keep-free edge that is not a coupling of the network or
/// keep-free edges that close a loop, max_free < 1. Deterministic for the
/// same graph, base, options and seed.
GeneratedProblem GenerateProblem(const ModuleGraph& graph, const RobotConfig* base,
                                 const ProblemOptions& options = {});

/// Maps an old configuration onto the network of `graph` (the warm start of
/// GenerateProblem, without symmetry ties): surviving modules keep amplitude,
/// offset, speed and limits; surviving couplings keep phase and weight; new
/// ones take a neighbour's value or the defaults. Deterministic.
RobotConfig WarmStart(const ModuleGraph& graph, const CpgNetwork& network, const RobotConfig& base,
                      const ProblemOptions& options = {});

}  // namespace yamor::cpg
