// Cost of generating an optimization problem from a morphology (thesis 7.4),
// reported as problems/s (items).
//
// `cpg_build/lattice/<n>` is yamor::cpg::GenerateProblem on a square lattice
// of n modules (every module coupled to its right and upper neighbour: many
// loops): network, spanning-tree loop constraints, nauty symmetries and the
// budget rule. `cpg_build_baseline/lattice/<n>` is the thesis's constraining
// algorithm (7.4.2) written as the thesis gives it: every loop of the CPG
// graph enumerated by a recursive walk (both directions of each edge, 2-loops
// included, rotations removed), then edges fixed free one at a time and every
// loop with a single unset edge constrained, until nothing is left. Its loop
// count grows exponentially, so it runs only up to 25 modules; both must find
// the same number of free phases (n - 1). tools/bench/run.sh pairs the two.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <functional>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "cpg/module_graph.h"
#include "cpg/problem.h"

namespace {

using yamor::cpg::Connector;
using yamor::cpg::GraphEdge;
using yamor::cpg::GraphModule;
using yamor::cpg::ModuleGraph;

ModuleGraph Lattice(int side) {
  std::vector<GraphModule> modules;
  std::vector<GraphEdge> edges;
  auto id = [&](int x, int y) { return y * side + x; };
  for (int y = 0; y < side; ++y) {
    for (int x = 0; x < side; ++x) {
      modules.push_back({.id = id(x, y)});
      if (x + 1 < side) edges.push_back({id(x + 1, y), Connector::kLeft, id(x, y), Connector::kRight, 0});
      if (y + 1 < side) edges.push_back({id(x, y + 1), Connector::kBottom, id(x, y), Connector::kTop, 0});
    }
  }
  return ModuleGraph(0, modules, edges);
}

void BenchGenerate(benchmark::State& state, int side) {
  const ModuleGraph graph = Lattice(side);
  const yamor::cpg::ProblemOptions options{.max_free = 100000};
  const auto check = yamor::cpg::GenerateProblem(graph, nullptr, {.use_symmetry = false, .max_free = 100000});
  int phases = 0;
  for (const auto& p : check.free) phases += p.param.rfind("phase.", 0) == 0;
  if (phases != side * side - 1) {
    state.SkipWithError("free phases != modules - 1");
    return;
  }
  for (auto _ : state) {
    auto problem = yamor::cpg::GenerateProblem(graph, nullptr, options);
    benchmark::DoNotOptimize(problem);
  }
  state.SetItemsProcessed(state.iterations());
}

// The thesis's algorithm, on the directed CPG graph (an edge both ways).
int ThesisFreePhases(const ModuleGraph& graph) {
  std::map<int, std::vector<int>> adj;
  for (const GraphEdge& e : graph.edges()) {
    adj[e.a].push_back(e.b);
    adj[e.b].push_back(e.a);
  }
  using Edge = std::pair<int, int>;
  std::vector<std::vector<Edge>> loops;
  std::set<std::vector<int>> seen;
  // Path(G, A, A): every walk back to A without repeating a vertex.
  std::vector<int> path;
  std::function<void(int, int)> walk = [&](int start, int at) {
    for (int next : adj[at]) {
      if (next == start && path.size() >= 2) {
        // Remove rotations: keep the rotation starting at the smallest vertex.
        std::vector<int> key = path;
        std::rotate(key.begin(), std::min_element(key.begin(), key.end()), key.end());
        if (!seen.insert(key).second) continue;
        std::vector<Edge> loop;
        for (size_t i = 0; i < path.size(); ++i) loop.push_back({path[i], path[(i + 1) % path.size()]});
        loops.push_back(std::move(loop));
      } else if (std::find(path.begin(), path.end(), next) == path.end()) {
        path.push_back(next);
        walk(start, next);
        path.pop_back();
      }
    }
  };
  for (const auto& [v, ns] : adj) {
    path = {v};
    walk(v, v);
  }
  std::map<Edge, bool> cn;  // edge -> true when free, false when constrained
  int free = 0;
  for (;;) {
    bool fixed = false;
    for (const auto& loop : loops) {
      for (const Edge& e : loop) {
        if (!cn.count(e)) {
          cn[e] = true;
          ++free;
          fixed = true;
          break;
        }
      }
      if (fixed) break;
    }
    if (!fixed) break;
    for (bool changed = true; changed;) {
      changed = false;
      for (const auto& loop : loops) {
        int unset = 0;
        Edge last;
        for (const Edge& e : loop) {
          if (!cn.count(e)) {
            ++unset;
            last = e;
          }
        }
        if (unset == 1) {
          cn[last] = false;
          changed = true;
        }
      }
    }
  }
  return free;
}

void BenchThesis(benchmark::State& state, int side) {
  const ModuleGraph graph = Lattice(side);
  if (ThesisFreePhases(graph) != side * side - 1) {
    state.SkipWithError("the thesis algorithm found another number of free phases");
    return;
  }
  for (auto _ : state) benchmark::DoNotOptimize(ThesisFreePhases(graph));
  state.SetItemsProcessed(state.iterations());
}

}  // namespace

int main(int argc, char** argv) {
  for (const int side : {3, 4, 5, 8}) {
    const std::string suffix = "/lattice/" + std::to_string(side * side);
    benchmark::RegisterBenchmark(("cpg_build" + suffix).c_str(), BenchGenerate, side)
        ->Unit(benchmark::kMillisecond);
    if (side <= 5) {
      benchmark::RegisterBenchmark(("cpg_build_baseline" + suffix).c_str(), BenchThesis, side)
          ->Unit(benchmark::kMillisecond);
    }
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
