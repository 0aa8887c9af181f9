// The ties of a generated problem (docs/cpg_build.md §4 "Ties", §2
// "Couplings of the base", §6 rule 1): see cpg/problem_steps.h.
#include "cpg/problem_steps.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <functional>
#include <numbers>
#include <optional>

namespace yamor::cpg {
namespace {

constexpr double kPi = std::numbers::pi;

std::string Id(ModuleId id) { return std::to_string(id); }

// Splits `items` into groups whose known values agree (`same`), in the order
// the values first appear; items with no value join the first group.
template <typename T>
std::vector<std::vector<T>> SplitByValue(const std::vector<T>& items,
                                         const std::function<std::optional<double>(const T&)>& value,
                                         const std::function<bool(double, double)>& same) {
  std::vector<std::vector<T>> groups;
  std::vector<double> values;
  std::vector<T> unknown;
  for (const T& x : items) {
    const std::optional<double> v = value(x);
    if (!v) {
      unknown.push_back(x);
      continue;
    }
    size_t g = 0;
    while (g < values.size() && !same(values[g], *v)) ++g;
    if (g == values.size()) {
      values.push_back(*v);
      groups.emplace_back();
    }
    groups[g].push_back(x);
  }
  if (groups.empty()) groups.emplace_back();
  groups.front().insert(groups.front().end(), unknown.begin(), unknown.end());
  return groups;
}

// Module classes with servo parity: offset(m) = sign·offset(rep).
class ParityJoins {
 public:
  void Add(ModuleId v) { parent_.try_emplace(v, std::pair{v, 1}); }
  std::pair<ModuleId, int> Find(ModuleId v) {
    auto& [p, s] = parent_.at(v);
    if (p == v) return {v, 1};
    const auto [r, rs] = Find(p);
    parent_[v] = {r, s * rs};
    return parent_[v];
  }
  // value(b) = sign·value(a). Returns false on a contradiction.
  bool Join(ModuleId a, ModuleId b, int sign) {
    const auto [ra, sa] = Find(a);
    const auto [rb, sb] = Find(b);
    if (ra == rb) return sa * sign == sb;
    // value(b) = sb·value(rb); value(a) = sa·value(ra) → value(rb) = sb·sign·sa·value(ra)
    if (rb < ra) {
      parent_[ra] = {rb, sb * sign * sa};
    } else {
      parent_[rb] = {ra, sb * sign * sa};
    }
    return true;
  }

 private:
  std::map<ModuleId, std::pair<ModuleId, int>> parent_;
};

// The classes one set of symmetries gives.
struct SymmetryClasses {
  std::map<ModuleId, std::vector<std::pair<ModuleId, int>>> module_classes;  // rep -> (member, sign)
  std::set<ModuleId> offsets_apart;  // class reps whose offsets stay untied
  std::vector<EdgeTie> ties;
  std::vector<bool> edge_broken;     // the class maps an edge onto itself shifted by pi
  std::vector<std::string> notes;
  int contradictions = 0;            // offsets a symmetry forces onto their reverse
};

SymmetryClasses ComputeTies(const std::vector<Symmetry>& elements, const std::vector<GraphModule>& pm,
                 const std::set<ModuleId>& driven, const CpgNetwork& net, const std::set<int>& keep_free) {
  SymmetryClasses ties_out;
  auto& module_classes = ties_out.module_classes;
  auto& offsets_apart = ties_out.offsets_apart;
  auto& ties = ties_out.ties;
  // Module classes.
  ParityJoins modules;
  for (ModuleId id : driven) modules.Add(id);
  std::vector<std::pair<ModuleId, ModuleId>> contradictions;
  for (const Symmetry& s : elements) {
    for (size_t i = 0; i < pm.size(); ++i) {
      const ModuleId a = pm[i].id, b = pm[s.image[i]].id;
      if (!driven.count(a)) continue;
      if (!modules.Join(a, b, s.ServoSign(static_cast<int>(i)))) contradictions.push_back({a, b});
    }
  }
  for (ModuleId id : driven) {
    const auto [r, s] = modules.Find(id);
    module_classes[r].push_back({id, s});
  }
  for (const auto& [a, b] : contradictions) offsets_apart.insert(modules.Find(a).first);

  // Edge classes.
  const int m = static_cast<int>(net.edges.size());
  std::map<std::pair<ModuleId, ModuleId>, int> edge_index;
  for (int e = 0; e < m; ++e) edge_index[{net.edges[e].u, net.edges[e].v}] = e;
  ties.resize(m);
  {
    // Weighted union-find: x_e = sign·x_root + pi·π.
    std::vector<int> parent(m), sign(m, 1), pi(m, 0);
    for (int e = 0; e < m; ++e) parent[e] = e;
    std::vector<bool> broken(m, false);
    std::function<int(int)> find = [&](int e) {
      if (parent[e] == e) return e;
      const int p = parent[e];
      const int r = find(p);
      sign[e] *= sign[p];
      pi[e] = (pi[e] + pi[p]) % 2;
      parent[e] = r;
      return r;
    };
    std::map<ModuleId, int> index_of;
    for (size_t i = 0; i < pm.size(); ++i) index_of[pm[i].id] = static_cast<int>(i);
    for (const Symmetry& s : elements) {
      for (int e = 0; e < m; ++e) {
        if (keep_free.count(e)) continue;
        const ModuleId u = net.edges[e].u, v = net.edges[e].v;
        const int iu = index_of.at(u), iv = index_of.at(v);
        const ModuleId su = pm[s.image[iu]].id, sv = pm[s.image[iv]].id;
        auto it = edge_index.find(std::minmax(su, sv));
        if (it == edge_index.end() || keep_free.count(it->second)) continue;
        const int flip = (driven.count(u) && driven.count(v) && s.ServoSign(iu) != s.ServoSign(iv)) ? 1 : 0;
        const int rel_sign = su < sv ? 1 : -1;  // x_e' = rel_sign·x_e + flip·π
        const int f = it->second;
        const int ra = find(e), rb = find(f);
        // x_e = sign[e]·x_ra + pi[e]π ; x_f = sign[f]·x_rb + pi[f]π
        if (ra == rb) {
          // need x_f = rel·x_e + flip: sign[f] == rel·sign[e], pi[f] == pi[e] + flip
          if (sign[f] != rel_sign * sign[e] || pi[f] != (pi[e] + flip) % 2) broken[ra] = true;
          continue;
        }
        // x_rb = sign[f]·(x_f - pi[f]π) = sign[f]·(rel·(sign[e] x_ra + pi[e]π) + flip π - pi[f]π)
        parent[rb] = ra;
        sign[rb] = sign[f] * rel_sign * sign[e];
        pi[rb] = (pi[e] + flip + pi[f]) % 2;
        broken[ra] = broken[ra] || broken[rb];
      }
    }
    for (int e = 0; e < m; ++e) {
      const int r = find(e);
      ties[e] = {.cls = r, .sign = sign[e], .pi = pi[e]};
    }
    ties_out.edge_broken.assign(m, false);
    for (int e = 0; e < m; ++e) ties_out.edge_broken[e] = broken[find(e)];
  }
  ties_out.contradictions += static_cast<int>(contradictions.size());
  return ties_out;
}

}  // namespace

std::string SpacedIds(const std::vector<ModuleId>& ids) {
  std::string out;
  for (ModuleId id : ids) {
    out += ' ';
    out += Id(id);
  }
  return out;
}

void KeepBaseCouplings(const ModuleGraph& graph, const RobotConfig& base, CpgNetwork& network,
                       std::vector<std::string>& notes) {
  const std::set<ModuleId> oscillators(network.oscillators.begin(), network.oscillators.end());
  const std::set<ModuleId> in_piece(network.piece.begin(), network.piece.end());
  auto connected_across_passive = [&](ModuleId from, ModuleId to) {
    std::set<ModuleId> seen{from};
    std::deque<ModuleId> todo{from};
    while (!todo.empty()) {
      const ModuleId at = todo.front();
      todo.pop_front();
      for (ModuleId n : graph.Neighbours(at)) {
        if (n == to) return true;
        if (!in_piece.count(n) || oscillators.count(n) || !seen.insert(n).second) continue;
        todo.push_back(n);
      }
    }
    return false;
  };
  for (const Coupling& c : base.couplings) {
    if (!oscillators.count(c.from) || !oscillators.count(c.to) || c.from == c.to ||
        network.FindEdge(c.from, c.to) != nullptr || !connected_across_passive(c.from, c.to)) {
      continue;
    }
    const auto [u, v] = std::minmax(c.from, c.to);
    network.edges.push_back({.u = u, .v = v, .physical = false, .from_base = true});
    notes.push_back("coupling " + Id(u) + "-" + Id(v) +
                    " is not one the construction rule gives but the base configuration's; it is kept");
  }
  std::sort(network.edges.begin(), network.edges.end(),
            [](const NetworkEdge& x, const NetworkEdge& y) { return std::pair{x.u, x.v} < std::pair{y.u, y.v}; });
}

ParameterTies SymmetryTies(const ModuleGraph& piece, const std::vector<Symmetry>& elements,
                           const std::set<ModuleId>& driven, const CpgNetwork& network,
                           const std::set<int>& keep_free, std::vector<std::string>& notes) {
  std::vector<Symmetry> rotations;
  for (const Symmetry& e : elements) {
    if (!e.mirror) rotations.push_back(e);
  }
  const auto& pm = piece.modules();
  const SymmetryClasses full = ComputeTies(elements, pm, driven, network, keep_free);
  const SymmetryClasses rot = ComputeTies(rotations, pm, driven, network, keep_free);
  const int m = static_cast<int>(network.edges.size());
  ParameterTies out;
  // Amplitude classes: every symmetry (an amplitude has no sign).
  for (const auto& [rep, members] : full.module_classes) {
    for (const auto& [id, sign] : members) out.amplitudes[rep].push_back(id);
  }
  // Offset classes with signs.
  for (const auto& [rep, members] : full.module_classes) {
    if (!full.offsets_apart.count(rep)) {
      out.offsets[rep] = members;
      continue;
    }
    std::string ids;
    for (const auto& [id, sign] : members) {
      ids += ' ';
      ids += Id(id);
    }
    notes.push_back("module(s)" + ids +
                    ": a mirror maps one of them onto its own reverse; their offsets are tied by "
                    "rotations only");
    for (const auto& [rrep, rmembers] : rot.module_classes) {
      const ModuleId rotation_rep = rrep;  // clang 14 cannot capture a structured binding
      if (std::none_of(members.begin(), members.end(),
                       [&](const auto& x) { return x.first == rotation_rep; })) {
        continue;
      }
      if (rot.offsets_apart.count(rrep)) {
        for (const auto& [id, sign] : rmembers) out.offsets[id] = {{id, 1}};
      } else {
        out.offsets[rrep] = rmembers;
      }
    }
  }
  std::vector<EdgeTie>& ties = out.phases;
  ties.resize(m);
  for (int e = 0; e < m; ++e) {
    if (!full.edge_broken[e]) {
      ties[e] = full.ties[e];
    } else if (!rot.edge_broken[e]) {
      ties[e] = {.cls = m + rot.ties[e].cls, .sign = rot.ties[e].sign, .pi = rot.ties[e].pi};
    } else {
      ties[e] = {.cls = 2 * m + e};
    }
  }
  return out;
}

BasePhases BasePhasesOf(const RobotConfig& base, const std::vector<NetworkEdge>& edges) {
  BasePhases base_phases;
  for (const NetworkEdge& ne : edges) {
    const Coupling* f = base.FindCoupling(ne.u, ne.v);
    const Coupling* b = base.FindCoupling(ne.v, ne.u);
    base_phases.forward.push_back(f ? std::optional(f->phase) : b ? std::optional(-b->phase) : std::nullopt);
    base_phases.backward.push_back(b ? std::optional(b->phase) : std::nullopt);
  }
  return base_phases;
}

void SplitTiesTheBaseContradicts(ParameterTies& ties, const RobotConfig& base, const BasePhases& base_phases,
                                 const std::vector<NetworkEdge>& edges, std::vector<std::string>& notes) {
  const auto same_value = [](double a, double b) { return std::abs(a - b) <= kSameValue; };
  {  // Amplitudes: equal base amplitudes.
    std::map<ModuleId, std::vector<ModuleId>> split;
    for (const auto& [rep, members] : ties.amplitudes) {
      auto groups = SplitByValue<ModuleId>(
          members,
          [&](const ModuleId& id) -> std::optional<double> {
            const ModuleParams* p = base.FindModule(id);
            return p ? std::optional(p->amplitude) : std::nullopt;
          },
          same_value);
      for (auto& g : groups) std::sort(g.begin(), g.end());
      if (groups.size() > 1) {
        notes.push_back("module(s)" + SpacedIds(members) +
                        " are symmetric but their base amplitudes differ; their amplitudes are not tied");
      }
      for (auto& g : groups) split[g.front()] = std::move(g);
    }
    ties.amplitudes = std::move(split);
  }
  {  // Offsets: base offsets that satisfy the tie's servo signs.
    std::map<ModuleId, std::vector<std::pair<ModuleId, int>>> split;
    for (const auto& [rep, members] : ties.offsets) {
      auto groups = SplitByValue<std::pair<ModuleId, int>>(
          members,
          [&](const std::pair<ModuleId, int>& x) -> std::optional<double> {
            const ModuleParams* p = base.FindModule(x.first);
            return p ? std::optional(x.second * p->offset) : std::nullopt;
          },
          same_value);
      if (groups.size() > 1) {
        std::vector<ModuleId> ids;
        for (const auto& x : members) ids.push_back(x.first);
        notes.push_back("module(s)" + SpacedIds(ids) +
                        " are symmetric but their base offsets differ from the tie; their offsets are "
                        "not tied");
      }
      for (auto& g : groups) {
        std::sort(g.begin(), g.end());
        const int rep_sign = g.front().second;
        for (auto& x : g) x.second *= rep_sign;
        split[g.front().first] = std::move(g);
      }
    }
    ties.offsets = std::move(split);
  }
  {  // Phases: base phases that satisfy the tie's sign and pi shift.
    int next = 0;
    for (const EdgeTie& t : ties.phases) next = std::max(next, t.cls + 1);
    std::map<int, std::vector<int>> classes;
    for (int e = 0; e < static_cast<int>(edges.size()); ++e) classes[ties.phases[e].cls].push_back(e);
    for (const auto& [cls, members] : classes) {
      const auto groups = SplitByValue<int>(
          members,
          [&](const int& e) -> std::optional<double> {
            const auto& x = base_phases.forward[e];
            return x ? std::optional(ties.phases[e].sign * (*x - ties.phases[e].pi * kPi)) : std::nullopt;
          },
          [](double a, double b) { return AngleGap(a, b) <= kSameValue; });
      if (groups.size() < 2) continue;
      std::string names;
      for (int e : members) {
        names += ' ';
        names += EdgeName(edges[e]);
      }
      notes.push_back("couplings" + names +
                      " are symmetric but their base phases differ from the tie; they are not tied");
      for (size_t g = 1; g < groups.size(); ++g) {
        for (int e : groups[g]) ties.phases[e].cls = next;
        ++next;
      }
    }
  }
}

}  // namespace yamor::cpg
