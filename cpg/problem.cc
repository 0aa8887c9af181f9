#include "cpg/problem.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <functional>
#include <map>
#include <numbers>
#include <optional>
#include <random>
#include <set>
#include <sstream>

#include "common/format.h"
#include "common/status.h"
#include "cpg/config_xml.h"

namespace yamor::cpg {
namespace {

constexpr double kPi = std::numbers::pi;

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

std::string Id(ModuleId id) { return std::to_string(id); }

// Sort key of a parameter name: its kind, then its ids as numbers.
std::vector<int> ParamOrder(const std::string& param) {
  std::vector<int> key{param[0] == 'a' ? 0 : param[0] == 'o' ? 1 : 2};
  std::stringstream in(param.substr(param.find('.') + 1));
  std::string id;
  while (std::getline(in, id, '.')) key.push_back(std::stoi(id));
  return key;
}

// " 1 2 3" for a list of ids.
std::string SpacedIds(const std::vector<ModuleId>& ids) {
  std::string out;
  for (ModuleId id : ids) {
    out += ' ';
    out += Id(id);
  }
  return out;
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

double AmplitudeMax(const ModuleParams& m) {
  return std::min(kPi / 2, std::max(0.0, (m.max_angle - m.min_angle) / 2));
}

// A fixed-algorithm shuffle so the seeded order is the same on every
// standard library.
template <typename T>
void SeededShuffle(std::vector<T>& items, std::mt19937_64& rng) {
  for (size_t i = items.size(); i > 1; --i) std::swap(items[i - 1], items[rng() % i]);
}

// Parameter ties under a set of symmetries.
struct Ties {
  std::map<ModuleId, std::vector<std::pair<ModuleId, int>>> module_classes;  // rep -> (member, sign)
  std::set<ModuleId> offsets_apart;  // class reps whose offsets stay untied
  std::vector<EdgeTie> ties;
  std::vector<bool> edge_broken;     // the class maps an edge onto itself shifted by pi
  std::vector<std::string> notes;
  int contradictions = 0;            // offsets a symmetry forces onto their reverse
};

Ties ComputeTies(const std::vector<Symmetry>& elements, const std::vector<GraphModule>& pm,
                 const std::set<ModuleId>& driven, const CpgNetwork& net, const std::set<int>& keep_free) {
  Ties ties_out;
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

RobotConfig WarmStart(const ModuleGraph& graph, const CpgNetwork& network, const RobotConfig& base,
                      const ProblemOptions& options) {
  double speed = options.default_speed;
  std::map<double, int> speeds;
  for (const ModuleParams& m : base.modules) {
    if (m.speed > 0) ++speeds[m.speed];
  }
  int most = 0;
  for (const auto& [s, count] : speeds) {
    if (count > most) {
      most = count;
      speed = s;
    }
  }
  RobotConfig config = NetworkConfig(graph, network, options.default_amplitude, speed,
                                     base.master_id);
  const std::set<ModuleId> oscillators(network.oscillators.begin(), network.oscillators.end());
  for (ModuleParams& m : config.modules) {
    if (!oscillators.count(m.id)) continue;
    if (const ModuleParams* old = base.FindModule(m.id)) {
      m = *old;
      continue;
    }
    for (ModuleId n : graph.Neighbours(m.id)) {
      const ModuleParams* near = base.FindModule(n);
      if (near && oscillators.count(n) && near->speed > 0) {
        m.amplitude = near->amplitude;
        m.min_angle = near->min_angle;
        m.max_angle = near->max_angle;
        break;
      }
    }
  }
  for (Coupling& c : config.couplings) {
    if (const Coupling* old = base.FindCoupling(c.from, c.to)) {
      c.phase = old->phase;
      c.weight = old->weight;
    }
  }
  return config;
}

GeneratedProblem GenerateProblem(const ModuleGraph& graph, const RobotConfig* base,
                                 const ProblemOptions& options) {
  if (options.max_free < 1) {
    throw Error(StatusCode::kInvalidArgument,
                "the free-parameter budget must be at least 1, not " + std::to_string(options.max_free));
  }
  GeneratedProblem out;
  out.graph_text = graph.Describe();
  out.key = MorphologyKey(graph);
  out.network = BuildNetwork(graph, options.network);
  if (base != nullptr) {
    // A coupling of the base between two oscillators that the body connects,
    // directly or across passive modules only, is kept even where the
    // construction rule gives none (docs/cpg_build.md, "The base is the start
    // point"). One between modules the body no longer connects is dropped: the
    // network follows the body (thesis 7.4).
    const std::set<ModuleId> oscillators(out.network.oscillators.begin(), out.network.oscillators.end());
    const std::set<ModuleId> in_piece(out.network.piece.begin(), out.network.piece.end());
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
    for (const Coupling& c : base->couplings) {
      if (!oscillators.count(c.from) || !oscillators.count(c.to) || c.from == c.to ||
          out.network.FindEdge(c.from, c.to) != nullptr || !connected_across_passive(c.from, c.to)) {
        continue;
      }
      const auto [u, v] = std::minmax(c.from, c.to);
      out.network.edges.push_back({.u = u, .v = v, .physical = false, .from_base = true});
      out.notes.push_back("coupling " + Id(u) + "-" + Id(v) +
                          " is not one the construction rule gives but the base configuration's; it is kept");
    }
    std::sort(out.network.edges.begin(), out.network.edges.end(),
              [](const NetworkEdge& x, const NetworkEdge& y) { return std::pair{x.u, x.v} < std::pair{y.u, y.v}; });
  }
  const CpgNetwork& net = out.network;
  if (!net.ignored.empty()) {
    out.notes.push_back("modules" + SpacedIds(net.ignored) + " are not connected to the largest piece and are ignored");
  }
  if (!net.passive.empty()) {
    out.notes.push_back("passive modules" + SpacedIds(net.passive) +
                        " have no oscillator; the network couples across them");
  }
  const std::set<ModuleId> driven = [&] {
    std::set<ModuleId> s;
    for (ModuleId id : net.oscillators) {
      if (graph.Module(id).active) s.insert(id);
    }
    return s;
  }();
  const std::set<int> keep_free = KeepFreeIndices(net.edges, options.keep_free);

  // Symmetries of the piece.
  const ModuleGraph piece = graph.Subgraph(net.piece);
  if (options.use_symmetry) out.symmetry = FindSymmetries(piece, options.symmetry);
  const auto& pm = piece.modules();

  // Ties under every kept symmetry; where a mirror maps a moving module (or
  // a coupling) onto its own reverse, no gait has that symmetry while the
  // module moves, and those classes fall back to the rotations' ties.
  const std::vector<Symmetry>& all_elements = out.symmetry.elements;
  std::vector<Symmetry> rotations;
  for (const Symmetry& e : all_elements) {
    if (!e.mirror) rotations.push_back(e);
  }
  const Ties full = ComputeTies(all_elements, pm, driven, net, keep_free);
  const Ties rot = ComputeTies(rotations, pm, driven, net, keep_free);
  const int m = static_cast<int>(net.edges.size());
  // Amplitude classes: every symmetry (an amplitude has no sign).
  std::map<ModuleId, std::vector<ModuleId>> amplitude_classes;
  for (const auto& [rep, members] : full.module_classes) {
    for (const auto& [id, sign] : members) amplitude_classes[rep].push_back(id);
  }
  // Offset classes with signs.
  std::map<ModuleId, std::vector<std::pair<ModuleId, int>>> offset_classes;
  for (const auto& [rep, members] : full.module_classes) {
    if (!full.offsets_apart.count(rep)) {
      offset_classes[rep] = members;
      continue;
    }
    std::string ids;
    for (const auto& [id, sign] : members) {
      ids += ' ';
      ids += Id(id);
    }
    out.notes.push_back("module(s)" + ids +
                        ": a mirror maps one of them onto its own reverse; their offsets are tied by "
                        "rotations only");
    for (const auto& [rrep, rmembers] : rot.module_classes) {
      const ModuleId rotation_rep = rrep;  // clang 14 cannot capture a structured binding
      if (std::none_of(members.begin(), members.end(),
                       [&](const auto& x) { return x.first == rotation_rep; })) {
        continue;
      }
      if (rot.offsets_apart.count(rrep)) {
        for (const auto& [id, sign] : rmembers) offset_classes[id] = {{id, 1}};
      } else {
        offset_classes[rrep] = rmembers;
      }
    }
  }
  std::vector<EdgeTie> ties(m);
  for (int e = 0; e < m; ++e) {
    if (!full.edge_broken[e]) {
      ties[e] = full.ties[e];
    } else if (!rot.edge_broken[e]) {
      ties[e] = {.cls = m + rot.ties[e].cls, .sign = rot.ties[e].sign, .pi = rot.ties[e].pi};
    } else {
      ties[e] = {.cls = 2 * m + e};
    }
  }

  // The base configuration is a point of the problem (docs/cpg_build.md,
  // "The base is the start point"): a tie is imposed only among modules or
  // couplings whose base values satisfy it; the others are split apart.
  RobotConfig empty;
  empty.master_id = graph.central();
  const RobotConfig& from = base ? *base : empty;
  BasePhases base_phases;
  for (const NetworkEdge& ne : net.edges) {
    const Coupling* f = from.FindCoupling(ne.u, ne.v);
    const Coupling* b = from.FindCoupling(ne.v, ne.u);
    base_phases.forward.push_back(f ? std::optional(f->phase) : b ? std::optional(-b->phase) : std::nullopt);
    base_phases.backward.push_back(b ? std::optional(b->phase) : std::nullopt);
  }
  const auto same_value = [](double a, double b) { return std::abs(a - b) <= kSameValue; };
  // With impose_symmetry the three splits below are skipped: every tie
  // holds and the start point is the base projected onto them.
  const bool split_by_base = !options.impose_symmetry;
  if (split_by_base) {
    std::map<ModuleId, std::vector<ModuleId>> split;
    for (const auto& [rep, members] : amplitude_classes) {
      auto groups = SplitByValue<ModuleId>(
          members,
          [&](const ModuleId& id) -> std::optional<double> {
            const ModuleParams* p = from.FindModule(id);
            return p ? std::optional(p->amplitude) : std::nullopt;
          },
          same_value);
      for (auto& g : groups) std::sort(g.begin(), g.end());
      if (groups.size() > 1) {
        out.notes.push_back("module(s)" + SpacedIds(members) +
                            " are symmetric but their base amplitudes differ; their amplitudes are not tied");
      }
      for (auto& g : groups) split[g.front()] = std::move(g);
    }
    amplitude_classes = std::move(split);
  }
  if (split_by_base) {
    std::map<ModuleId, std::vector<std::pair<ModuleId, int>>> split;
    for (const auto& [rep, members] : offset_classes) {
      auto groups = SplitByValue<std::pair<ModuleId, int>>(
          members,
          [&](const std::pair<ModuleId, int>& x) -> std::optional<double> {
            const ModuleParams* p = from.FindModule(x.first);
            return p ? std::optional(x.second * p->offset) : std::nullopt;
          },
          same_value);
      if (groups.size() > 1) {
        std::vector<ModuleId> ids;
        for (const auto& x : members) ids.push_back(x.first);
        out.notes.push_back("module(s)" + SpacedIds(ids) +
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
    offset_classes = std::move(split);
  }
  if (split_by_base) {
    int next = 0;
    for (const EdgeTie& t : ties) next = std::max(next, t.cls + 1);
    std::map<int, std::vector<int>> classes;
    for (int e = 0; e < m; ++e) classes[ties[e].cls].push_back(e);
    for (const auto& [cls, edges] : classes) {
      const auto groups = SplitByValue<int>(
          edges,
          [&](const int& e) -> std::optional<double> {
            const auto& x = base_phases.forward[e];
            return x ? std::optional(ties[e].sign * (*x - ties[e].pi * kPi)) : std::nullopt;
          },
          [](double a, double b) { return AngleGap(a, b) <= kSameValue; });
      if (groups.size() < 2) continue;
      std::string names;
      for (int e : edges) names += " " + EdgeName(net.edges[e]);
      out.notes.push_back("couplings" + names +
                          " are symmetric but their base phases differ from the tie; they are not tied");
      for (size_t g = 1; g < groups.size(); ++g) {
        for (int e : groups[g]) ties[e].cls = next;
        ++next;
      }
    }
  }
  Normalise(ties);
  std::vector<bool> base_edge(m);
  for (int e = 0; e < m; ++e) base_edge[e] = base_phases.forward[e].has_value();
  const PhaseSolution sol = SolvePhases(net.oscillators, net.edges, ties, keep_free, base_edge);
  out.loops = sol.loops;
  for (const std::string& u : sol.untied) out.notes.push_back(u);

  // The warm-started robot.
  out.robot = WarmStart(graph, net, from, options);
  // Start values the base does not give are clamped into their module's
  // limits; the base's own values are kept as they are.
  auto clamp_amplitude = [&](ModuleParams& p) {
    if (!from.FindModule(p.id)) p.amplitude = std::clamp(p.amplitude, 0.0, AmplitudeMax(p));
  };
  auto clamp_offset = [&](ModuleParams& p) {
    if (!from.FindModule(p.id)) p.offset = std::clamp(p.offset, p.min_angle, p.max_angle);
  };
  for (ModuleParams& p : out.robot.modules) {
    if (!driven.count(p.id)) continue;
    clamp_amplitude(p);
    clamp_offset(p);
  }
  // New modules take their orbit's values (offset and limits mirrored by
  // the servo sign).
  for (const auto& [rep, members] : offset_classes) {
    const ModuleParams* known = nullptr;
    int known_sign = 1;
    for (const auto& [id, sign] : members) {
      if ((known = from.FindModule(id))) {
        known_sign = sign;
        break;
      }
    }
    if (!known) continue;
    for (const auto& [id, sign] : members) {
      if (from.FindModule(id)) continue;
      ModuleParams* p = out.robot.FindModule(id);
      const int rel = sign * known_sign;
      p->amplitude = known->amplitude;
      p->offset = rel * known->offset;
      p->speed = known->speed;
      p->min_angle = rel > 0 ? known->min_angle : -known->max_angle;
      p->max_angle = rel > 0 ? known->max_angle : -known->min_angle;
    }
  }
  // New couplings take their class's phase.
  for (int e = 0; e < m; ++e) {
    const NetworkEdge& ne = net.edges[e];
    if (from.FindCoupling(ne.u, ne.v)) continue;
    for (int k = 0; k < m; ++k) {
      const NetworkEdge& nk = net.edges[k];
      const Coupling* old = from.FindCoupling(nk.u, nk.v);
      if (!old || ties[k].cls != ties[e].cls) continue;
      // x_k = s_k·y + p_k·π → y = s_k·(x_k − p_k·π); x_e = s_e·y + p_e·π
      const double y = ties[k].sign * (old->phase - ties[k].pi * kPi);
      const double x = ties[e].sign * y + ties[e].pi * kPi;
      out.robot.FindCoupling(ne.u, ne.v)->phase = x;
      out.robot.FindCoupling(ne.v, ne.u)->phase = -x;
      break;
    }
  }
  // Phases are angles: start them in [0, 2π), the bounds of a free phase.
  for (Coupling& c : out.robot.couplings) {
    c.phase = std::fmod(c.phase, 2 * kPi);
    if (c.phase < 0) c.phase += 2 * kPi;
    if (c.phase >= 2 * kPi) c.phase = 0;
  }
  // Candidates: one amplitude per amplitude class, one offset per offset
  // class, one phase per free phase class.
  struct Candidate {
    FreeParameter param;
    int kind;  // 0 offset, 1 phase, 2 amplitude
  };
  auto members_text = [](const auto& ids) {
    std::string t;
    for (const auto& x : ids) {
      if constexpr (std::is_same_v<std::decay_t<decltype(x)>, ModuleId>) {
        t += ' ';
        t += Id(x);
      } else {
        t += ' ';
        t += Id(x.first);
      }
    }
    return t;
  };
  std::vector<Candidate> offsets, amplitudes, phases;
  for (const auto& [rep, members] : offset_classes) {
    const ModuleParams& r = *out.robot.FindModule(rep);
    offsets.push_back({{"offset." + Id(rep), r.min_angle, r.max_angle, "offset of module(s)" + members_text(members)}, 0});
  }
  for (const auto& [rep, members] : amplitude_classes) {
    double max = kPi / 2;
    for (ModuleId id : members) max = std::min(max, AmplitudeMax(*out.robot.FindModule(id)));
    amplitudes.push_back({{"amplitude." + Id(rep), 0.0, max, "amplitude of module(s)" + members_text(members)}, 2});
  }
  const auto names = ClassNames(sol, net.edges);
  for (int cls : sol.free_classes) {
    std::string es;
    for (int e = 0; e < m; ++e) {
      if (sol.ties[e].cls == cls) {
        es += ' ';
        es += EdgeName(net.edges[e]);
      }
    }
    phases.push_back({{names[cls], 0.0, 2 * kPi, "phase of coupling(s)" + es}, 1});
  }

  // The budget rule (docs/cpg_build.md): (1) fix offsets, in a seeded order;
  // (2) tie every amplitude to one; (3) fix phases, in a seeded order;
  // (4) fix the amplitude; (5) free fixed offsets again while the budget
  // allows. What is fixed keeps its warm-start value.
  std::mt19937_64 rng(options.seed);
  SeededShuffle(offsets, rng);
  SeededShuffle(phases, rng);
  auto total = [&] { return offsets.size() + amplitudes.size() + phases.size(); };
  const size_t budget = static_cast<size_t>(options.max_free);
  std::vector<std::string> fixed_params;
  std::vector<Candidate> fixed_offsets;  // in the order fixed
  while (total() > budget && !offsets.empty()) {
    fixed_params.push_back(offsets.back().param.param);
    fixed_offsets.push_back(offsets.back());
    offsets.pop_back();
  }
  // Ties amplitude classes with the same key into one each: the
  // representative is the group's smallest id, its bound the tightest.
  // The key holds the start amplitude too: amplitudes the base configures
  // differently are never tied (the base stays a point of the problem).
  using AmplitudeKey = std::tuple<double, double, double>;
  auto merge_amplitudes = [&](const std::function<AmplitudeKey(ModuleId)>& key,
                              const std::string& what) {
    std::map<AmplitudeKey, std::vector<ModuleId>> groups;  // key -> class reps
    for (const auto& [rep, members] : amplitude_classes) groups[key(rep)].push_back(rep);
    if (groups.size() == amplitude_classes.size()) return;  // nothing to tie
    std::map<ModuleId, std::vector<ModuleId>> merged_classes;
    std::vector<Candidate> merged;
    for (const auto& [k, reps] : groups) {
      const ModuleId rep = *std::min_element(reps.begin(), reps.end());
      std::vector<ModuleId>& members = merged_classes[rep];
      double max = kPi / 2;
      for (ModuleId r : reps) {
        members.insert(members.end(), amplitude_classes.at(r).begin(), amplitude_classes.at(r).end());
        max = std::min(max, AmplitudeMax(*out.robot.FindModule(r)));
      }
      std::sort(members.begin(), members.end());
      std::string note = "amplitude of module(s)" + members_text(members);
      if (reps.size() > 1) {
        note += " (tied by the budget rule)";
        out.notes.push_back("the budget rule ties the amplitudes of" + members_text(members) + " (" + what +
                            ") to amplitude." + Id(rep));
      }
      merged.push_back({{"amplitude." + Id(rep), 0.0, max, note}, 2});
    }
    amplitude_classes = std::move(merged_classes);
    amplitudes = std::move(merged);
  };
  if (total() > budget) {
    merge_amplitudes([&](ModuleId id) {
      const ModuleParams& p = *out.robot.FindModule(id);
      return AmplitudeKey{p.min_angle, p.max_angle, p.amplitude};
    }, "same limit angles");
  }
  if (total() > budget) merge_amplitudes([&](ModuleId id) { return AmplitudeKey{0.0, 0.0, out.robot.FindModule(id)->amplitude}; },
                     "every driven module");
  while (total() > budget && !phases.empty()) {
    fixed_params.push_back(phases.back().param.param);
    phases.pop_back();
  }
  while (total() > budget && !amplitudes.empty()) {
    fixed_params.push_back(amplitudes.back().param.param);
    amplitudes.pop_back();
  }
  // (5) Tying the amplitudes may leave the budget unspent after step (1)
  // fixed offsets for it: those offsets come back, the last fixed first
  // (the transformed quadruped: 6 free with four offsets fixed, now 7).
  while (total() < budget && !fixed_offsets.empty()) {
    const std::string name = fixed_offsets.back().param.param;
    fixed_params.erase(std::find(fixed_params.begin(), fixed_params.end(), name));
    offsets.push_back(std::move(fixed_offsets.back()));
    fixed_offsets.pop_back();
  }

  // Tied members start where their representative is, or where the base
  // puts the class (its configured members agree, the split above made sure);
  // base_amplitudes and base_offsets hold the classes the base configures.
  std::set<ModuleId> base_amplitudes, base_offsets;
  for (const auto& [rep, members] : amplitude_classes) {
    const auto known = std::find_if(members.begin(), members.end(),
                                    [&](ModuleId id) { return from.FindModule(id) != nullptr; });
    const double a = out.robot.FindModule(known != members.end() ? *known : rep)->amplitude;
    if (known != members.end()) base_amplitudes.insert(rep);
    for (ModuleId id : members) out.robot.FindModule(id)->amplitude = a;
  }
  for (const auto& [rep, members] : offset_classes) {
    const auto known = std::find_if(members.begin(), members.end(),
                                    [&](const auto& x) { return from.FindModule(x.first) != nullptr; });
    const auto& [kid, ksign] = known != members.end() ? *known : members.front();
    const double o = ksign * out.robot.FindModule(kid)->offset;  // the representative's offset
    if (known != members.end()) base_offsets.insert(rep);
    for (const auto& [id, sign] : members) out.robot.FindModule(id)->offset = sign * o;
  }
  for (const auto& [rep, members] : amplitude_classes) {
    if (base_amplitudes.count(rep)) continue;
    for (ModuleId id : members) clamp_amplitude(*out.robot.FindModule(id));
  }
  for (const auto& [rep, members] : offset_classes) {
    if (base_offsets.count(rep)) continue;
    for (const auto& [id, sign] : members) clamp_offset(*out.robot.FindModule(id));
  }

  auto value_of = [&](const std::string& param) -> double {
    const auto dot = param.find('.');
    const std::string kind = param.substr(0, dot);
    const std::string rest = param.substr(dot + 1);
    if (kind == "phase") {
      const auto dot2 = rest.find('.');
      const Coupling* c = out.robot.FindCoupling(std::stoi(rest.substr(0, dot2)), std::stoi(rest.substr(dot2 + 1)));
      return c ? c->phase : 0.0;
    }
    const ModuleParams* p = out.robot.FindModule(std::stoi(rest));
    return kind == "amplitude" ? p->amplitude : p->offset;
  };
  for (const std::string& f : fixed_params) out.fixed.push_back({f, value_of(f)});
  // The free set in a fixed order (the seeded order only chose what to fix):
  // amplitudes, offsets, then phases, each by representative. A box widens
  // to hold the base's value, so the start point is the base configuration.
  for (auto* group : {&amplitudes, &offsets}) {
    const std::set<ModuleId>& known = group == &amplitudes ? base_amplitudes : base_offsets;
    for (Candidate& c : *group) {
      const std::string& name = c.param.param;
      if (!known.count(std::stoi(name.substr(name.find('.') + 1)))) continue;
      const double v = value_of(name);
      c.param.min = std::min(c.param.min, v);
      c.param.max = std::max(c.param.max, v);
    }
  }
  for (const auto* group : {&amplitudes, &offsets, &phases}) {
    std::vector<Candidate> sorted = *group;
    std::sort(sorted.begin(), sorted.end(), [](const Candidate& x, const Candidate& y) {
      return ParamOrder(x.param.param) < ParamOrder(y.param.param);
    });
    for (const Candidate& c : sorted) out.free.push_back(c.param);
  }
  if (!out.fixed.empty()) {
    out.notes.push_back(std::to_string(out.fixed.size()) + " parameter(s) above the budget of " +
                        std::to_string(options.max_free) + " fixed at their warm-start values (seed " +
                        std::to_string(options.seed) + ")");
  }

  // Tied parameters: module ties, then phases.
  for (const auto& [rep, members] : amplitude_classes) {
    for (ModuleId id : members) {
      if (id != rep) out.tied.push_back({"amplitude." + Id(id), "amplitude." + Id(rep) + "()"});
    }
  }
  for (const auto& [rep, members] : offset_classes) {
    for (const auto& [id, sign] : members) {
      if (id == rep) continue;
      std::string expr = sign > 0 ? "offset." : "-offset.";
      expr += Id(rep) + "()";
      out.tied.push_back({"offset." + Id(id), expr});
    }
  }
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
