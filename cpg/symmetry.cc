#include "cpg/symmetry.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <mutex>
#include <numeric>
#include <set>
#include <unordered_set>

#include "common/status.h"

// nauty is C; its header defines short macros (TRUE, FALSE, SETWD, ...), so it
// is included last and only here.
#include <nauty/nauty.h>
#include <nauty/nautinv.h>

namespace yamor::cpg {
namespace {

// A body map as a code: F = Rx(90°)^turns · Y^mirror, Y = diag(1, -1, 1).
struct BodyCode {
  int turns = 0;        // quarter turns about x, 0..3
  bool mirror = false;  // the module's own x-z reflection first
};

// (F2 ∘ F1): Rq^a Y^m Rq^b Y^n = Rq^(a ± b) Y^(m+n), since Y Rq Y = Rq^-1.
BodyCode Compose(const BodyCode& second, const BodyCode& first) {
  const int b = second.mirror ? -first.turns : first.turns;
  return {.turns = ((second.turns + b) % 4 + 4) % 4, .mirror = second.mirror != first.mirror};
}

Eigen::Matrix3i QuarterTurnX() {
  Eigen::Matrix3i r;
  r << 1, 0, 0, 0, 0, -1, 0, 1, 0;
  return r;
}

Eigen::Matrix3i ToMatrix(const BodyCode& code) {
  Eigen::Matrix3i f = Eigen::Matrix3i::Identity();
  for (int i = 0; i < code.turns; ++i) f = QuarterTurnX() * f;
  if (code.mirror) {
    Eigen::Matrix3i y = Eigen::Matrix3i::Identity();
    y(1, 1) = -1;
    f = f * y;
  }
  return f;
}

std::optional<BodyCode> FromMatrix(const Eigen::Matrix3i& f) {
  for (int mirror = 0; mirror < 2; ++mirror) {
    for (int turns = 0; turns < 4; ++turns) {
      const BodyCode code{.turns = turns, .mirror = mirror == 1};
      if (ToMatrix(code) == f) return code;
    }
  }
  return std::nullopt;
}

// Quarter turns a module of this kind may use: a driven module only half turns.
int TurnStep(bool active) { return active ? 2 : 1; }
int FrameCount(bool active) { return active ? 2 : 4; }

bool Allowed(bool active, const BodyCode& code) { return code.turns % TurnStep(active) == 0; }

struct Labelled {
  Connector a_connector, b_connector;
  int angle;
};

// A connection seen through body maps of its two ends (det = ±1 of both).
Labelled Transform(const GraphEdge& e, const Eigen::Matrix3i& fa, const Eigen::Matrix3i& fb,
                   int det) {
  const auto [ca, da] = MapConnector(fa, e.a_connector);
  const auto [cb, db] = MapConnector(fb, e.b_connector);
  const int angle = ((det * e.angle_steps + da + db) % kAngleSteps + kAngleSteps) % kAngleSteps;
  return {ca, cb, angle};
}

// Symmetry in code form.
struct Element {
  std::vector<int> image;
  std::vector<BodyCode> body;
  bool mirror = false;

  Symmetry ToSymmetry() const {
    Symmetry s{.image = image, .mirror = mirror};
    for (const BodyCode& c : body) s.body.push_back(ToMatrix(c));
    return s;
  }
  std::string Key() const {
    std::string k;
    for (size_t i = 0; i < image.size(); ++i) {
      k += std::to_string(image[i]) + ':' + std::to_string(body[i].turns) + (body[i].mirror ? 'm' : 'r') + ',';
    }
    return k;
  }
};

Element ComposeElements(const Element& second, const Element& first) {
  Element out{.image = first.image, .body = first.body, .mirror = first.mirror != second.mirror};
  for (size_t i = 0; i < first.image.size(); ++i) {
    out.image[i] = second.image[first.image[i]];
    out.body[i] = Compose(second.body[first.image[i]], first.body[i]);
  }
  return out;
}

// --- nauty plumbing -------------------------------------------------------

std::mutex& NautyMutex() {
  static std::mutex mutex;
  return mutex;
}

thread_local std::vector<std::vector<int>>* collected_generators = nullptr;

void CollectAutomorphism(int, int* perm, int*, int, int, int n) {
  if (collected_generators) collected_generators->emplace_back(perm, perm + n);
}

// A vertex-coloured (di)graph for nauty.
struct ColouredGraph {
  int n = 0;
  std::vector<std::string> colour;
  std::vector<std::pair<int, int>> arcs;  // directed; add both for an edge

  int AddVertex(std::string c) {
    colour.push_back(std::move(c));
    return n++;
  }
  void AddEdge(int a, int b) {
    arcs.emplace_back(a, b);
    arcs.emplace_back(b, a);
  }
};

struct NautyResult {
  std::vector<std::vector<int>> generators;
  std::vector<int> lab;            // canonical order: position -> vertex
  std::vector<setword> canonical;  // canonical graph rows
  std::vector<std::string> cell_keys;  // colour of each cell, in order
  std::vector<int> cell_sizes;
  double group_size = 1;
  int m = 0;
};

NautyResult RunNauty(const ColouredGraph& cg, bool digraph, bool canon) {
  NautyResult out;
  const int n = cg.n;
  const int m = SETWORDSNEEDED(n);
  out.m = m;
  std::vector<setword> g(static_cast<size_t>(m) * n, 0);
  for (const auto& [a, b] : cg.arcs) ADDONEARC(g.data(), a, b, m);
  // Cells in colour order, vertices by index inside a cell.
  std::map<std::string, std::vector<int>> cells;
  for (int v = 0; v < n; ++v) cells[cg.colour[v]].push_back(v);
  std::vector<int> lab, ptn(n, 1), orbits(n);
  for (auto& [key, vs] : cells) {
    lab.insert(lab.end(), vs.begin(), vs.end());
    ptn[lab.size() - 1] = 0;
    out.cell_keys.push_back(key);
    out.cell_sizes.push_back(static_cast<int>(vs.size()));
  }
  statsblk stats;
  std::vector<setword> cg_out(canon ? static_cast<size_t>(m) * n : 1, 0);
  std::lock_guard lock(NautyMutex());
  nauty_check(WORDSIZE, m, n, NAUTYVERSIONID);
  // nauty's two default option sets differ only in the digraph flag and the
  // vertex invariant a digraph needs.
  DEFAULTOPTIONS_GRAPH(graph_options);
  DEFAULTOPTIONS_DIGRAPH(digraph_options);
  optionblk options = digraph ? digraph_options : graph_options;
  options.defaultptn = FALSE;
  options.getcanon = canon ? TRUE : FALSE;
  options.userautomproc = CollectAutomorphism;
  collected_generators = &out.generators;
  densenauty(g.data(), lab.data(), ptn.data(), orbits.data(), &options, &stats, m, n,
             canon ? cg_out.data() : nullptr);
  collected_generators = nullptr;
  out.group_size = stats.grpsize1 * std::pow(10.0, stats.grpsize2);
  out.lab = lab;
  if (canon) out.canonical = std::move(cg_out);
  return out;
}

// The gadget of thesis-free symmetry search: per module a vertex and a
// directed cycle of frames (one per allowed turn); per connection and pair
// of frames two end vertices coloured by how the connection looks from them.
struct Gadget {
  ColouredGraph graph;
  std::vector<int> frame_start;
};

Gadget BuildGadget(const ModuleGraph& graph, const std::vector<GraphEdge>& edges) {
  Gadget gd;
  const auto& modules = graph.modules();
  const int n = static_cast<int>(modules.size());
  for (int i = 0; i < n; ++i) gd.graph.AddVertex(modules[i].active ? "m|driven" : "m|passive");
  for (int i = 0; i < n; ++i) {
    const bool active = modules[i].active;
    gd.frame_start.push_back(gd.graph.n);
    const int count = FrameCount(active);
    for (int f = 0; f < count; ++f) {
      const int v = gd.graph.AddVertex(active ? "f|driven" : "f|passive");
      gd.graph.AddEdge(i, v);
    }
    for (int f = 0; f < count; ++f) {
      gd.graph.arcs.emplace_back(gd.frame_start[i] + f, gd.frame_start[i] + (f + 1) % count);
    }
  }
  for (const GraphEdge& e : edges) {
    const int ia = graph.IndexOf(e.a), ib = graph.IndexOf(e.b);
    const bool aa = modules[ia].active, ab = modules[ib].active;
    for (int g = 0; g < FrameCount(aa); ++g) {
      for (int h = 0; h < FrameCount(ab); ++h) {
        const Labelled l = Transform(e, ToMatrix({.turns = g * TurnStep(aa)}),
                                     ToMatrix({.turns = h * TurnStep(ab)}), 1);
        const int va = gd.graph.AddVertex("e|" + std::string(ConnectorName(l.a_connector)) + "|" +
                                          std::to_string(l.angle));
        const int vb = gd.graph.AddVertex("e|" + std::string(ConnectorName(l.b_connector)) + "|" +
                                          std::to_string(l.angle));
        gd.graph.AddEdge(va, gd.frame_start[ia] + g);
        gd.graph.AddEdge(vb, gd.frame_start[ib] + h);
        gd.graph.AddEdge(va, vb);
      }
    }
  }
  return gd;
}

// Reads a module map off a gadget vertex map; tries both turn conventions
// and returns the one that checks.
std::optional<Element> ToElement(const ModuleGraph& graph, const Gadget& from, const Gadget& to,
                                 const std::vector<int>& vertex_map, bool mirror) {
  const auto& modules = graph.modules();
  const int n = static_cast<int>(modules.size());
  for (int sign : {1, -1}) {
    Element el{.image = std::vector<int>(n), .body = std::vector<BodyCode>(n), .mirror = mirror};
    bool ok = true;
    for (int i = 0; i < n && ok; ++i) {
      const int j = vertex_map[i];
      if (j < 0 || j >= n) {
        ok = false;
        break;
      }
      el.image[i] = j;
      const int f = vertex_map[from.frame_start[i]] - to.frame_start[j];
      if (f < 0 || f >= FrameCount(modules[j].active)) {
        ok = false;
        break;
      }
      const int turns = ((sign * f * TurnStep(modules[i].active)) % 4 + 4) % 4;
      el.body[i] = {.turns = turns, .mirror = mirror};
    }
    if (ok && IsSymmetry(graph, el.ToSymmetry())) return el;
  }
  return std::nullopt;
}

std::vector<GraphEdge> Mirrored(const std::vector<GraphEdge>& edges) {
  const Eigen::Matrix3i y = ToMatrix({.turns = 0, .mirror = true});
  std::vector<GraphEdge> out;
  for (const GraphEdge& e : edges) {
    const Labelled l = Transform(e, y, y, -1);
    out.push_back({.a = e.a, .a_connector = l.a_connector, .b = e.b, .b_connector = l.b_connector,
                   .angle_steps = l.angle});
  }
  return out;
}

// Does `el` keep the robot's up direction (graphs with geometry only)?
bool KeepsUp(const ModuleGraph& graph, const Element& el) {
  const auto& modules = graph.modules();
  if (!graph.has_geometry() || !graph.up()) return true;
  std::optional<Eigen::Matrix3d> t;
  for (size_t i = 0; i < modules.size(); ++i) {
    const Eigen::Matrix3d f = ToMatrix(el.body[i]).cast<double>();
    const Eigen::Matrix3d ti =
        *modules[el.image[i]].orientation * f * modules[i].orientation->transpose();
    if (!t) {
      t = ti;
    } else if ((*t - ti).cwiseAbs().maxCoeff() > 1e-6) {
      return false;  // not one rigid map of the robot: not a symmetry of its shape
    }
  }
  return ((*t) * *graph.up() - *graph.up()).norm() < 1e-6;
}

uint64_t Fnv1a(const std::string& bytes) {
  uint64_t h = 1469598103934665603ull;
  for (unsigned char c : bytes) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return h;
}

}  // namespace

int Symmetry::ServoSign(int index) const {
  const auto code = FromMatrix(body.at(index));
  YAMOR_CHECK(code.has_value(), "body map is not a module symmetry");
  return code->turns == 2 ? -1 : 1;
}

std::vector<Eigen::Matrix3i> AllowedBodyMaps(bool active, bool mirror) {
  std::vector<Eigen::Matrix3i> out;
  for (int turns = 0; turns < 4; turns += TurnStep(active)) {
    out.push_back(ToMatrix({.turns = turns, .mirror = mirror}));
  }
  return out;
}

std::pair<Connector, int> MapConnector(const Eigen::Matrix3i& body, Connector connector) {
  const Eigen::Vector3i normal = body * ConnectorNormal(connector);
  const Eigen::Vector3i north = body * ConnectorNorth(connector);
  for (int i = 0; i < kConnectorCount; ++i) {
    const auto c = static_cast<Connector>(i);
    if (ConnectorNormal(c) != normal) continue;
    const Eigen::Vector3i ref = ConnectorNorth(c);
    int steps = 0;
    if (north == ref) {
      steps = 0;
    } else if (north == -ref) {
      steps = 12;
    } else if (ref.cross(north) == normal) {
      steps = 6;
    } else {
      steps = 18;
    }
    return {c, steps};
  }
  YAMOR_CHECK(false, "a body map must map connector normals onto connector normals");
  return {connector, 0};
}

bool IsSymmetry(const ModuleGraph& graph, const Symmetry& s) {
  const auto& modules = graph.modules();
  const size_t n = modules.size();
  if (s.image.size() != n || s.body.size() != n) return false;
  std::vector<bool> hit(n, false);
  const int det = s.mirror ? -1 : 1;
  for (size_t i = 0; i < n; ++i) {
    const int j = s.image[i];
    if (j < 0 || static_cast<size_t>(j) >= n || hit[j]) return false;
    hit[j] = true;
    if (modules[i].active != modules[j].active) return false;
    const auto code = FromMatrix(s.body[i]);
    if (!code || code->mirror != s.mirror || !Allowed(modules[i].active, *code)) return false;
  }
  // (module, connector) -> (other module, other connector, angle)
  std::map<std::pair<ModuleId, Connector>, std::tuple<ModuleId, Connector, int>> ends;
  for (const GraphEdge& e : graph.edges()) {
    ends[{e.a, e.a_connector}] = {e.b, e.b_connector, e.angle_steps};
    ends[{e.b, e.b_connector}] = {e.a, e.a_connector, e.angle_steps};
  }
  for (const GraphEdge& e : graph.edges()) {
    const int ia = graph.IndexOf(e.a), ib = graph.IndexOf(e.b);
    const Labelled l = Transform(e, s.body[ia], s.body[ib], det);
    const ModuleId a2 = modules[s.image[ia]].id, b2 = modules[s.image[ib]].id;
    auto it = ends.find({a2, l.a_connector});
    if (it == ends.end()) return false;
    if (it->second != std::tuple{b2, l.b_connector, l.angle}) return false;
  }
  return true;
}

SymmetryGroup FindSymmetries(const ModuleGraph& graph, const SymmetryOptions& options) {
  SymmetryGroup out;
  const auto& modules = graph.modules();
  const int n = static_cast<int>(modules.size());
  const Gadget gadget = BuildGadget(graph, graph.edges());
  const bool want_canon = options.mirrors;
  NautyResult direct = RunNauty(gadget.graph, /*digraph=*/true, want_canon);
  out.full_order = direct.group_size;

  std::vector<Element> generators;
  for (const auto& perm : direct.generators) {
    auto el = ToElement(graph, gadget, gadget, perm, false);
    YAMOR_CHECK(el.has_value(), "a nauty automorphism of the gadget is not a module symmetry");
    generators.push_back(*el);
  }
  if (options.mirrors) {
    const Gadget mirrored = BuildGadget(graph, Mirrored(graph.edges()));
    NautyResult image = RunNauty(mirrored.graph, true, true);
    if (image.cell_keys == direct.cell_keys && image.cell_sizes == direct.cell_sizes &&
        image.canonical == direct.canonical) {
      // Canonical position p holds vertex direct.lab[p] in G and image.lab[p]
      // in the mirror image: that pairing is an isomorphism.
      std::vector<int> map(gadget.graph.n);
      for (int p = 0; p < gadget.graph.n; ++p) map[direct.lab[p]] = image.lab[p];
      auto el = ToElement(graph, gadget, mirrored, map, true);
      YAMOR_CHECK(el.has_value(), "the mirror isomorphism is not a module symmetry");
      generators.push_back(*el);
      out.full_order *= 2;
    }
  }
  for (const Element& g : generators) out.generators.push_back(g.ToSymmetry());

  // Enumerate the group when it is small enough.
  Element identity{.image = std::vector<int>(n), .body = std::vector<BodyCode>(n)};
  std::iota(identity.image.begin(), identity.image.end(), 0);
  std::vector<Element> all{identity};
  std::unordered_set<std::string> seen{identity.Key()};
  bool complete = true;
  for (size_t at = 0; at < all.size(); ++at) {
    for (const Element& g : generators) {
      Element next = ComposeElements(g, all[at]);
      if (!seen.insert(next.Key()).second) continue;
      if (static_cast<int>(all.size()) >= options.max_elements) {
        complete = false;
        break;
      }
      all.push_back(std::move(next));
    }
    if (!complete) break;
  }
  out.enumerated = complete;
  std::vector<Element> kept;
  const std::vector<Element>& candidates = complete ? all : generators;
  for (const Element& el : candidates) {
    if (options.respect_gravity && !KeepsUp(graph, el)) {
      ++out.dropped_for_gravity;
      continue;
    }
    kept.push_back(el);
  }
  if (!complete) kept.insert(kept.begin(), identity);
  for (const Element& el : kept) out.elements.push_back(el.ToSymmetry());

  std::vector<int> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  auto root = [&](int v) {
    while (parent[v] != v) v = parent[v] = parent[parent[v]];
    return v;
  };
  for (const Element& el : kept) {
    for (int i = 0; i < n; ++i) parent[root(i)] = root(el.image[i]);
  }
  std::map<int, std::vector<ModuleId>> orbits;
  for (int i = 0; i < n; ++i) orbits[root(i)].push_back(modules[i].id);
  for (auto& [r, ids] : orbits) out.orbits.push_back(ids);
  std::sort(out.orbits.begin(), out.orbits.end());
  return out;
}

std::string MorphologyKey(const ModuleGraph& graph) {
  ColouredGraph cg;
  const auto& modules = graph.modules();
  for (const GraphModule& m : modules) {
    cg.AddVertex(std::string("m|") + (m.active ? "driven" : "passive") +
                 (m.id == graph.central() ? "|central" : ""));
  }
  for (const GraphEdge& e : graph.edges()) {
    const std::string angle = std::to_string(e.angle_steps);
    const int va = cg.AddVertex("e|" + std::string(ConnectorName(e.a_connector)) + "|" + angle);
    const int vb = cg.AddVertex("e|" + std::string(ConnectorName(e.b_connector)) + "|" + angle);
    cg.AddEdge(va, graph.IndexOf(e.a));
    cg.AddEdge(vb, graph.IndexOf(e.b));
    cg.AddEdge(va, vb);
  }
  const NautyResult r = RunNauty(cg, false, true);
  std::string bytes = std::to_string(cg.n) + ";";
  for (size_t c = 0; c < r.cell_keys.size(); ++c) {
    bytes += r.cell_keys[c] + "#" + std::to_string(r.cell_sizes[c]) + ";";
  }
  char word[20];
  for (setword w : r.canonical) {
    std::snprintf(word, sizeof word, "%016llx", static_cast<unsigned long long>(w));
    bytes += word;
  }
  char key[20];
  std::snprintf(key, sizeof key, "%016llx", static_cast<unsigned long long>(Fnv1a(bytes)));
  return key;
}

}  // namespace yamor::cpg
