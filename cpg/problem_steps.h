// The steps of GenerateProblem (cpg/problem.cc), one function per rule of
// docs/cpg_build.md, in the order GenerateProblem runs them:
//
//   rule (docs/cpg_build.md)                       step                          file
//   §2 couplings of the base                       KeepBaseCouplings             problem_ties.cc
//   §4 ties (symmetry; mirror -> rotations)        SymmetryTies                  problem_ties.cc
//   §6 rule 1: a tie the base contradicts          SplitTiesTheBaseContradicts   problem_ties.cc
//   §3 loop constraints, §4 looped ties split      SolvePhases                   phase_system.cc
//   §6 warm start                                  WarmStartProblem              problem_start.cc
//   candidates: one per class                      MakeCandidates                problem_budget.cc
//   §4 budget rule, steps (1) (2) (2b) (3) (4) (5) ApplyBudgetRule               problem_budget.cc
//   §6 tied members start together                 StartTiedMembersTogether      problem_start.cc
//   §6 rule 3: a box holds the base value          WidenBoxesToBase              problem_start.cc
//   §3/§6 rule 4: rules keep the base's loop sums  PhaseRules                    phase_system.cc
//
// Exposed for GenerateProblem and for the tests of each rule
// (tests/cpg/problem_steps_test.cc). Stateless functions: safe from any
// thread; each changes only what it is given.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <set>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "cpg/module_graph.h"
#include "cpg/network_builder.h"
#include "cpg/phase_system.h"
#include "cpg/problem.h"
#include "cpg/robot_config.h"
#include "cpg/symmetry.h"

namespace yamor::cpg {

/// Amplitude classes: representative (smallest id) -> members, ascending.
using AmplitudeClasses = std::map<ModuleId, std::vector<ModuleId>>;
/// Offset classes: representative -> (member, servo sign against the
/// representative): offset(member) = sign·offset(representative).
using OffsetClasses = std::map<ModuleId, std::vector<std::pair<ModuleId, int>>>;

/// The ties among a problem's parameters.
struct ParameterTies {
  AmplitudeClasses amplitudes;  ///< Modules sharing one amplitude.
  OffsetClasses offsets;        ///< Modules sharing one offset, with servo signs.
  std::vector<EdgeTie> phases;  ///< One per network edge.
};

/// " 1 2 3" for a list of ids (the form of every id list in notes).
std::string SpacedIds(const std::vector<ModuleId>& ids);
/// The largest amplitude a module's limit angles allow: half their range,
/// at most π/2.
double AmplitudeMax(const ModuleParams& m);
/// The value `param` ("amplitude.3", "offset.3", "phase.0.1") has in
/// `robot`; 0 for a coupling it does not have.
double ParameterValue(const RobotConfig& robot, const std::string& param);

/// §2 "Couplings of the base": a coupling of `base` between two oscillators
/// of `network` that the body connects, directly or across passive modules
/// only, joins the network (marked from_base, named in `notes`) even where
/// the construction rule gives none; one between modules the body no longer
/// connects stays out (the network follows the body, thesis 7.4). Edges stay
/// sorted by (u, v).
void KeepBaseCouplings(const ModuleGraph& graph, const RobotConfig& base, CpgNetwork& network,
                       std::vector<std::string>& notes);

/// §4 "Ties": modules in one orbit of `elements` (symmetries of `piece`,
/// the network's piece of the graph) share their amplitude and, with the
/// map's servo sign, their offset; a coupling shares its image's phase,
/// negated when the map reverses the edge, plus π when it reverses exactly
/// one servo. Where a mirror maps a moving module or a coupling onto its own
/// reverse, those classes fall back to the rotations' ties (the modules
/// named in `notes`). Keep-free edges stay alone. Phase classes are not yet
/// normalised (Normalise).
ParameterTies SymmetryTies(const ModuleGraph& piece, const std::vector<Symmetry>& elements,
                           const std::set<ModuleId>& driven, const CpgNetwork& network,
                           const std::set<int>& keep_free, std::vector<std::string>& notes);

/// The phases `base` gives each network edge (§6).
BasePhases BasePhasesOf(const RobotConfig& base, const std::vector<NetworkEdge>& edges);

/// §6 "The base is the start point", rule 1: a tie the base contradicts is
/// not imposed. Each amplitude, offset and phase class is split into groups
/// of equal base values (offsets with the tie's servo sign, phases with its
/// sign and π shift); what the base does not give joins the first group.
/// `notes` names every split class. (--impose-symmetry skips this step.)
void SplitTiesTheBaseContradicts(ParameterTies& ties, const RobotConfig& base, const BasePhases& base_phases,
                                 const std::vector<NetworkEdge>& edges, std::vector<std::string>& notes);

/// §6 "Warm start": the robot of the problem before the budget rule.
/// Surviving modules and couplings keep the base's values (WarmStart); a new
/// module's amplitude and offset are clamped into its limits, then it takes
/// its offset class's values (offset and limits mirrored by the servo sign);
/// a new coupling takes its phase class's phase (`ties.phases`, before
/// SolvePhases); every phase starts in [0, 2π).
RobotConfig WarmStartProblem(const ModuleGraph& graph, const CpgNetwork& network, const RobotConfig& base,
                             const std::set<ModuleId>& driven, const ParameterTies& ties,
                             const ProblemOptions& options);

/// The candidates for the free set, one per class, each with its box.
struct Candidates {
  std::vector<FreeParameter> amplitudes;  ///< One per amplitude class.
  std::vector<FreeParameter> offsets;     ///< One per offset class.
  std::vector<FreeParameter> phases;      ///< One per free phase class.

  /// How many there are.
  std::size_t Total() const { return amplitudes.size() + offsets.size() + phases.size(); }
};

/// The candidates: one amplitude per amplitude class (box [0, the tightest
/// AmplitudeMax of its members]), one offset per offset class (box: the
/// representative's limit angles), one phase per free class of `sol` (box
/// [0, 2π]), in class order.
Candidates MakeCandidates(const ParameterTies& ties, const PhaseSolution& sol,
                          const std::vector<NetworkEdge>& edges, const RobotConfig& robot);

/// What the budget rule works on and what it decides.
struct BudgetState {
  std::size_t budget = 7;                    ///< The budget of free parameters (--max-free).
  Candidates free;                           ///< Still free.
  AmplitudeClasses amplitude_classes;        ///< Steps 2 and 2b merge these.
  std::vector<std::string> fixed;            ///< Parameters fixed, in the order fixed.
  std::vector<FreeParameter> fixed_offsets;  ///< Step 1's offsets, in the order fixed.
  std::vector<std::string> notes;            ///< What steps 2 and 2b tied.
};

/// The key two amplitude classes must share for the budget rule to tie them.
using AmplitudeKey = std::tuple<double, double, double>;

/// §4 "Budget rule" step (1): offsets are fixed from the back of
/// `state.free.offsets` (in the seeded order) while the free set is above
/// the budget.
void FixOffsets(BudgetState& state);
/// §4 "Budget rule" steps (2) and (2b): amplitude classes whose
/// representatives in `robot` have the same `key` become one class, its
/// representative the smallest id, its box the tightest; `what` names the
/// key in the note. A no-op when no two classes share a key.
void TieAmplitudes(BudgetState& state, const RobotConfig& robot,
                   const std::function<AmplitudeKey(const ModuleParams&)>& key, const std::string& what);
/// §4 "Budget rule" step (3): phases are fixed from the back (the seeded
/// order) while the free set is above the budget.
void FixPhases(BudgetState& state);
/// §4 "Budget rule" step (4): amplitudes are fixed from the back while the
/// free set is above the budget.
void FixAmplitudes(BudgetState& state);
/// §4 "Budget rule" step (5): while the free set is below the budget,
/// offsets step (1) fixed are freed again, the last fixed first.
void FreeFixedOffsets(BudgetState& state);
/// §4 "Budget rule", all of it: offsets and phases shuffled by `seed`
/// (a fixed Fisher–Yates over std::mt19937_64), then steps (1), (2) (same
/// limit angles and start amplitude), (2b) (same start amplitude), (3),
/// (4), (5), each only while the free set is above (or, for 5, below) the
/// budget. What is fixed keeps its value in `robot`.
void ApplyBudgetRule(BudgetState& state, const RobotConfig& robot, std::uint64_t seed);

/// The classes whose start value the base configures.
struct BaseClasses {
  std::set<ModuleId> amplitudes;  ///< Amplitude class representatives.
  std::set<ModuleId> offsets;     ///< Offset class representatives.
};

/// §6 "Warm start": tied members start at their class's value, where the
/// base puts the class (its first configured member's value) or else at the
/// representative's; classes the base does not configure are clamped into
/// their limits. Returns the classes the base configures.
BaseClasses StartTiedMembersTogether(RobotConfig& robot, const AmplitudeClasses& amplitudes,
                                     const OffsetClasses& offsets, const RobotConfig& base);

/// §6 "The base is the start point", rule 3: the box of a free amplitude or
/// offset whose class the base configures widens to hold its start value in
/// `robot`.
void WidenBoxesToBase(Candidates& free, const BaseClasses& base_classes, const RobotConfig& robot);

}  // namespace yamor::cpg
