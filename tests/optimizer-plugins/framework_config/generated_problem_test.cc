// Generated problems (cpg/problem.h) load with the optimization config
// loader, and every loop of the network keeps its phases summing to a
// multiple of 2π for any point the optimizer picks (thesis 7.4.2): checked on
// 1000 seeded random graphs against an independent cycle enumeration.
#include <cmath>
#include <functional>
#include <map>
#include <numbers>
#include <random>
#include <set>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "common/status.h"
#include "cpg/config_xml.h"
#include "cpg/problem.h"
#include "optimizer-plugins/framework/optimization_config.h"
#include "physics/module_graph.h"
#include "physics/morphology.h"
#include "tests/support/random_module_graph.h"

namespace yamor::optimizer {
namespace {

const std::string kConfigs = std::string(YAMOR_SOURCE_DIR) + "/configs/";

// Every simple cycle of the undirected network (up to `cap`), each as a
// vertex list, by depth-first search from its smallest vertex.
std::vector<std::vector<int>> SimpleCycles(const cpg::CpgNetwork& net, size_t cap) {
  std::map<int, std::vector<int>> adj;
  for (const cpg::NetworkEdge& e : net.edges) {
    adj[e.u].push_back(e.v);
    adj[e.v].push_back(e.u);
  }
  std::vector<std::vector<int>> cycles;
  std::vector<int> path;
  std::set<int> on_path;
  std::function<void(int, int)> walk = [&](int start, int at) {
    for (int next : adj[at]) {
      if (cycles.size() >= cap) return;
      if (next == start && path.size() >= 3 && path[1] < path.back()) {
        cycles.push_back(path);  // each cycle once: one direction, from its smallest vertex
      } else if (next > start && !on_path.count(next)) {
        path.push_back(next);
        on_path.insert(next);
        walk(start, next);
        on_path.erase(next);
        path.pop_back();
      }
    }
  };
  for (const auto& [v, ns] : adj) {
    path = {v};
    on_path = {v};
    walk(v, v);
  }
  return cycles;
}

double Remainder2Pi(double x) {
  const double r = std::remainder(x, 2 * std::numbers::pi);
  return std::abs(r);
}

TEST(GeneratedProblemTest, EveryWorldLoadsAndResolves) {
  for (const std::string world : {"quadruped", "snake", "tripod", "dog", "trebuchet", "wheel"}) {
    SCOPED_TRACE(world);
    const physics::Morphology m = physics::Morphology::LoadFile(kConfigs + "worlds/" + world + ".xml");
    const cpg::RobotConfig base = cpg::LoadConfigFile(kConfigs + "robots/" + world + ".xml");
    std::vector<int> ids;
    for (const auto& x : m.modules()) ids.push_back(x.id);
    const cpg::ModuleGraph g = physics::ModuleGraphOf(m, cpg::ActivityFromConfig(base, ids));
    const cpg::GeneratedProblem p = cpg::GenerateProblem(g, &base);
    const OptimizationConfig config = OptimizationConfig::Parse(p.OptimizationXml(), world + "-auto.xml");
    EXPECT_EQ(config.optimized().size(), p.free.size());
    EXPECT_LE(config.optimized().size(), 7u);
    const std::vector<double> start = config.StartValues();
    const cpg::RobotConfig applied = config.Apply(start);
    EXPECT_NO_THROW(cpg::Validate(applied));
  }
}

TEST(GeneratedProblemTest, QuadrupedStartIsTheConfiguredGait) {
  const physics::Morphology m = physics::Morphology::LoadFile(kConfigs + "worlds/quadruped.xml");
  const cpg::RobotConfig base = cpg::LoadConfigFile(kConfigs + "robots/quadruped.xml");
  std::vector<int> ids;
  for (const auto& x : m.modules()) ids.push_back(x.id);
  const cpg::GeneratedProblem p =
      cpg::GenerateProblem(physics::ModuleGraphOf(m, cpg::ActivityFromConfig(base, ids)), &base);
  const OptimizationConfig config = OptimizationConfig::Parse(p.OptimizationXml(), "auto");
  const cpg::RobotConfig start = config.Apply(config.StartValues());
  // The thesis quadruped's gait satisfies the generated ties and loop rules,
  // so the start point is that gait, coupling for coupling.
  for (const cpg::Coupling& c : base.couplings) {
    const cpg::Coupling* s = start.FindCoupling(c.from, c.to);
    ASSERT_NE(s, nullptr);
    EXPECT_LT(Remainder2Pi(s->phase - c.phase), 1e-9) << c.from << "->" << c.to;
  }
}

void CheckLoops(const cpg::GeneratedProblem& p, const OptimizationConfig& config, std::mt19937& rng,
                int trial) {
  std::vector<double> x;
  for (const OptimizeRule& r : config.optimized()) {
    x.push_back(std::uniform_real_distribution<double>(r.min, r.max)(rng));
  }
  const cpg::RobotConfig applied = config.Apply(x);
  auto phase = [&](int from, int to) { return applied.FindCoupling(from, to)->phase; };
  for (const cpg::NetworkEdge& e : p.network.edges) {
    ASSERT_LT(Remainder2Pi(phase(e.u, e.v) + phase(e.v, e.u)), 1e-9) << "trial " << trial;
  }
  for (const auto& cycle : SimpleCycles(p.network, 300)) {
    double sum = 0;
    for (size_t i = 0; i < cycle.size(); ++i) sum += phase(cycle[i], cycle[(i + 1) % cycle.size()]);
    ASSERT_LT(Remainder2Pi(sum), 1e-7) << "trial " << trial << ", a loop of " << cycle.size();
  }
}

TEST(GeneratedProblemTest, LoopsCloseOnRandomGraphs) {
  std::mt19937 rng(20261202);
  int with_loops = 0;
  for (int trial = 0; trial < 1000; ++trial) {
    const int n = 1 + static_cast<int>(rng() % 64);
    const cpg::ModuleGraph full = cpg::test::RandomModuleGraph(rng, n, true, /*active_one_in=*/0);
    const cpg::ModuleGraph g = full.Subgraph(full.Components().front());
    const cpg::CpgNetwork net = cpg::BuildNetwork(g);
    // Up to three keep-free couplings that form no loop.
    std::vector<std::pair<int, int>> keep;
    std::map<int, int> parent;
    std::function<int(int)> root = [&](int v) { return parent.count(v) && parent[v] != v ? root(parent[v]) : v; };
    for (const cpg::NetworkEdge& e : net.edges) {
      if (keep.size() >= 3 || rng() % 3 != 0 || root(e.u) == root(e.v)) continue;
      parent[root(e.u)] = root(e.v);
      keep.push_back({e.v, e.u});
    }
    const cpg::GeneratedProblem p =
        cpg::GenerateProblem(g, nullptr, {.use_symmetry = false, .max_free = 100000, .keep_free = keep});
    const OptimizationConfig config = OptimizationConfig::Parse(p.OptimizationXml(), "random");
    int free_phases = 0;
    std::set<std::string> free;
    for (const OptimizeRule& r : config.optimized()) {
      free.insert(r.param);
      free_phases += r.param.rfind("phase.", 0) == 0;
    }
    ASSERT_EQ(free_phases, static_cast<int>(net.oscillators.size()) - 1) << "trial " << trial;
    for (const auto& [a, b] : keep) {
      EXPECT_TRUE(free.count("phase." + std::to_string(std::min(a, b)) + "." + std::to_string(std::max(a, b))));
    }
    with_loops += !p.loops.empty();
    CheckLoops(p, config, rng, trial);
  }
  EXPECT_GT(with_loops, 300);
}

TEST(GeneratedProblemTest, LoopsCloseWithSymmetryTiesAndPassiveModules) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 300; ++trial) {
    const int n = 2 + static_cast<int>(rng() % 24);
    const cpg::ModuleGraph full = cpg::test::RandomModuleGraph(rng, n, true);
    const cpg::ModuleGraph g = full.Subgraph(full.Components().front());
    cpg::GeneratedProblem p;
    try {
      p = cpg::GenerateProblem(g, nullptr, {.max_free = 100000});
    } catch (const yamor::Error& e) {
      ASSERT_THAT(e.what(), ::testing::HasSubstr("no driven module"));
      continue;
    }
    CheckLoops(p, OptimizationConfig::Parse(p.OptimizationXml(), "random"), rng, trial);
  }
}

}  // namespace
}  // namespace yamor::optimizer
