// The budget rule of a generated problem (docs/cpg_build.md §4, "Budget
// rule"): what is above --max-free is fixed or tied in five steps, each a
// function below, ApplyBudgetRule runs them in order. See cpg/problem_steps.h.
#include "cpg/problem_steps.h"

#include <algorithm>
#include <numbers>
#include <random>

namespace yamor::cpg {
namespace {

constexpr double kPi = std::numbers::pi;

std::string Id(ModuleId id) { return std::to_string(id); }

// The ids of offset class members.
std::vector<ModuleId> MemberIds(const std::vector<std::pair<ModuleId, int>>& members) {
  std::vector<ModuleId> ids;
  for (const auto& x : members) ids.push_back(x.first);
  return ids;
}

// A fixed-algorithm shuffle so the seeded order is the same on every
// standard library.
template <typename T>
void SeededShuffle(std::vector<T>& items, std::mt19937_64& rng) {
  for (size_t i = items.size(); i > 1; --i) std::swap(items[i - 1], items[rng() % i]);
}

// Fixes the back of `from` while the free set is above the budget.
void FixFromTheBack(BudgetState& state, std::vector<FreeParameter>& from) {
  while (state.free.Total() > state.budget && !from.empty()) {
    state.fixed.push_back(from.back().param);
    from.pop_back();
  }
}

}  // namespace

Candidates MakeCandidates(const ParameterTies& ties, const PhaseSolution& sol,
                          const std::vector<NetworkEdge>& edges, const RobotConfig& robot) {
  Candidates out;
  for (const auto& [rep, members] : ties.offsets) {
    const ModuleParams& r = *robot.FindModule(rep);
    out.offsets.push_back(
        {"offset." + Id(rep), r.min_angle, r.max_angle, "offset of module(s)" + SpacedIds(MemberIds(members))});
  }
  for (const auto& [rep, members] : ties.amplitudes) {
    double max = kPi / 2;
    for (ModuleId id : members) max = std::min(max, AmplitudeMax(*robot.FindModule(id)));
    out.amplitudes.push_back({"amplitude." + Id(rep), 0.0, max, "amplitude of module(s)" + SpacedIds(members)});
  }
  const auto names = ClassNames(sol, edges);
  for (int cls : sol.free_classes) {
    std::string es;
    for (size_t e = 0; e < edges.size(); ++e) {
      if (sol.ties[e].cls == cls) {
        es += ' ';
        es += EdgeName(edges[e]);
      }
    }
    out.phases.push_back({names[cls], 0.0, 2 * kPi, "phase of coupling(s)" + es});
  }
  return out;
}

void FixOffsets(BudgetState& state) {
  while (state.free.Total() > state.budget && !state.free.offsets.empty()) {
    state.fixed.push_back(state.free.offsets.back().param);
    state.fixed_offsets.push_back(state.free.offsets.back());
    state.free.offsets.pop_back();
  }
}

void TieAmplitudes(BudgetState& state, const RobotConfig& robot,
                   const std::function<AmplitudeKey(const ModuleParams&)>& key, const std::string& what) {
  std::map<AmplitudeKey, std::vector<ModuleId>> groups;  // key -> class reps
  for (const auto& [rep, members] : state.amplitude_classes) groups[key(*robot.FindModule(rep))].push_back(rep);
  if (groups.size() == state.amplitude_classes.size()) return;  // nothing to tie
  AmplitudeClasses merged_classes;
  std::vector<FreeParameter> merged;
  for (const auto& [k, reps] : groups) {
    const ModuleId rep = *std::min_element(reps.begin(), reps.end());
    std::vector<ModuleId>& members = merged_classes[rep];
    double max = kPi / 2;
    for (ModuleId r : reps) {
      members.insert(members.end(), state.amplitude_classes.at(r).begin(), state.amplitude_classes.at(r).end());
      max = std::min(max, AmplitudeMax(*robot.FindModule(r)));
    }
    std::sort(members.begin(), members.end());
    std::string note = "amplitude of module(s)" + SpacedIds(members);
    if (reps.size() > 1) {
      note += " (tied by the budget rule)";
      state.notes.push_back("the budget rule ties the amplitudes of" + SpacedIds(members) + " (" + what +
                            ") to amplitude." + Id(rep));
    }
    merged.push_back({"amplitude." + Id(rep), 0.0, max, note});
  }
  state.amplitude_classes = std::move(merged_classes);
  state.free.amplitudes = std::move(merged);
}

void FixPhases(BudgetState& state) { FixFromTheBack(state, state.free.phases); }

void FixAmplitudes(BudgetState& state) { FixFromTheBack(state, state.free.amplitudes); }

void FreeFixedOffsets(BudgetState& state) {
  while (state.free.Total() < state.budget && !state.fixed_offsets.empty()) {
    const std::string name = state.fixed_offsets.back().param;
    state.fixed.erase(std::find(state.fixed.begin(), state.fixed.end(), name));
    state.free.offsets.push_back(std::move(state.fixed_offsets.back()));
    state.fixed_offsets.pop_back();
  }
}

void ApplyBudgetRule(BudgetState& state, const RobotConfig& robot, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  SeededShuffle(state.free.offsets, rng);
  SeededShuffle(state.free.phases, rng);
  FixOffsets(state);  // (1)
  // (2), (2b): the key holds the start amplitude too, so amplitudes the base
  // configures differently are never tied (the base stays a point of the
  // problem, §6 rule 2).
  if (state.free.Total() > state.budget) {
    TieAmplitudes(
        state, robot, [](const ModuleParams& p) { return AmplitudeKey{p.min_angle, p.max_angle, p.amplitude}; },
        "same limit angles");
  }
  if (state.free.Total() > state.budget) {
    TieAmplitudes(
        state, robot, [](const ModuleParams& p) { return AmplitudeKey{0.0, 0.0, p.amplitude}; },
        "every driven module");
  }
  FixPhases(state);      // (3)
  FixAmplitudes(state);  // (4)
  // (5) Tying the amplitudes may leave the budget unspent after step (1)
  // fixed offsets for it: those offsets come back, the last fixed first
  // (the transformed quadruped: 6 free with four offsets fixed, now 7).
  FreeFixedOffsets(state);
}

}  // namespace yamor::cpg
