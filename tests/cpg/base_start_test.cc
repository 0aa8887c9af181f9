// The base configuration is the start point of a generated problem
// (docs/cpg_build.md, "The base is the start point"): loaded with the
// optimization config loader, the generated problem's start values, with its
// ties and loop rules applied, give back the configured gait of every world
// of configs/worlds/ and of the transformed quadruped of thesis 7.5.1, so
// learning on it can only improve on that gait.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "cpg/config_xml.h"
#include "cpg/problem.h"
#include "optimizer-plugins/framework/optimization_config.h"
#include "physics/module_graph.h"
#include "physics/morphology.h"

namespace yamor::cpg {
namespace {

const std::string kConfigs = std::string(YAMOR_SOURCE_DIR) + "/configs/";

// |a - b| on the circle.
double AngleGap(double a, double b) { return std::abs(std::remainder(a - b, 2 * std::numbers::pi)); }

GeneratedProblem Generate(const physics::Morphology& body, const RobotConfig& base,
                          const ProblemOptions& options = {}) {
  std::vector<int> ids;
  for (const auto& m : body.modules()) ids.push_back(m.id);
  return GenerateProblem(physics::ModuleGraphOf(body, ActivityFromConfig(base, ids)), &base, options);
}

// The robot the optimizer evaluates first: the start values, clamped into
// their boxes as the loader does, with every rule applied.
RobotConfig StartRobot(const GeneratedProblem& p) {
  const optimizer::OptimizationConfig config = optimizer::OptimizationConfig::Parse(p.OptimizationXml(), "auto");
  return config.Apply(config.StartValues());
}

// Every module of the network and every coupling of `base` that the network
// has starts at the base's value; `all_couplings` also requires every base
// coupling to be one of the network's.
void ExpectStartIsBase(const GeneratedProblem& p, const RobotConfig& base, bool all_couplings) {
  const RobotConfig start = StartRobot(p);
  for (ModuleId id : p.network.oscillators) {
    const ModuleParams* b = base.FindModule(id);
    const ModuleParams* s = start.FindModule(id);
    ASSERT_NE(b, nullptr) << id;
    ASSERT_NE(s, nullptr) << id;
    EXPECT_NEAR(s->amplitude, b->amplitude, 1e-9) << "amplitude." << id;
    EXPECT_NEAR(s->offset, b->offset, 1e-9) << "offset." << id;
    EXPECT_EQ(s->speed, b->speed) << "speed." << id;
    EXPECT_EQ(s->min_angle, b->min_angle) << "minangle." << id;
    EXPECT_EQ(s->max_angle, b->max_angle) << "maxangle." << id;
  }
  for (const Coupling& c : base.couplings) {
    const Coupling* s = start.FindCoupling(c.from, c.to);
    if (s == nullptr) {
      EXPECT_FALSE(all_couplings) << "coupling " << c.from << "->" << c.to << " is not in the network";
      continue;
    }
    EXPECT_LT(AngleGap(s->phase, c.phase), 1e-9) << "phase." << c.from << "." << c.to << ": " << s->phase
                                                 << " against " << c.phase;
    EXPECT_EQ(s->weight, c.weight) << "weight." << c.from << "." << c.to;
  }
}

std::vector<std::string> Worlds() {
  std::vector<std::string> worlds;
  for (const auto& entry : std::filesystem::directory_iterator(kConfigs + "worlds")) {
    const std::string name = entry.path().stem().string();
    if (std::filesystem::exists(kConfigs + "robots/" + name + ".xml")) worlds.push_back(name);
  }
  return worlds;
}

TEST(BaseStartTest, EveryWorldStartsAtItsConfiguredGait) {
  const std::vector<std::string> worlds = Worlds();
  ASSERT_GE(worlds.size(), 6u);
  for (const std::string& world : worlds) {
    SCOPED_TRACE(world);
    const RobotConfig base = LoadConfigFile(kConfigs + "robots/" + world + ".xml");
    const GeneratedProblem p = Generate(physics::Morphology::LoadFile(kConfigs + "worlds/" + world + ".xml"), base);
    EXPECT_LE(p.free.size(), 7u);
    ExpectStartIsBase(p, base, /*all_couplings=*/true);
  }
}

TEST(BaseStartTest, HoldsForEveryBudgetAndSeed) {
  // The budget rule fixes or ties only what keeps the base a point.
  for (const std::string& world : Worlds()) {
    const RobotConfig base = LoadConfigFile(kConfigs + "robots/" + world + ".xml");
    const physics::Morphology body = physics::Morphology::LoadFile(kConfigs + "worlds/" + world + ".xml");
    for (int budget : {1, 2, 3, 5}) {
      for (uint64_t seed : {1u, 2u, 7u}) {
        SCOPED_TRACE(world + ", budget " + std::to_string(budget) + ", seed " + std::to_string(seed));
        const GeneratedProblem p = Generate(body, base, {.max_free = budget, .seed = seed});
        EXPECT_LE(p.free.size(), static_cast<size_t>(budget));
        ExpectStartIsBase(p, base, /*all_couplings=*/true);
      }
    }
  }
}

TEST(BaseStartTest, TransformedQuadrupedStartsAtTheQuadrupedsGait) {
  // Thesis 7.5.1: the knees of legs 2 and 3 move to the ends of legs 0 and 1
  // (configs/scripts/quadruped-transform.xml; the body World::CurrentMorphology
  // reports after the script, tests/physics/reconfiguration_test.cc).
  std::string xml;
  {
    const physics::Morphology q = physics::Morphology::LoadFile(kConfigs + "worlds/quadruped.xml");
    xml = q.ToXml();
  }
  for (const auto& [old_link, new_link] :
       {std::pair{std::string("idfrom=\"7\" connfrom=\"front\" idto=\"2\" connto=\"rear\" angle=\"270\""),
                  std::string("idfrom=\"7\" connfrom=\"front\" idto=\"5\" connto=\"rear\" angle=\"0\"")},
        std::pair{std::string("idfrom=\"8\" connfrom=\"front\" idto=\"3\" connto=\"rear\" angle=\"270\""),
                  std::string("idfrom=\"8\" connfrom=\"front\" idto=\"6\" connto=\"rear\" angle=\"0\"")}}) {
    const size_t at = xml.find(old_link);
    ASSERT_NE(at, std::string::npos) << old_link << " in\n" << xml;
    xml.replace(at, old_link.size(), new_link);
  }
  const RobotConfig base = LoadConfigFile(kConfigs + "robots/quadruped.xml");
  const GeneratedProblem p = Generate(physics::Morphology::Parse(xml, "transformed.xml"), base);
  // The body no longer connects 2 with 7 or 3 with 8: those couplings leave
  // the network (it follows the body), the knee-knee couplings 5-7 and 6-8
  // come in; every module and every surviving coupling keeps the quadruped's
  // values.
  EXPECT_EQ(p.network.FindEdge(2, 7), nullptr);
  EXPECT_EQ(p.network.FindEdge(3, 8), nullptr);
  EXPECT_NE(p.network.FindEdge(5, 7), nullptr);
  ExpectStartIsBase(p, base, /*all_couplings=*/false);
}

TEST(BaseStartTest, ABaseCouplingAcrossPassiveModulesIsKept) {
  // The tripod's hips 1 and 2 sit on opposite faces of the passive module 0;
  // the construction rule couples them only through 3, the base couples them
  // directly, so the network keeps 1-2.
  const RobotConfig base = LoadConfigFile(kConfigs + "robots/tripod.xml");
  const physics::Morphology body = physics::Morphology::LoadFile(kConfigs + "worlds/tripod.xml");
  ASSERT_NE(base.FindCoupling(1, 2), nullptr);
  const GeneratedProblem p = Generate(body, base);
  const NetworkEdge* kept = p.network.FindEdge(1, 2);
  ASSERT_NE(kept, nullptr);
  EXPECT_TRUE(kept->from_base);
  std::vector<int> ids;
  for (const auto& m : body.modules()) ids.push_back(m.id);
  EXPECT_EQ(GenerateProblem(physics::ModuleGraphOf(body, ActivityFromConfig(base, ids)), nullptr)
                .network.FindEdge(1, 2),
            nullptr);
}

TEST(BaseStartTest, ATieTheBaseContradictsIsNotImposedAndOneItKeepsIs) {
  // The trebuchet's legs 7 and 12 mirror each other: the base keeps their
  // amplitude and mirrored offset ties, but its leg couplings (7-10 at −3,
  // 10-12 at 0) are not the mirror's (a lag of π between them).
  const RobotConfig base = LoadConfigFile(kConfigs + "robots/trebuchet.xml");
  const physics::Morphology body = physics::Morphology::LoadFile(kConfigs + "worlds/trebuchet.xml");
  const GeneratedProblem p = Generate(body, base);
  std::vector<std::string> free, tied;
  for (const FreeParameter& f : p.free) free.push_back(f.param);
  for (const TiedParameter& t : p.tied) tied.push_back(t.param + " = " + t.expr);
  EXPECT_THAT(free, ::testing::UnorderedElementsAre("amplitude.7", "amplitude.10", "offset.7", "offset.10",
                                                    "phase.7.10", "phase.10.12"));
  EXPECT_THAT(tied, ::testing::IsSupersetOf({"amplitude.12 = amplitude.7()", "offset.12 = -offset.7()"}));
  // The legs' amplitude box widens to hold the base's 1 rad (the limit angles
  // alone give 0.285), and the offset box its 0.8 rad.
  for (const FreeParameter& f : p.free) {
    if (f.param == "amplitude.7") {
      EXPECT_EQ(f.max, 1.0);
    } else if (f.param == "offset.7") {
      EXPECT_EQ(f.min, 0.8);
    }
  }
  // Phases that do satisfy the mirror tie keep it.
  RobotConfig mirrored = base;
  for (Coupling& c : mirrored.couplings) {
    if (c.from == 10 && c.to == 12) c.phase = 3.0 - std::numbers::pi;
    if (c.from == 12 && c.to == 10) c.phase = std::numbers::pi - 3.0;
  }
  const GeneratedProblem q = Generate(body, mirrored);
  EXPECT_EQ(q.free.size(), 5u);
  ExpectStartIsBase(q, mirrored, /*all_couplings=*/true);
  // Without a base every symmetry ties, as before.
  std::vector<int> ids;
  for (const auto& m : body.modules()) ids.push_back(m.id);
  const GeneratedProblem none =
      GenerateProblem(physics::ModuleGraphOf(body, ActivityFromConfig(base, ids)), nullptr);
  EXPECT_EQ(none.free.size(), 5u);
}

TEST(BaseStartTest, ABaseWhoseBackLinksAreNotOppositeKeepsTheirSum) {
  // The dog's configured couplings 10 -> 11 and 11 -> 10 do not sum to a
  // multiple of 2π; the rule keeps their sum and says so.
  const RobotConfig base = LoadConfigFile(kConfigs + "robots/dog.xml");
  const GeneratedProblem p = Generate(physics::Morphology::LoadFile(kConfigs + "worlds/dog.xml"), base);
  const Coupling* forward = base.FindCoupling(10, 11);
  const Coupling* back = base.FindCoupling(11, 10);
  ASSERT_NE(forward, nullptr);
  ASSERT_NE(back, nullptr);
  ASSERT_GT(AngleGap(forward->phase + back->phase, 0), 1e-3);
  EXPECT_THAT(p.notes, ::testing::Contains(::testing::HasSubstr("couplings 10-11 are not opposite")));
  // Any point of the problem keeps that sum.
  const optimizer::OptimizationConfig config = optimizer::OptimizationConfig::Parse(p.OptimizationXml(), "dog");
  std::vector<double> x;
  for (const optimizer::OptimizeRule& r : config.optimized()) x.push_back(0.25 * r.min + 0.75 * r.max);
  const RobotConfig moved = config.Apply(x);
  EXPECT_LT(AngleGap(moved.FindCoupling(10, 11)->phase + moved.FindCoupling(11, 10)->phase,
                     forward->phase + back->phase),
            1e-9);
}

TEST(BaseStartTest, ImposeSymmetryTiesWhatTheBaseContradicts) {
  // The trebuchet's leg couplings break the mirror tie (above); with
  // impose_symmetry the tie holds anyway, with the base's first coupling as
  // the class's start: 10->12 starts at -(7->10) + pi, not at the base's 0.
  const RobotConfig base = LoadConfigFile(kConfigs + "robots/trebuchet.xml");
  const physics::Morphology body = physics::Morphology::LoadFile(kConfigs + "worlds/trebuchet.xml");
  ProblemOptions options;
  options.impose_symmetry = true;
  const GeneratedProblem p = Generate(body, base, options);
  std::vector<std::string> free;
  for (const FreeParameter& f : p.free) free.push_back(f.param);
  EXPECT_THAT(free, ::testing::Not(::testing::Contains("phase.10.12")));
  EXPECT_EQ(p.free.size(), 5u);
  const RobotConfig start = StartRobot(p);
  EXPECT_LT(AngleGap(start.FindCoupling(10, 12)->phase, -start.FindCoupling(7, 10)->phase + std::numbers::pi),
            1e-9);
  EXPECT_LT(AngleGap(start.FindCoupling(7, 10)->phase, base.FindCoupling(7, 10)->phase), 1e-9);
  EXPECT_GT(AngleGap(start.FindCoupling(10, 12)->phase, base.FindCoupling(10, 12)->phase), 0.1);
  // A base that satisfies every tie and closes every loop (no note about the
  // base) is still the start point.
  for (const std::string& world : Worlds()) {
    SCOPED_TRACE(world);
    const RobotConfig own = LoadConfigFile(kConfigs + "robots/" + world + ".xml");
    const physics::Morphology w = physics::Morphology::LoadFile(kConfigs + "worlds/" + world + ".xml");
    const GeneratedProblem faithful = Generate(w, own);
    if (std::none_of(faithful.notes.begin(), faithful.notes.end(),
                     [](const std::string& n) { return n.find("base") != std::string::npos; })) {
      ExpectStartIsBase(Generate(w, own, options), own, /*all_couplings=*/true);
    }
  }
}

TEST(BaseStartTest, NoOffsetStaysFixedWhileTheBudgetHasRoom) {
  // Step 1 of the budget rule fixes offsets before step 2 ties amplitudes;
  // what step 2 frees goes back to offsets (the transformed quadruped had 6
  // free parameters with four offsets fixed).
  for (const std::string& world : Worlds()) {
    const RobotConfig base = LoadConfigFile(kConfigs + "robots/" + world + ".xml");
    const physics::Morphology body = physics::Morphology::LoadFile(kConfigs + "worlds/" + world + ".xml");
    for (int budget : {1, 2, 3, 5, 7}) {
      for (uint64_t seed : {1u, 2u, 7u}) {
        for (bool impose : {false, true}) {
          SCOPED_TRACE(world + ", budget " + std::to_string(budget) + ", seed " + std::to_string(seed) +
                       (impose ? ", imposed" : ""));
          ProblemOptions options{.max_free = budget, .seed = seed};
          options.impose_symmetry = impose;
          const GeneratedProblem p = Generate(body, base, options);
          EXPECT_LE(p.free.size(), static_cast<size_t>(budget));
          const bool offset_fixed = std::any_of(p.fixed.begin(), p.fixed.end(), [](const FixedParameter& f) {
            return f.param.rfind("offset.", 0) == 0;
          });
          if (offset_fixed) {
            EXPECT_EQ(p.free.size(), static_cast<size_t>(budget));
          }
        }
      }
    }
  }
}

}  // namespace
}  // namespace yamor::cpg
