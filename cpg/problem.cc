#include "cpg/problem.h"

#include <algorithm>
#include <set>
#include <sstream>

#include "common/format.h"
#include "common/status.h"
#include "cpg/config_xml.h"
#include "cpg/problem_steps.h"

namespace yamor::cpg {
namespace {

// Sort key of a parameter name: its kind, then its ids as numbers.
std::vector<int> ParamOrder(const std::string& param) {
  std::vector<int> key{param[0] == 'a' ? 0 : param[0] == 'o' ? 1 : 2};
  std::stringstream in(param.substr(param.find('.') + 1));
  std::string id;
  while (std::getline(in, id, '.')) key.push_back(std::stoi(id));
  return key;
}

// The free set in a fixed order (the seeded order only chose what to fix):
// amplitudes, offsets, then phases, each by representative.
std::vector<FreeParameter> FreeSet(const Candidates& free) {
  std::vector<FreeParameter> out;
  for (const auto* group : {&free.amplitudes, &free.offsets, &free.phases}) {
    std::vector<FreeParameter> sorted = *group;
    std::sort(sorted.begin(), sorted.end(), [](const FreeParameter& x, const FreeParameter& y) {
      return ParamOrder(x.param) < ParamOrder(y.param);
    });
    out.insert(out.end(), sorted.begin(), sorted.end());
  }
  return out;
}

// The module ties as constrain rules: each member of a class follows its
// representative (offsets with the servo sign).
std::vector<TiedParameter> ModuleTieRules(const AmplitudeClasses& amplitudes, const OffsetClasses& offsets) {
  std::vector<TiedParameter> rules;
  for (const auto& [rep, members] : amplitudes) {
    for (ModuleId id : members) {
      if (id != rep) rules.push_back({"amplitude." + std::to_string(id), "amplitude." + std::to_string(rep) + "()"});
    }
  }
  for (const auto& [rep, members] : offsets) {
    for (const auto& [id, sign] : members) {
      if (id == rep) continue;
      std::string expr = sign > 0 ? "offset." : "-offset.";
      expr += std::to_string(rep) + "()";
      rules.push_back({"offset." + std::to_string(id), expr});
    }
  }
  return rules;
}

}  // namespace

// The rules of docs/cpg_build.md in order; cpg/problem_steps.h says which
// function and file implements each.
GeneratedProblem GenerateProblem(const ModuleGraph& graph, const RobotConfig* base,
                                 const ProblemOptions& options) {
  if (options.max_free < 1) {
    throw Error(StatusCode::kInvalidArgument,
                "the free-parameter budget must be at least 1, not " + std::to_string(options.max_free));
  }
  GeneratedProblem out;
  out.graph_text = graph.Describe();
  out.key = MorphologyKey(graph);
  // §2: the network, with the base's couplings the body still gives.
  out.network = BuildNetwork(graph, options.network);
  if (base != nullptr) KeepBaseCouplings(graph, *base, out.network, out.notes);
  const CpgNetwork& net = out.network;
  if (!net.ignored.empty()) {
    out.notes.push_back("modules" + SpacedIds(net.ignored) + " are not connected to the largest piece and are ignored");
  }
  if (!net.passive.empty()) {
    out.notes.push_back("passive modules" + SpacedIds(net.passive) +
                        " have no oscillator; the network couples across them");
  }
  std::set<ModuleId> driven;
  for (ModuleId id : net.oscillators) {
    if (graph.Module(id).active) driven.insert(id);
  }
  const std::set<int> keep_free = KeepFreeIndices(net.edges, options.keep_free);

  // §4: ties across the symmetries of the piece.
  const ModuleGraph piece = graph.Subgraph(net.piece);
  if (options.use_symmetry) out.symmetry = FindSymmetries(piece, options.symmetry);
  ParameterTies ties = SymmetryTies(piece, out.symmetry.elements, driven, net, keep_free, out.notes);

  // §6 rule 1: only the ties the base satisfies (all of them with
  // impose_symmetry: the start point is then the base projected onto them).
  RobotConfig empty;
  empty.master_id = graph.central();
  const RobotConfig& from = base ? *base : empty;
  const BasePhases base_phases = BasePhasesOf(from, net.edges);
  const bool split_by_base = !options.impose_symmetry;
  if (split_by_base) SplitTiesTheBaseContradicts(ties, from, base_phases, net.edges, out.notes);
  Normalise(ties.phases);

  // §3: loop constraints over the phase classes.
  std::vector<bool> base_edge(net.edges.size());
  for (size_t e = 0; e < net.edges.size(); ++e) base_edge[e] = base_phases.forward[e].has_value();
  const PhaseSolution sol = SolvePhases(net.oscillators, net.edges, ties.phases, keep_free, base_edge);
  out.loops = sol.loops;
  for (const std::string& u : sol.untied) out.notes.push_back(u);

  // §6: the warm-started robot.
  out.robot = WarmStartProblem(graph, net, from, driven, ties, options);

  // §4: the budget rule (cpg/problem_budget.cc) over one candidate per class.
  Candidates candidates = MakeCandidates(ties, sol, net.edges, out.robot);
  BudgetState budget{.budget = static_cast<size_t>(options.max_free),
                     .free = std::move(candidates),
                     .amplitude_classes = ties.amplitudes};
  ApplyBudgetRule(budget, out.robot, options.seed);
  for (std::string& n : budget.notes) out.notes.push_back(std::move(n));

  // §6: tied members start together; boxes hold the base's values.
  const BaseClasses base_classes =
      StartTiedMembersTogether(out.robot, budget.amplitude_classes, ties.offsets, from);
  for (const std::string& f : budget.fixed) out.fixed.push_back({f, ParameterValue(out.robot, f)});
  WidenBoxesToBase(budget.free, base_classes, out.robot);
  out.free = FreeSet(budget.free);
  if (!out.fixed.empty()) {
    out.notes.push_back(std::to_string(out.fixed.size()) + " parameter(s) above the budget of " +
                        std::to_string(options.max_free) + " fixed at their warm-start values (seed " +
                        std::to_string(options.seed) + ")");
  }

  // The rules: module ties, then phases (§3, §6 rule 4: loops keep the
  // base's sums).
  out.tied = ModuleTieRules(budget.amplitude_classes, ties.offsets);
  for (TiedParameter& t : PhaseRules(sol, net.edges, split_by_base ? &base_phases : nullptr, &out.notes)) {
    out.tied.push_back(std::move(t));
  }
  return out;
}

std::string GeneratedProblem::OptimizationXml() const {
  std::string xml = WriteConfigXml(robot);
  const std::string close = "</yamorconfig>";
  const auto at = xml.rfind(close);
  YAMOR_CHECK(at != std::string::npos, "robot XML without </yamorconfig>");
  std::ostringstream rules;
  rules << "  <!-- generated by yamor-cpg-build; morphology key " << key << " -->\n";
  for (const FixedParameter& f : fixed) {
    rules << "  <!-- fixed by the budget rule: " << f.param << " = " << FormatDouble(f.value) << " -->\n";
  }
  for (const FreeParameter& p : free) {
    rules << "  <optimize param=\"" << p.param << "\" min=\"" << FormatDouble(p.min) << "\" max=\""
          << FormatDouble(p.max) << "\"/>  <!-- " << p.note << " -->\n";
  }
  for (const TiedParameter& t : tied) {
    rules << "  <constrain param=\"" << t.param << "\" expr=\"" << t.expr << "\"/>\n";
  }
  return xml.substr(0, at) + rules.str() + xml.substr(at);
}

std::string GeneratedProblem::Explain() const {
  std::ostringstream out;
  out << "morphology key: " << key << "\n\n" << graph_text << "\nCPG network: " << network.oscillators.size()
      << " oscillators, " << network.edges.size() << " couplings (each both ways)\n";
  for (const NetworkEdge& e : network.edges) {
    out << "  " << e.u << " <-> " << e.v;
    if (e.from_base) {
      out << "  (from the base configuration)";
    } else if (!e.physical) {
      out << "  (across passive module " << e.via << ")";
    }
    out << "\n";
  }
  out << "\nsymmetries: group of order " << symmetry.full_order;
  if (symmetry.dropped_for_gravity > 0) {
    out << ", " << symmetry.dropped_for_gravity << " element(s) left out because they turn the robot over";
  }
  out << "; " << symmetry.elements.size() << " used" << (symmetry.enumerated ? "" : " (generators only)")
      << "\norbits:";
  for (const auto& orbit : symmetry.orbits) {
    out << " {";
    for (size_t i = 0; i < orbit.size(); ++i) out << (i ? " " : "") << orbit[i];
    out << "}";
  }
  out << "\n\nloops (fundamental cycles of a spanning tree): " << loops.size() << "\n";
  for (const std::string& l : loops) out << "  " << l << "\n";
  out << "\nfree parameters: " << free.size() << "\n";
  for (const FreeParameter& p : free) {
    out << "  " << p.param << " in [" << FormatDouble(p.min) << ", " << FormatDouble(p.max) << "]  " << p.note
        << "\n";
  }
  if (!fixed.empty()) {
    out << "fixed by the budget rule:\n";
    for (const FixedParameter& f : fixed) out << "  " << f.param << " = " << FormatDouble(f.value) << "\n";
  }
  out << "constraints: " << tied.size() << "\n";
  for (const TiedParameter& t : tied) out << "  " << t.param << " = " << t.expr << "\n";
  if (!notes.empty()) {
    out << "notes:\n";
    for (const std::string& n : notes) out << "  - " << n << "\n";
  }
  return out.str();
}

}  // namespace yamor::cpg
