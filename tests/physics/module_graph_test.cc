// physics::ModuleGraphOf on the robots of configs/worlds: the morphology key
// is the body's, not its ids'; the symmetry groups and orbits are the ones
// derived by hand in docs/cpg_build.md.
#include <algorithm>
#include <map>
#include <numeric>
#include <random>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "cpg/config_xml.h"
#include "cpg/symmetry.h"
#include "physics/module_graph.h"
#include "physics/morphology.h"

namespace yamor::physics {
namespace {

using ::testing::ElementsAre;

const std::string kConfigs = std::string(YAMOR_SOURCE_DIR) + "/configs/";

cpg::ModuleGraph GraphOf(const Morphology& morphology, const std::string& name) {
  const cpg::RobotConfig config = cpg::LoadConfigFile(kConfigs + "robots/" + name + ".xml");
  std::vector<int> ids;
  for (const MorphologyModule& m : morphology.modules()) ids.push_back(m.id);
  return ModuleGraphOf(morphology, cpg::ActivityFromConfig(config, ids));
}

// The same robot with module ids renumbered by `to`.
Morphology Renumbered(const Morphology& m, const std::map<int, int>& to) {
  std::vector<MorphologyModule> modules = m.modules();
  for (MorphologyModule& x : modules) x.id = to.at(x.id);
  std::vector<MorphologyConnection> connections = m.connections();
  for (MorphologyConnection& c : connections) {
    c.from = to.at(c.from);
    c.to = to.at(c.to);
  }
  return Morphology::Build(to.at(m.central()), modules, connections, m.orientation_degrees());
}

class WorldGraphTest : public ::testing::TestWithParam<std::string> {};

TEST_P(WorldGraphTest, KeyIsTheSameUnderRenumbering) {
  const Morphology m = Morphology::LoadFile(kConfigs + "worlds/" + GetParam() + ".xml");
  const std::string key = cpg::MorphologyKey(ModuleGraphOf(m));
  std::mt19937 rng(42);
  for (int k = 0; k < 100; ++k) {
    std::vector<int> ids(255);
    std::iota(ids.begin(), ids.end(), 0);
    std::shuffle(ids.begin(), ids.end(), rng);
    std::map<int, int> to;
    for (const MorphologyModule& x : m.modules()) to[x.id] = ids[x.id];
    ASSERT_EQ(cpg::MorphologyKey(ModuleGraphOf(Renumbered(m, to))), key) << "relabelling " << k;
  }
  // A turned connection or another connector is another body.
  const cpg::ModuleGraph g = ModuleGraphOf(m);
  std::vector<cpg::GraphEdge> edges = g.edges();
  edges.back().angle_steps = (edges.back().angle_steps + 6) % 24;
  EXPECT_NE(cpg::MorphologyKey(cpg::ModuleGraph(g.central(), g.modules(), edges)), key);
  edges = g.edges();
  edges.back().b_connector = edges.back().b_connector == cpg::Connector::kBottom ? cpg::Connector::kTop
                                                                                 : cpg::Connector::kBottom;
  EXPECT_NE(cpg::MorphologyKey(cpg::ModuleGraph(g.central(), g.modules(), edges)), key);
}

INSTANTIATE_TEST_SUITE_P(Worlds, WorldGraphTest,
                         ::testing::Values("quadruped", "snake", "tripod", "dog", "trebuchet", "wheel"));

struct Expected {
  std::string world;
  double full_order;
  int dropped_for_gravity;
  std::vector<std::vector<int>> orbits;
};

TEST(WorldSymmetryTest, GroupsAndOrbitsAreTheHandDerivedOnes) {
  const std::vector<Expected> expected = {
      // The cross turns by quarter turns about the upright body 4, and
      // mirrors in the four vertical planes through it: D4.
      {"quadruped", 8, 0, {{0, 1, 2, 3}, {4}, {5, 6, 7, 8}}},
      // A half turn about the chain's axis (upside down), the left-right
      // mirror, and both: only the mirror keeps the snake on the ground,
      // and it maps every module onto itself.
      {"snake", 4, 2, {{0}, {1}, {2}, {3}, {4}, {5}, {6}, {7}, {8}}},
      // Legs 1 and 2 on 0's left and right are mirror images; the half turn
      // about 0's axis that also swaps them turns the robot over.
      {"tripod", 4, 2, {{0}, {1, 2}, {3}, {4, 5}, {6}}},
      // Every module lies in the dog's plane of symmetry.
      {"dog", 2, 0, {{1}, {5}, {10}, {11}, {12}}},
      // Legs 7 and 12 mirror each other in the plane across the beam 10.
      {"trebuchet", 4, 2, {{1}, {7, 12}, {10}}},
      // The hexagon's turns about its axle and its flips roll or turn the
      // wheel: all but the mirror in its own plane leave the ground.
      {"wheel", 12, 10, {{1}, {2}, {3}, {6}, {7}, {12}}},
  };
  for (const Expected& e : expected) {
    SCOPED_TRACE(e.world);
    const Morphology m = Morphology::LoadFile(kConfigs + "worlds/" + e.world + ".xml");
    const cpg::SymmetryGroup group = cpg::FindSymmetries(GraphOf(m, e.world));
    EXPECT_EQ(group.full_order, e.full_order);
    EXPECT_EQ(group.dropped_for_gravity, e.dropped_for_gravity);
    EXPECT_EQ(group.orbits, e.orbits);
    for (const cpg::Symmetry& s : group.elements) EXPECT_TRUE(cpg::IsSymmetry(GraphOf(m, e.world), s));
  }
}

TEST(WorldSymmetryTest, GraphCarriesPassiveFlagsAndLeavesSparesOut) {
  const Morphology m = Morphology::LoadFile(kConfigs + "worlds/quadruped.xml");
  const cpg::ModuleGraph g = GraphOf(m, "quadruped");
  EXPECT_FALSE(g.Module(4).active);
  EXPECT_TRUE(g.Module(0).active);
  EXPECT_TRUE(g.has_geometry());
  EXPECT_EQ(g.edges().size(), 8u);
  const Morphology spare = Morphology::Parse(
      R"(<morphology central="0"><module id="0"/><module id="1"/><module id="2" free="true"/>
         <connect idfrom="1" connfrom="front" idto="0" connto="rear"/></morphology>)",
      "<test>");
  const cpg::ModuleGraph sg = ModuleGraphOf(spare, {{1, false}, {1, true}});
  EXPECT_FALSE(sg.Contains(2));
  EXPECT_TRUE(sg.Module(1).active);  // the last entry wins
}

}  // namespace
}  // namespace yamor::physics
