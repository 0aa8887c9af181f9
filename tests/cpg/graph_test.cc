// The body-to-brain library: module graph, network construction, symmetries
// (checked against an independent brute-force search), the morphology key
// and generated problems.
#include <algorithm>
#include <functional>
#include <map>
#include <random>
#include <set>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "common/status.h"
#include "cpg/module_graph.h"
#include "cpg/network_builder.h"
#include "cpg/problem.h"
#include "cpg/symmetry.h"
#include "tests/support/random_module_graph.h"

namespace yamor::cpg {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

constexpr Connector F = Connector::kFront, R = Connector::kRear, L = Connector::kLeft,
                    Ri = Connector::kRight, T = Connector::kTop, B = Connector::kBottom;

// configs/worlds/quadruped.xml, with module 4 passive.
ModuleGraph Quadruped(bool passive_centre = true) {
  std::vector<GraphModule> modules;
  for (int id = 0; id <= 8; ++id) modules.push_back({.id = id, .active = !(passive_centre && id == 4)});
  std::vector<GraphEdge> edges = {
      {0, F, 4, B, 18}, {1, F, 4, L, 0}, {2, F, 4, T, 18}, {3, F, 4, Ri, 12},
      {5, F, 0, R, 18}, {6, F, 1, R, 18}, {7, F, 2, R, 18}, {8, F, 3, R, 18},
  };
  return ModuleGraph(4, modules, edges);
}

// configs/worlds/trebuchet.xml with arm 1 passive.
ModuleGraph Trebuchet() {
  std::vector<GraphModule> modules = {{1, false}, {7, true}, {10, true}, {12, true}};
  std::vector<GraphEdge> edges = {{7, F, 10, L, 0}, {12, F, 10, Ri, 12}, {10, F, 1, R, 0}};
  return ModuleGraph(10, modules, edges);
}

std::vector<ModuleId> Sorted(std::vector<ModuleId> v) {
  std::sort(v.begin(), v.end());
  return v;
}

TEST(ModuleGraphTest, ConnectorsMapUnderBodyTurns) {
  Eigen::Matrix3i quarter;
  quarter << 1, 0, 0, 0, 0, -1, 0, 1, 0;
  // A quarter turn about x takes left to top; left's north +z becomes -y,
  // which is 270° from top's north +x about +z.
  EXPECT_EQ(MapConnector(quarter, L), std::pair(T, 18));
  EXPECT_EQ(MapConnector(quarter, F), std::pair(F, 6));
  EXPECT_EQ(MapConnector(quarter, R), std::pair(R, 18));
  EXPECT_EQ(MapConnector(quarter * quarter, L), std::pair(Ri, 12));
  EXPECT_EQ(MapConnector(quarter * quarter, T), std::pair(B, 0));
}

TEST(ModuleGraphTest, RejectsBadGraphsNamingTheCulprit) {
  auto message = [](auto build) {
    try {
      build();
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_THAT(message([] { ModuleGraph(0, {}, {}); }), HasSubstr("no module"));
  EXPECT_THAT(message([] { ModuleGraph(0, {{0}, {0}}, {}); }), HasSubstr("module 0 appears twice"));
  EXPECT_THAT(message([] { ModuleGraph(0, {{0}, {1}}, {{0, F, 2, R, 0}}); }), HasSubstr("module 2"));
  EXPECT_THAT(message([] { ModuleGraph(0, {{0}, {1}}, {{0, F, 0, R, 0}}); }), HasSubstr("itself"));
  EXPECT_THAT(message([] { ModuleGraph(0, {{0}, {1}, {2}}, {{1, F, 0, R, 0}, {2, F, 0, R, 0}}); }),
              HasSubstr("connector rear of module 0 is used twice"));
  EXPECT_THAT(message([] { ModuleGraph(0, {{0}, {1}}, {{1, F, 0, R, 24}}); }), HasSubstr("angle step 24"));
  EXPECT_THAT(message([] { ModuleGraph(7, {{0}}, {}); }), HasSubstr("central module 7"));
}

TEST(ModuleGraphTest, ComponentsLargestFirst) {
  const ModuleGraph g(5, {{1}, {2}, {5}, {6}, {9}}, {{2, F, 1, R, 0}, {6, F, 5, R, 0}, {9, F, 6, R, 0}});
  EXPECT_THAT(g.Components(), ElementsAre(ElementsAre(5, 6, 9), ElementsAre(1, 2)));
}

TEST(NetworkTest, QuadrupedCouplesTheHipRingAcrossThePassiveBody) {
  const CpgNetwork net = BuildNetwork(Quadruped());
  EXPECT_THAT(net.oscillators, ElementsAre(0, 1, 2, 3, 5, 6, 7, 8));
  EXPECT_THAT(net.passive, ElementsAre(4));
  std::vector<std::pair<int, int>> pairs;
  for (const NetworkEdge& e : net.edges) pairs.push_back({e.u, e.v});
  // Adjacent faces of 4 (bottom-left, left-top, top-right, right-bottom)
  // are coupled; the opposite ones (0-2, 1-3) are not.
  EXPECT_THAT(pairs, ElementsAre(std::pair(0, 1), std::pair(0, 3), std::pair(0, 5), std::pair(1, 2),
                                 std::pair(1, 6), std::pair(2, 3), std::pair(2, 7), std::pair(3, 8)));
}

TEST(NetworkTest, ThesisLiteralNetworkHasEveryModuleAndOnlyPhysicalEdges) {
  const CpgNetwork net = BuildNetwork(Quadruped(), {.couple_across_passive = false});
  EXPECT_EQ(net.oscillators.size(), 9u);
  EXPECT_EQ(net.edges.size(), 8u);
  for (const NetworkEdge& e : net.edges) EXPECT_TRUE(e.physical);
  const RobotConfig config = NetworkConfig(Quadruped(), net, 0.5, 0.3);
  EXPECT_EQ(config.couplings.size(), 16u);
  for (const Coupling& c : config.couplings) {
    EXPECT_EQ(c.phase, 0.0);
    EXPECT_EQ(c.weight, 1.0);
  }
  EXPECT_NO_THROW(Validate(config));
  EXPECT_EQ(config.master_id, 4);
}

TEST(NetworkTest, OppositeFacesAreCoupledWhenNothingElseJoinsThem) {
  // A chain 0 - 1(passive) - 2 through 1's front and rear.
  const ModuleGraph g(0, {{0}, {1, false}, {2}}, {{0, F, 1, R, 0}, {1, F, 2, R, 0}});
  const CpgNetwork net = BuildNetwork(g);
  ASSERT_EQ(net.edges.size(), 1u);
  EXPECT_EQ(net.edges[0], (NetworkEdge{0, 2, false, 1}));
}

TEST(NetworkTest, NoDrivenModuleIsAClearError) {
  const ModuleGraph g(0, {{0, false}, {1, false}}, {{1, F, 0, R, 0}});
  try {
    BuildNetwork(g);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kInvalidArgument);
    EXPECT_THAT(e.what(), HasSubstr("modules 0, 1"));
  }
}

TEST(SymmetryTest, QuadrupedLegsAreOneOrbit) {
  const SymmetryGroup group = FindSymmetries(Quadruped());
  EXPECT_THAT(group.orbits, ElementsAre(ElementsAre(0, 1, 2, 3), ElementsAre(4), ElementsAre(5, 6, 7, 8)));
  // Four quarter turns of the body about its upright axis, and their mirrors.
  EXPECT_EQ(group.full_order, 8);
  EXPECT_TRUE(group.enumerated);
  for (const Symmetry& s : group.elements) {
    EXPECT_TRUE(IsSymmetry(Quadruped(), s));
    // Hip axes are upright: a mirror in a vertical plane reverses their
    // swing; knee axes lie in the mirror's plane or across it and keep theirs.
    for (int i : {0, 1, 2, 3}) EXPECT_EQ(s.ServoSign(Quadruped().IndexOf(i)), s.mirror ? -1 : 1);
    for (int i : {5, 6, 7, 8}) EXPECT_EQ(s.ServoSign(Quadruped().IndexOf(i)), 1);
  }
}

TEST(SymmetryTest, TrebuchetLegsAreMirrorImagesWithReversedServos) {
  const ModuleGraph g = Trebuchet();
  const SymmetryGroup group = FindSymmetries(g);
  EXPECT_THAT(group.orbits, ElementsAre(ElementsAre(1), ElementsAre(7, 12), ElementsAre(10)));
  bool mirror_found = false;
  for (const Symmetry& s : group.elements) {
    if (!s.mirror || s.image[g.IndexOf(7)] != g.IndexOf(12)) continue;
    mirror_found = true;
    EXPECT_EQ(s.ServoSign(g.IndexOf(7)), -1);  // 7 > 0 and 12 < 0 fold both legs down
  }
  EXPECT_TRUE(mirror_found);
  const SymmetryGroup no_mirrors = FindSymmetries(g, {.mirrors = false});
  // Without mirrors only the half turn of 10 about its long axis is left.
  EXPECT_EQ(no_mirrors.full_order, 2);
}

TEST(SymmetryTest, GravityDropsSymmetriesThatTurnTheRobotOver) {
  // A snake of three driven modules lying flat: its half turn about its
  // long axis is a symmetry of the shape but puts it upside down.
  std::vector<GraphModule> modules;
  for (int id = 0; id < 3; ++id) modules.push_back({.id = id, .orientation = Eigen::Matrix3d::Identity()});
  const ModuleGraph g(0, modules, {{1, F, 0, R, 0}, {2, F, 1, R, 0}}, Eigen::Vector3d::UnitZ());
  const SymmetryGroup kept = FindSymmetries(g, {.mirrors = false});
  EXPECT_EQ(kept.full_order, 2);
  EXPECT_EQ(kept.dropped_for_gravity, 1);
  EXPECT_EQ(kept.elements.size(), 1u);
  const SymmetryGroup all = FindSymmetries(g, {.mirrors = false, .respect_gravity = false});
  EXPECT_EQ(all.elements.size(), 2u);
}

// --- brute force ------------------------------------------------------------

// Counts every symmetry by backtracking over module images and body maps,
// checking connections as soon as both ends are placed. Uses IsSymmetry's
// definition only through MapConnector, not nauty.
int BruteForceSymmetries(const ModuleGraph& g, bool mirror, std::vector<std::set<int>>* orbits) {
  const auto& modules = g.modules();
  const int n = static_cast<int>(modules.size());
  Symmetry s{.image = std::vector<int>(n, -1), .body = std::vector<Eigen::Matrix3i>(n), .mirror = mirror};
  std::vector<bool> used(n, false);
  int count = 0;
  const int det = mirror ? -1 : 1;
  std::map<std::pair<ModuleId, Connector>, std::tuple<ModuleId, Connector, int>> ends;
  for (const GraphEdge& e : g.edges()) {
    ends[{e.a, e.a_connector}] = {e.b, e.b_connector, e.angle_steps};
    ends[{e.b, e.b_connector}] = {e.a, e.a_connector, e.angle_steps};
  }
  auto edge_ok = [&](const GraphEdge& e) {
    const int ia = g.IndexOf(e.a), ib = g.IndexOf(e.b);
    const auto [ca, da] = MapConnector(s.body[ia], e.a_connector);
    const auto [cb, db] = MapConnector(s.body[ib], e.b_connector);
    const int angle = ((det * e.angle_steps + da + db) % 24 + 24) % 24;
    auto it = ends.find({modules[s.image[ia]].id, ca});
    return it != ends.end() && it->second == std::tuple{modules[s.image[ib]].id, cb, angle};
  };
  std::function<void(int)> place = [&](int i) {
    if (i == n) {
      EXPECT_TRUE(IsSymmetry(g, s));
      ++count;
      if (orbits) {
        for (int k = 0; k < n; ++k) (*orbits)[k].insert(s.image[k]);
      }
      return;
    }
    for (int j = 0; j < n; ++j) {
      if (used[j] || modules[j].active != modules[i].active) continue;
      for (const Eigen::Matrix3i& f : AllowedBodyMaps(modules[i].active, mirror)) {
        s.image[i] = j;
        s.body[i] = f;
        bool ok = true;
        for (const GraphEdge& e : g.edges()) {
          const int ia = g.IndexOf(e.a), ib = g.IndexOf(e.b);
          if (std::max(ia, ib) != i) continue;
          if (!edge_ok(e)) {
            ok = false;
            break;
          }
        }
        if (!ok) continue;
        used[j] = true;
        place(i + 1);
        used[j] = false;
      }
    }
    s.image[i] = -1;
  };
  place(0);
  return count;
}

TEST(SymmetryTest, AgreesWithBruteForceOnSmallRandomGraphs) {
  std::mt19937 rng(20261202);
  int nontrivial = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const int n = 1 + static_cast<int>(rng() % 9);
    const ModuleGraph g = test::RandomModuleGraph(rng, n, trial % 2 == 0);
    if (g.Components().size() != 1) continue;
    std::vector<std::set<int>> orbits(n);
    const int rotations = BruteForceSymmetries(g, false, &orbits);
    const int mirrors = BruteForceSymmetries(g, true, &orbits);
    const SymmetryGroup group = FindSymmetries(g);
    SCOPED_TRACE(g.Describe());
    EXPECT_EQ(group.full_order, rotations + mirrors);
    ASSERT_TRUE(group.enumerated);
    EXPECT_EQ(static_cast<int>(group.elements.size()), rotations + mirrors);
    // Same orbits.
    std::set<std::vector<ModuleId>> brute;
    for (int i = 0; i < n; ++i) {
      std::vector<ModuleId> ids;
      for (int j : orbits[i]) ids.push_back(g.modules()[j].id);
      brute.insert(Sorted(ids));
    }
    EXPECT_EQ(std::set<std::vector<ModuleId>>(group.orbits.begin(), group.orbits.end()), brute);
    if (rotations + mirrors > 1) ++nontrivial;
  }
  EXPECT_GT(nontrivial, 30);  // the test would mean little on asymmetric graphs only
}

// --- morphology key ---------------------------------------------------------

ModuleGraph Relabel(const ModuleGraph& g, const std::map<ModuleId, ModuleId>& to) {
  std::vector<GraphModule> modules;
  for (GraphModule m : g.modules()) {
    m.id = to.at(m.id);
    modules.push_back(m);
  }
  std::vector<GraphEdge> edges;
  for (GraphEdge e : g.edges()) {
    e.a = to.at(e.a);
    e.b = to.at(e.b);
    edges.push_back(e);
  }
  return ModuleGraph(to.at(g.central()), modules, edges, g.up());
}

TEST(MorphologyKeyTest, SameUnderRelabellingDifferentForAnotherBody) {
  const ModuleGraph q = Quadruped();
  const std::string key = MorphologyKey(q);
  EXPECT_EQ(key.size(), 16u);
  std::mt19937 rng(7);
  for (int k = 0; k < 100; ++k) {
    std::vector<ModuleId> ids(255);
    std::iota(ids.begin(), ids.end(), 0);
    std::shuffle(ids.begin(), ids.end(), rng);
    std::map<ModuleId, ModuleId> to;
    for (const GraphModule& m : q.modules()) to[m.id] = ids[m.id];
    EXPECT_EQ(MorphologyKey(Relabel(q, to)), key);
  }
  std::vector<GraphEdge> edges = q.edges();
  edges[4].angle_steps = 0;  // knee 5 turned
  EXPECT_NE(MorphologyKey(ModuleGraph(4, q.modules(), edges)), key);
  edges = q.edges();
  edges[4].b_connector = L;  // knee 5 on the hip's left face
  EXPECT_NE(MorphologyKey(ModuleGraph(4, q.modules(), edges)), key);
  EXPECT_NE(MorphologyKey(Quadruped(false)), key);  // 4 driven
  EXPECT_NE(MorphologyKey(ModuleGraph(0, q.modules(), q.edges())), key);  // another central
}

// --- generated problems -----------------------------------------------------

std::vector<std::string> Params(const std::vector<FreeParameter>& free) {
  std::vector<std::string> out;
  for (const FreeParameter& p : free) out.push_back(p.param);
  return out;
}

TEST(ProblemTest, QuadrupedGetsATable61KindOfProblem) {
  const GeneratedProblem p = GenerateProblem(Quadruped(), nullptr);
  // Before the budget: one amplitude and offset for the hips, one for the
  // knees, the hip->knee phase and three free ring phases (the fourth closes
  // the ring); the budget of 7 fixes one offset.
  EXPECT_EQ(p.free.size(), 7u);
  ASSERT_EQ(p.fixed.size(), 1u);
  EXPECT_THAT(p.fixed[0].param, ::testing::AnyOf("offset.0", "offset.5"));
  EXPECT_EQ(p.fixed[0].value, 0.0);
  const auto names = Params(p.free);
  EXPECT_THAT(names, ::testing::IsSupersetOf({"amplitude.0", "amplitude.5", "phase.0.5"}));
  int ring = 0;
  for (const std::string& n : names) {
    ring += n == "phase.0.1" || n == "phase.0.3" || n == "phase.1.2" || n == "phase.2.3";
  }
  EXPECT_EQ(ring, 3);
  EXPECT_EQ(p.loops.size(), 1u);
  std::map<std::string, std::string> tied;
  for (const TiedParameter& t : p.tied) tied[t.param] = t.expr;
  EXPECT_EQ(tied["amplitude.2"], "amplitude.0()");
  EXPECT_EQ(tied["offset.7"], "offset.5()");
  EXPECT_EQ(tied["phase.2.7"], "phase.0.5()");
  EXPECT_EQ(tied["phase.5.0"], "-phase.0.5()");
  EXPECT_THAT(p.Explain(), HasSubstr("orbits: {0 1 2 3} {4} {5 6 7 8}"));
}

TEST(ProblemTest, BudgetRuleIsSeededAndSaysWhatItFixed) {
  ProblemOptions options{.max_free = 3};
  const GeneratedProblem a = GenerateProblem(Quadruped(), nullptr, options);
  const GeneratedProblem b = GenerateProblem(Quadruped(), nullptr, options);
  EXPECT_EQ(Params(a.free), Params(b.free));
  EXPECT_EQ(a.free.size(), 3u);
  // 8 candidates: both offsets are fixed, the two amplitudes tied into one,
  // then two of the four phases fixed.
  EXPECT_EQ(a.fixed.size(), 4u);
  EXPECT_THAT(Params(a.free), ElementsAre("amplitude.0", ::testing::StartsWith("phase."),
                                          ::testing::StartsWith("phase.")));
  EXPECT_THAT(a.Explain(), HasSubstr("ties the amplitudes of 0 1 2 3 5 6 7 8"));
  EXPECT_THAT(a.Explain(), HasSubstr("couplings 0-1 0-3 1-2 2-3 are symmetric but not tied"));
  EXPECT_THAT(a.OptimizationXml(), HasSubstr("fixed by the budget rule"));
  std::set<std::vector<std::string>> seen;
  for (uint64_t seed = 1; seed <= 20; ++seed) {
    options.seed = seed;
    seen.insert(Params(GenerateProblem(Quadruped(), nullptr, options).free));
  }
  EXPECT_GT(seen.size(), 1u);
}

TEST(ProblemTest, BadRequestsAreClearErrors) {
  auto message = [](const ModuleGraph& g, const ProblemOptions& o) {
    try {
      GenerateProblem(g, nullptr, o);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_THAT(message(Quadruped(), {.max_free = 0}), HasSubstr("at least 1, not 0"));
  EXPECT_THAT(message(Quadruped(), {.keep_free = {{0, 2}}}), HasSubstr("keep-free coupling 0-2"));
  EXPECT_THAT(message(Quadruped(), {.keep_free = {{0, 1}, {1, 2}, {2, 3}, {3, 0}}}),
              HasSubstr("close a loop"));
  const ModuleGraph passive(0, {{0, false}, {1, false}}, {{1, F, 0, R, 0}});
  EXPECT_THAT(message(passive, {}), HasSubstr("no driven module"));
}

TEST(ProblemTest, SingleModuleAndDetachedPieces) {
  const GeneratedProblem one = GenerateProblem(ModuleGraph(3, {{3}}, {}), nullptr);
  EXPECT_EQ(Params(one.free), (std::vector<std::string>{"amplitude.3", "offset.3"}));
  const ModuleGraph two_pieces(0, {{0}, {1}, {2}, {7}}, {{1, F, 0, R, 0}, {2, F, 1, R, 0}});
  const GeneratedProblem p = GenerateProblem(two_pieces, nullptr);
  EXPECT_THAT(p.network.ignored, ElementsAre(7));
  EXPECT_THAT(p.Explain(), HasSubstr("modules 7 are not connected to the largest piece"));
  EXPECT_EQ(p.robot.FindModule(7), nullptr);
}

TEST(ProblemTest, KeepFreeEdgesStayFree) {
  const GeneratedProblem p = GenerateProblem(Quadruped(), nullptr, {.max_free = 20, .keep_free = {{3, 0}}});
  EXPECT_THAT(Params(p.free), ::testing::Contains("phase.0.3"));
  for (const TiedParameter& t : p.tied) EXPECT_NE(t.param, "phase.0.3");
}

TEST(ProblemTest, WarmStartKeepsSurvivorsAndFillsNewcomers) {
  RobotConfig base;
  base.master_id = 4;
  base.modules = {{.id = 0, .amplitude = 0.3, .offset = 0.1, .speed = 0.4, .min_angle = -0.7, .max_angle = 0.7},
                  {.id = 4}, {.id = 5, .amplitude = 0.2, .offset = -0.3, .speed = 0.4}};
  base.couplings = {{0, 5, 1.0, 0.8}, {5, 0, -1.0, 0.8}};
  base.bluetooth_parent = {{0, 4}, {5, 0}};
  const GeneratedProblem p = GenerateProblem(Quadruped(), &base, {.max_free = 20});
  const ModuleParams* hip2 = p.robot.FindModule(2);
  ASSERT_NE(hip2, nullptr);
  EXPECT_EQ(hip2->amplitude, 0.3);   // the hip orbit's value
  EXPECT_EQ(hip2->max_angle, 0.7);   // and its limits
  EXPECT_EQ(hip2->speed, 0.4);
  EXPECT_EQ(p.robot.FindModule(8)->offset, -0.3);
  EXPECT_EQ(p.robot.FindCoupling(0, 5)->phase, 1.0);
  EXPECT_EQ(p.robot.FindCoupling(0, 5)->weight, 0.8);
  EXPECT_EQ(p.robot.master_id, 4);
  EXPECT_NO_THROW(Validate(p.robot));
}

TEST(PhaseSystemTest, FreePhasesAreTheSpanningTree) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 1000; ++trial) {
    const int n = 1 + static_cast<int>(rng() % 64);
    std::vector<ModuleId> vertices(n);
    std::iota(vertices.begin(), vertices.end(), 0);
    std::set<std::pair<int, int>> es;
    for (int v = 1; v < n; ++v) es.insert({static_cast<int>(rng() % v), v});
    const int extra = static_cast<int>(rng() % (n + 1));
    for (int k = 0; k < extra; ++k) {
      const int a = static_cast<int>(rng() % n), b = static_cast<int>(rng() % n);
      if (a != b) es.insert(std::minmax(a, b));
    }
    std::vector<NetworkEdge> edges;
    for (const auto& [a, b] : es) edges.push_back({a, b});
    const PhaseSystem s = BuildPhaseSystem(vertices, edges);
    ASSERT_EQ(static_cast<int>(s.free.size()), n - 1);
    EXPECT_EQ(s.loops.size(), edges.size() - (n - 1));
    EXPECT_EQ(s.tied.size(), 2 * edges.size() - s.free.size());
  }
}

}  // namespace
}  // namespace yamor::cpg
