#include "cpg/phase_system.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <functional>
#include <numbers>
#include <tuple>

#include "common/format.h"
#include "common/status.h"

namespace yamor::cpg {
namespace {

constexpr double kPi = std::numbers::pi;

std::string Id(ModuleId id) { return std::to_string(id); }

std::string Term(int coef, const std::string& name, bool first) {
  std::string s;
  if (coef < 0) {
    s = first ? "-" : " - ";
  } else if (!first) {
    s = " + ";
  }
  const int a = std::abs(coef);
  if (a != 1) s += std::to_string(a) + "*";
  return s + name + "()";
}

// " + 0.25" or " - 0.25": a constant term of a rule.
std::string Constant(double c) {
  return (c < 0 ? " - " : " + ") + FormatDouble(std::abs(c));
}

int ClassCount(const std::vector<EdgeTie>& ties) {
  int k = 0;
  for (const EdgeTie& t : ties) k = std::max(k, t.cls + 1);
  return k;
}

long ClassSize(const std::vector<EdgeTie>& ties, int cls) {
  return std::count_if(ties.begin(), ties.end(), [&](const EdgeTie& t) { return t.cls == cls; });
}

// Classes whose loop equations could not be solved, and why.
struct LoopFailure {
  std::set<int> classes;
  std::string why;
};

// One elimination over the cycle equations with the classes `ties`: the
// pivot chosen in each equation, or the classes of the first equation that
// cannot hold (their tie fixes a phase to a few values).
struct Elimination {
  std::map<int, Row> pivots;
  std::optional<LoopFailure> failure;
};

Elimination EliminateLoops(const std::vector<Cycle>& cycles, const std::vector<EdgeTie>& ties,
                           const std::vector<bool>& in_tree, const std::set<int>& keep_free,
                           const std::vector<bool>& base_edge) {
  const int m = static_cast<int>(ties.size());
  const int classes = ClassCount(ties);
  std::vector<bool> tree_class(classes, false), keep_class(classes, false), base_class(classes, false);
  for (int e = 0; e < m; ++e) {
    if (in_tree[e]) tree_class[ties[e].cls] = true;
    if (!base_edge.empty() && base_edge[e]) base_class[ties[e].cls] = true;
    if (keep_free.count(e)) keep_class[ties[e].cls] = true;
  }
  Elimination out;
  std::map<int, Row>& pivots = out.pivots;
  std::map<int, std::set<int>> pivot_row_classes;
  for (const Cycle& c : cycles) {
    Row row;
    std::set<int> row_classes;
    for (const auto& [e, orient] : c.terms) {
      row.Add(ties[e].cls, orient * ties[e].sign);
      row.pi = (row.pi + ties[e].pi) % 2;
      row_classes.insert(ties[e].cls);
    }
    Row reduced;
    reduced.pi = row.pi;
    for (const auto& [cls, a] : row.coef) {
      auto p = pivots.find(cls);
      if (p == pivots.end()) {
        reduced.Add(cls, a);
      } else {
        reduced.AddRow(p->second, a);
      }
    }
    if (reduced.coef.empty()) {
      if (reduced.pi != 0) {
        out.failure = LoopFailure{row_classes, "tied, the loop " + c.text + " could not close"};
        return out;
      }
      continue;  // a loop the others already close
    }
    int best = -1;
    for (const auto& [cls, a] : reduced.coef) {
      if (std::abs(a) != 1 || keep_class[cls]) continue;
      if (best < 0) {
        best = cls;
        continue;
      }
      // Prefer constraining classes the base does not give, then non-tree,
      // small, late classes.
      auto score = [&](int k) { return std::tuple{base_class[k], tree_class[k], ClassSize(ties, k), -k}; };
      if (score(cls) < score(best)) best = cls;
    }
    if (best < 0) {
      out.failure = LoopFailure{row_classes, "tied, the loop " + c.text + " would fix their phase to a few values"};
      return out;
    }
    const int a = reduced.coef.at(best);
    Row expr;  // y_best = -a·(reduced - a·y_best)
    for (const auto& [cls, b] : reduced.coef) {
      if (cls != best) expr.Add(cls, -a * b);
    }
    expr.pi = reduced.pi;
    for (auto& [cls, other] : pivots) {
      auto it = other.coef.find(best);
      if (it == other.coef.end()) continue;
      const int factor = it->second;
      other.coef.erase(it);
      other.AddRow(expr, factor);
    }
    pivots[best] = expr;
    pivot_row_classes[best] = row_classes;
  }
  for (const auto& [cls, expr] : pivots) {
    if (expr.coef.empty()) {
      out.failure = LoopFailure{pivot_row_classes[cls], "tied, a loop would fix a phase"};
      break;
    }
  }
  return out;
}

// Splits every class of `failure` with two or more edges into classes of
// one edge each (§4: tied couplings that form a loop among themselves are
// left to the loop constraints) and names each split in `untied`.
void SplitClasses(std::vector<EdgeTie>& ties, const std::vector<NetworkEdge>& edges, const LoopFailure& failure,
                  std::vector<std::string>& untied) {
  int next = ClassCount(ties);
  for (int cls : failure.classes) {
    if (ClassSize(ties, cls) < 2) continue;
    std::string names;
    for (size_t e = 0; e < edges.size(); ++e) {
      if (ties[e].cls != cls) continue;
      if (!names.empty()) names += ' ';
      names += EdgeName(edges[e]);
      ties[e] = {.cls = next++, .sign = 1, .pi = 0};
    }
    untied.push_back("couplings " + names + " are symmetric but not tied: " + failure.why);
  }
  Normalise(ties);
}

}  // namespace

double AngleGap(double a, double b) { return std::abs(std::remainder(a - b, 2 * kPi)); }
std::string PhaseName(ModuleId from, ModuleId to) { return "phase." + Id(from) + "." + Id(to); }
std::string EdgeName(const NetworkEdge& e) { return Id(e.u) + "-" + Id(e.v); }

void Row::Add(int cls, int a) {
  if (a == 0) return;
  if ((coef[cls] += a) == 0) coef.erase(cls);
}

void Row::AddRow(const Row& other, int factor) {
  for (const auto& [c, a] : other.coef) Add(c, factor * a);
  pi = ((pi + factor * other.pi) % 2 + 2) % 2;
}

void Normalise(std::vector<EdgeTie>& ties) {
  std::map<int, int> rep;  // old class -> representative edge
  for (int e = 0; e < static_cast<int>(ties.size()); ++e) rep.try_emplace(ties[e].cls, e);
  std::map<int, int> renumber;
  for (int e = 0; e < static_cast<int>(ties.size()); ++e) {
    if (rep[ties[e].cls] == e) renumber[ties[e].cls] = static_cast<int>(renumber.size());
  }
  std::vector<EdgeTie> out(ties.size());
  for (int e = 0; e < static_cast<int>(ties.size()); ++e) {
    const EdgeTie& r = ties[rep[ties[e].cls]];
    out[e] = {.cls = renumber[ties[e].cls], .sign = ties[e].sign * r.sign,
              .pi = (ties[e].pi + r.pi) % 2};
  }
  ties = std::move(out);
}

std::set<int> KeepFreeIndices(const std::vector<NetworkEdge>& edges,
                              const std::vector<std::pair<ModuleId, ModuleId>>& keep_free) {
  std::set<int> out;
  for (const auto& [a, b] : keep_free) {
    const auto key = std::minmax(a, b);
    int found = -1;
    for (int e = 0; e < static_cast<int>(edges.size()); ++e) {
      if (edges[e].u == key.first && edges[e].v == key.second) found = e;
    }
    if (found < 0) {
      throw Error(StatusCode::kInvalidArgument,
                  "keep-free coupling " + Id(a) + "-" + Id(b) +
                      " is not a coupling of the generated network");
    }
    out.insert(found);
  }
  return out;
}

std::vector<bool> SpanningTree(const std::vector<ModuleId>& vertices, const std::vector<NetworkEdge>& edges,
                               const std::set<int>& keep_free) {
  const int m = static_cast<int>(edges.size());
  std::map<ModuleId, ModuleId> parent;
  for (ModuleId v : vertices) parent[v] = v;
  auto root = [&](ModuleId v) {
    while (parent[v] != v) v = parent[v] = parent[parent[v]];
    return v;
  };
  // Edge order for the tree: keep-free edges, then the depth-first walk's
  // edges, then the rest.
  std::vector<int> order;
  std::vector<bool> placed(m, false);
  for (int e : keep_free) {
    order.push_back(e);
    placed[e] = true;
  }
  {
    std::map<ModuleId, std::vector<std::pair<ModuleId, int>>> adj;
    for (int e = 0; e < m; ++e) {
      adj[edges[e].u].push_back({edges[e].v, e});
      adj[edges[e].v].push_back({edges[e].u, e});
    }
    for (auto& [v, ns] : adj) std::sort(ns.begin(), ns.end());
    std::set<ModuleId> visited;
    std::function<void(ModuleId)> dfs = [&](ModuleId at) {
      visited.insert(at);
      for (const auto& [next, e] : adj[at]) {
        if (visited.count(next)) continue;
        if (!placed[e]) {
          order.push_back(e);
          placed[e] = true;
        }
        dfs(next);
      }
    };
    for (ModuleId v : vertices) {
      if (!visited.count(v)) dfs(v);
    }
  }
  for (int e = 0; e < m; ++e) {
    if (!placed[e]) order.push_back(e);
  }
  std::vector<bool> in_tree(m, false);
  for (int e : order) {
    const ModuleId a = root(edges[e].u), b = root(edges[e].v);
    if (a == b) {
      if (keep_free.count(e)) {
        std::string names;
        for (int k : keep_free) {
          if (!names.empty()) names += ", ";
          names += EdgeName(edges[k]);
        }
        throw Error(StatusCode::kInvalidArgument,
                    "keep-free couplings " + names + " close a loop (" + EdgeName(edges[e]) +
                        " closes it): every loop's phases must sum to a multiple of 2pi, so one "
                        "of them has to follow from the others");
      }
      continue;
    }
    parent[a] = b;
    in_tree[e] = true;
  }
  return in_tree;
}

std::vector<Cycle> FundamentalCycles(const std::vector<ModuleId>& vertices, const std::vector<NetworkEdge>& edges,
                                     const std::vector<bool>& in_tree) {
  const int m = static_cast<int>(edges.size());
  std::map<ModuleId, std::vector<std::pair<ModuleId, int>>> tree_adj;
  for (int e = 0; e < m; ++e) {
    if (!in_tree[e]) continue;
    tree_adj[edges[e].u].push_back({edges[e].v, e});
    tree_adj[edges[e].v].push_back({edges[e].u, e});
  }
  // Tree parents by BFS from the first vertex (a tree: every vertex's
  // parent and depth are the same in any visiting order).
  std::map<ModuleId, std::pair<ModuleId, int>> up;  // vertex -> (parent, edge)
  std::map<ModuleId, int> depth;
  if (!vertices.empty()) {
    std::deque<ModuleId> queue{vertices.front()};
    depth[vertices.front()] = 0;
    while (!queue.empty()) {
      const ModuleId at = queue.front();
      queue.pop_front();
      for (const auto& [next, e] : tree_adj[at]) {
        if (depth.count(next)) continue;
        depth[next] = depth[at] + 1;
        up[next] = {at, e};
        queue.push_back(next);
      }
    }
  }
  std::vector<Cycle> cycles;
  for (int f = 0; f < m; ++f) {
    if (in_tree[f]) continue;
    Cycle c;
    c.terms.push_back({f, 1});
    // Path v -> u through the tree: climb both to their common ancestor.
    ModuleId a = edges[f].v, b = edges[f].u;
    std::vector<ModuleId> from_a{a}, from_b{b};
    std::vector<std::pair<int, int>> tail;  // terms from the b side, reversed later
    while (a != b) {
      if (depth[a] >= depth[b]) {
        const auto [p, e] = up[a];
        c.terms.push_back({e, a < p ? 1 : -1});
        a = p;
        from_a.push_back(a);
      } else {
        const auto [p, e] = up[b];
        tail.push_back({e, p < b ? 1 : -1});  // traversed p -> b
        b = p;
        from_b.push_back(b);
      }
    }
    c.terms.insert(c.terms.end(), tail.rbegin(), tail.rend());
    std::string text = Id(edges[f].u);
    for (ModuleId v : from_a) text += "-" + Id(v);
    for (auto it = from_b.rbegin() + 1; it != from_b.rend(); ++it) text += "-" + Id(*it);
    c.text = text;
    cycles.push_back(std::move(c));
  }
  return cycles;
}

PhaseSolution SolvePhases(const std::vector<ModuleId>& vertices, const std::vector<NetworkEdge>& edges,
                          std::vector<EdgeTie> ties, const std::set<int>& keep_free,
                          const std::vector<bool>& base_edge) {
  PhaseSolution sol;
  const std::vector<bool> in_tree = SpanningTree(vertices, edges, keep_free);
  const std::vector<Cycle> cycles = FundamentalCycles(vertices, edges, in_tree);
  for (const Cycle& c : cycles) sol.loops.push_back(c.text);
  for (;;) {
    Elimination elimination = EliminateLoops(cycles, ties, in_tree, keep_free, base_edge);
    if (elimination.failure) {
      bool any = false;
      for (int cls : elimination.failure->classes) any = any || ClassSize(ties, cls) > 1;
      YAMOR_CHECK(any, "an untied phase system must be solvable");
      SplitClasses(ties, edges, *elimination.failure, sol.untied);
      continue;
    }
    sol.ties = ties;
    sol.pivots = std::move(elimination.pivots);
    for (int cls = 0; cls < ClassCount(ties); ++cls) {
      if (!sol.pivots.count(cls)) sol.free_classes.push_back(cls);
    }
    return sol;
  }
}

std::vector<std::string> ClassNames(const PhaseSolution& sol, const std::vector<NetworkEdge>& edges) {
  std::vector<std::string> names;
  for (int e = 0; e < static_cast<int>(edges.size()); ++e) {
    const int cls = sol.ties[e].cls;
    if (cls >= static_cast<int>(names.size())) names.resize(cls + 1);
    if (names[cls].empty()) names[cls] = PhaseName(edges[e].u, edges[e].v);
  }
  return names;
}

std::vector<TiedParameter> PhaseRules(const PhaseSolution& sol, const std::vector<NetworkEdge>& edges,
                                      const BasePhases* base, std::vector<std::string>* notes) {
  const auto names = ClassNames(sol, edges);
  // Base value of each class variable: y = sign·(x_e − pi·π) of any of its
  // configured edges (base ties agree, GenerateProblem splits them otherwise).
  std::map<int, double> class_base;
  if (base != nullptr) {
    for (int e = 0; e < static_cast<int>(edges.size()); ++e) {
      const EdgeTie& t = sol.ties[e];
      if (base->forward[e] && !class_base.count(t.cls)) {
        class_base[t.cls] = t.sign * (*base->forward[e] - t.pi * kPi);
      }
    }
  }
  std::vector<TiedParameter> rules;
  for (const auto& [cls, expr] : sol.pivots) {
    // y ≡ Σ a·y_j + pi·π (+ r, the base's sum), so y = M2Pi(Σ (-a)·y_j + pi·π − r).
    std::string body;
    for (const auto& [j, a] : expr.coef) body += Term(-a, names[j], body.empty());
    if (expr.pi) body += " + pi";
    bool known = class_base.count(cls) > 0;
    double sum = known ? class_base[cls] - expr.pi * kPi : 0;
    for (const auto& [j, a] : expr.coef) {
      known = known && class_base.count(j) > 0;
      if (known) sum -= a * class_base[j];
    }
    if (known && AngleGap(sum, 0) > kSameValue) {
      const double r = std::remainder(sum, 2 * kPi);
      body += Constant(-r);
      if (notes) {
        notes->push_back("the base configuration's phases do not close a loop through " + names[cls] +
                         " (off by " + FormatDouble(r) + " rad); the rule keeps that sum");
      }
    }
    rules.push_back({names[cls], "M2Pi(" + body + ")"});
  }
  for (int e = 0; e < static_cast<int>(edges.size()); ++e) {
    const std::string own = PhaseName(edges[e].u, edges[e].v);
    const EdgeTie& t = sol.ties[e];
    if (own != names[t.cls]) {
      const std::string ref = names[t.cls] + "()";
      std::string expr = t.sign > 0 ? ref : "-" + ref;
      if (t.pi) expr = "M2Pi(" + std::string(t.sign > 0 ? "-" : "") + ref + " + pi)";
      rules.push_back({own, expr});
    }
  }
  for (int e = 0; e < static_cast<int>(edges.size()); ++e) {
    const NetworkEdge& ne = edges[e];
    const std::string back = PhaseName(ne.v, ne.u), fwd = PhaseName(ne.u, ne.v);
    // Both directions of an edge form a loop: x_vu ≡ −x_uv (+ the base's sum).
    if (base != nullptr && base->forward[e] && base->backward[e] &&
        AngleGap(*base->forward[e] + *base->backward[e], 0) > kSameValue) {
      const double r = std::remainder(*base->forward[e] + *base->backward[e], 2 * kPi);
      rules.push_back({back, "M2Pi(" + fwd + "()" + Constant(-r) + ")"});
      if (notes) {
        notes->push_back("the base configuration's couplings " + EdgeName(ne) + " are not opposite (" + fwd +
                         " + " + back + " = " + FormatDouble(r) + " rad); the rule keeps that sum");
      }
      continue;
    }
    rules.push_back({back, "-" + fwd + "()"});
  }
  return rules;
}

PhaseSystem BuildPhaseSystem(const std::vector<ModuleId>& vertices,
                             const std::vector<NetworkEdge>& edges,
                             const std::vector<std::pair<ModuleId, ModuleId>>& keep_free) {
  std::vector<EdgeTie> ties(edges.size());
  for (size_t e = 0; e < edges.size(); ++e) ties[e] = {.cls = static_cast<int>(e)};
  const PhaseSolution sol = SolvePhases(vertices, edges, ties, KeepFreeIndices(edges, keep_free));
  PhaseSystem out;
  const auto names = ClassNames(sol, edges);
  for (int cls : sol.free_classes) out.free.push_back(names[cls]);
  out.tied = PhaseRules(sol, edges);
  out.loops = sol.loops;
  return out;
}

}  // namespace yamor::cpg
