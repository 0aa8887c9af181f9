// A seeded random module graph for tests: connected, labels from a small
// alphabet (right-angle connections) so that symmetric graphs are common.
#pragma once

#include <optional>
#include <random>
#include <set>
#include <vector>

#include "cpg/module_graph.h"

namespace yamor::cpg::test {

// A random connected graph: each new module's front (or another connector)
// screwed onto a free connector of an earlier one at a right angle, and a
// few extra connections; labels from a small alphabet so symmetric graphs
// are common.
inline ModuleGraph RandomModuleGraph(std::mt19937& rng, int n, bool extra_edges, int active_one_in = 4) {
  std::vector<GraphModule> modules;
  for (int i = 0; i < n; ++i) modules.push_back({.id = i * 3 % 251, .active = active_one_in <= 0 || rng() % active_one_in != 0});
  std::vector<GraphEdge> edges;
  std::set<std::pair<int, Connector>> used;
  auto free_connector = [&](int id, bool front_first) -> std::optional<Connector> {
    std::vector<Connector> options;
    for (int c = 0; c < kConnectorCount; ++c) {
      if (!used.count({id, static_cast<Connector>(c)})) options.push_back(static_cast<Connector>(c));
    }
    if (options.empty()) return std::nullopt;
    if (front_first && !used.count({id, Connector::kFront})) return Connector::kFront;
    return options[rng() % options.size()];
  };
  for (int i = 1; i < n; ++i) {
    for (int attempt = 0; attempt < 20; ++attempt) {
      const int parent = modules[rng() % i].id;
      auto cp = free_connector(parent, false);
      auto cc = free_connector(modules[i].id, rng() % 4 != 0);
      if (!cp || !cc) continue;
      used.insert({parent, *cp});
      used.insert({modules[i].id, *cc});
      edges.push_back({modules[i].id, *cc, parent, *cp, static_cast<int>(rng() % 4) * 6});
      break;
    }
  }
  const int extra = extra_edges ? static_cast<int>(rng() % (n / 2 + 1)) : 0;
  for (int k = 0; k < extra; ++k) {
    const int a = modules[rng() % n].id, b = modules[rng() % n].id;
    if (a == b) continue;
    auto ca = free_connector(a, false);
    auto cb = free_connector(b, false);
    if (!ca || !cb) continue;
    used.insert({a, *ca});
    used.insert({b, *cb});
    edges.push_back({a, *ca, b, *cb, static_cast<int>(rng() % 4) * 6});
  }
  return ModuleGraph(modules.front().id, modules, edges);
}

}  // namespace yamor::cpg::test
