// The phase system of a generated problem (docs/cpg_build.md §3, "Loop
// constraints"): which coupling phases are free and which follow from them so
// that every loop of the network sums to a multiple of 2π. A spanning tree
// and its fundamental cycles replace the thesis's loop enumeration (7.4.2);
// Gaussian elimination over the cycle equations chooses what each loop
// constrains. Symmetry ties between phases (§4) enter as classes of edges;
// classes a loop cannot close are split apart again. Stateless functions:
// safe from any thread.
#pragma once

#include <map>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "cpg/module_graph.h"
#include "cpg/network_builder.h"

namespace yamor::cpg {

/// A constrain rule of a generated problem: an optimization config `<constrain>`.
struct TiedParameter {
  std::string param;  ///< e.g. "phase.3.0".
  std::string expr;   ///< muParser expression, e.g. "M2Pi(phase.0.1() + phase.1.2())".
};

/// The phase part on its own: for the undirected couplings `edges` (u < v)
/// among `vertices`, the free phases and the rules that make every loop sum
/// to a multiple of 2π, with no symmetry ties. Keep-free edges stay free.
/// Used by GenerateProblem and by tests.
struct PhaseSystem {
  std::vector<std::string> free;      ///< "phase.u.v" of the free couplings.
  std::vector<TiedParameter> tied;    ///< Rules for every other directed coupling.
  std::vector<std::string> loops;     ///< Fundamental cycles.
};
/// Builds the phase system. Errors as GenerateProblem's for keep-free edges.
PhaseSystem BuildPhaseSystem(const std::vector<ModuleId>& vertices,
                             const std::vector<NetworkEdge>& edges,
                             const std::vector<std::pair<ModuleId, ModuleId>>& keep_free = {});

// ---- The steps, for GenerateProblem (cpg/problem.cc) and the tests. ----

/// Base values closer than this are the same value (they are read from
/// decimal text, so equal texts give equal doubles; the margin only absorbs
/// rounding).
inline constexpr double kSameValue = 1e-9;
/// The distance between two angles on the circle, in [0, π].
double AngleGap(double a, double b);
/// "phase.from.to".
std::string PhaseName(ModuleId from, ModuleId to);
/// "u-v" of a network edge.
std::string EdgeName(const NetworkEdge& e);

/// Where an edge's phase comes from: x_e = sign·y_cls + pi·π, y_cls the
/// phase of its class (§4, "Ties": negated when a symmetry reverses the
/// edge, plus π when it reverses exactly one servo).
struct EdgeTie {
  int cls = 0;   ///< Class of the edge.
  int sign = 1;  ///< +1 or -1.
  int pi = 0;    ///< 0 or 1: half a period added.
};

/// Renumbers classes 0..K-1 in the order of their first edge and makes that
/// edge its class's representative (sign +1, pi 0).
void Normalise(std::vector<EdgeTie>& ties);

/// The indices in `edges` of the keep-free couplings (either order).
/// kInvalidArgument naming a pair that is not a coupling of the network.
std::set<int> KeepFreeIndices(const std::vector<NetworkEdge>& edges,
                              const std::vector<std::pair<ModuleId, ModuleId>>& keep_free);

/// The spanning tree of §3: keep-free edges first, then the edges a
/// depth-first walk from the smallest vertex (neighbours ascending) goes
/// along, then the rest, so a ring's free lags are consecutive and its
/// closing edge is constrained (Table 6.1). One flag per edge: in the tree.
/// kInvalidArgument when keep-free edges close a loop among themselves.
std::vector<bool> SpanningTree(const std::vector<ModuleId>& vertices, const std::vector<NetworkEdge>& edges,
                               const std::set<int>& keep_free);

/// A fundamental cycle: u -> v over a non-tree edge, back to u in the tree.
struct Cycle {
  std::vector<std::pair<int, int>> terms;  ///< (edge, +1 walked small->large id / -1).
  std::string text;                        ///< "0-1-2-3-0".
};
/// The fundamental cycles of the tree `in_tree`, one per non-tree edge in
/// edge order (§3: they span every loop).
std::vector<Cycle> FundamentalCycles(const std::vector<ModuleId>& vertices, const std::vector<NetworkEdge>& edges,
                                     const std::vector<bool>& in_tree);

/// A linear relation over class variables: Σ coef·y + pi·π (pi mod 2).
struct Row {
  std::map<int, int> coef;  ///< Class -> integer coefficient, no zeros.
  int pi = 0;               ///< 0 or 1.

  /// Adds a·y_cls.
  void Add(int cls, int a);
  /// Adds factor·other.
  void AddRow(const Row& other, int factor);
};

/// A solved phase system.
struct PhaseSolution {
  std::vector<EdgeTie> ties;         ///< Final classes (after any split).
  std::vector<int> free_classes;     ///< In class order.
  std::map<int, Row> pivots;         ///< Constrained class -> expression over free classes.
  std::vector<std::string> loops;    ///< Fundamental cycles.
  std::vector<std::string> untied;   ///< Classes split apart, with the reason.
};

/// Solves the loop equations over the edge classes `ties` (§3, and §4's
/// last tie rule: tied couplings that form a loop among themselves are split
/// apart and left to the loop constraints, each split named in `untied`).
/// `base_edge` (empty or one flag per edge): edges whose phase the base
/// configuration gives; a loop constrains a class without such edges first,
/// so the base's phases stay where the base puts them (§6 rule 4).
PhaseSolution SolvePhases(const std::vector<ModuleId>& vertices, const std::vector<NetworkEdge>& edges,
                          std::vector<EdgeTie> ties, const std::set<int>& keep_free,
                          const std::vector<bool>& base_edge = {});

/// Class -> "phase.u.v" of its representative (its first edge).
std::vector<std::string> ClassNames(const PhaseSolution& sol, const std::vector<NetworkEdge>& edges);

/// The base configuration's phases per network edge u-v (u < v): u -> v
/// (or minus v -> u) and v -> u, where the base configures them.
struct BasePhases {
  std::vector<std::optional<double>> forward;   ///< Phase u -> v.
  std::vector<std::optional<double>> backward;  ///< Phase v -> u.
};

/// The constrain rules of a solved system: pivots, tied class members, then
/// every back-link. With `base`, a loop whose phases the base configures
/// keeps the base's sum (§3, §6 rule 4; `notes` says where that sum is not
/// zero), so the base is a point of the problem.
std::vector<TiedParameter> PhaseRules(const PhaseSolution& sol, const std::vector<NetworkEdge>& edges,
                                      const BasePhases* base = nullptr,
                                      std::vector<std::string>* notes = nullptr);

}  // namespace yamor::cpg
