// The relearning plan (adaptation.h) for the thesis's 7.5.1 transformation:
// the quadruped's learned gait (configs/lifelong/quadruped-walking.xml) on
// the body configs/scripts/quadruped-transform.xml leaves (knees 7 and 8 on
// the ends of legs 0 and 1). A rebuilt network imposes the new body's
// symmetry ties (the legs 0/1 and 2/3 mirror each other) and spends the
// whole budget; --base-ties-only keeps the current gait as the exact start.
#include "optimizer-plugins/lifelong/adaptation.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <numbers>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "cpg/config_xml.h"
#include "cpg/module_graph.h"
#include "optimizer-plugins/framework/optimization_config.h"
#include "physics/module_graph.h"
#include "physics/morphology.h"

namespace yamor::lifelong {
namespace {

const std::string kConfigs = std::string(YAMOR_SOURCE_DIR) + "/configs/";
constexpr double kPi = std::numbers::pi;

double AngleGap(double a, double b) { return std::abs(std::remainder(a - b, 2 * kPi)); }

// The quadruped after the 7.5.1 script (as World::CurrentMorphology reports
// it; tests/cpg/base_start_test.cc builds it the same way).
physics::Morphology TransformedQuadruped() {
  std::string xml = physics::Morphology::LoadFile(kConfigs + "worlds/quadruped.xml").ToXml();
  for (const auto& [from, to] :
       {std::pair{std::string("idfrom=\"7\" connfrom=\"front\" idto=\"2\" connto=\"rear\" angle=\"270\""),
                  std::string("idfrom=\"7\" connfrom=\"front\" idto=\"5\" connto=\"rear\" angle=\"0\"")},
        std::pair{std::string("idfrom=\"8\" connfrom=\"front\" idto=\"3\" connto=\"rear\" angle=\"270\""),
                  std::string("idfrom=\"8\" connfrom=\"front\" idto=\"6\" connto=\"rear\" angle=\"0\"")}}) {
    const size_t at = xml.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) xml.replace(at, from.size(), to);
  }
  return physics::Morphology::Parse(xml, "transformed.xml");
}

std::string ReadFile(const std::string& path) {
  std::ifstream in(path);
  EXPECT_TRUE(in.good()) << path;
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// The lifelong starting gait: its robot (the rules stay in the problem).
struct Fixture {
  std::string gait_xml;     // robot only
  std::string problem_xml;  // robot + the seven rules
  cpg::ModuleGraph graph;   // the transformed body, driven as the gait drives it
};

Fixture Transformed() {
  const std::string problem_path = kConfigs + "lifelong/quadruped-walking.xml";
  const optimizer::OptimizationConfig problem = optimizer::OptimizationConfig::LoadFile(problem_path);
  const cpg::RobotConfig gait = problem.robot();
  const physics::Morphology body = TransformedQuadruped();
  std::vector<int> ids;
  for (const auto& m : body.modules()) ids.push_back(m.id);
  std::set<int> driven;
  for (const auto& [id, active] : cpg::ActivityFromConfig(gait, ids)) {
    if (active) driven.insert(id);
  }
  cpg::ModuleGraph graph = WithKnownActivity(physics::ModuleGraphOf(body, cpg::ActivityFromConfig(gait, ids)),
                                             driven, {});
  return {cpg::WriteConfigXml(gait), ReadFile(problem_path), std::move(graph)};
}

cpg::RobotConfig Start(const AdaptationPlan& plan) {
  return cpg::ParseConfigXml(plan.start_config_xml, "start");
}

double Phase(const cpg::RobotConfig& c, int from, int to) {
  const cpg::Coupling* k = c.FindCoupling(from, to);
  EXPECT_NE(k, nullptr) << from << "->" << to;
  return k ? k->phase : NAN;
}

TEST(AdaptationTest, ARebuiltNetworkImposesTheNewBodysSymmetry) {
  const Fixture f = Transformed();
  const AdaptationPlan plan = PlanAdaptation(f.graph, f.gait_xml, f.problem_xml, /*body_changed=*/true, {});
  EXPECT_EQ(plan.how, "rebuilt");
  const cpg::RobotConfig start = Start(plan);
  // The mirror maps leg 0 onto leg 1 (hip servo reversed, knee not) and the
  // short legs 2 and 3 onto each other: the hip-knee lags differ by pi, the
  // lags 0->3 and 1->2 are one, and so are the knee-knee lags 5->7 and 6->8.
  // The old gait's hip-knee lags are equal (4.79 both), which the
  // base-faithful problem kept as two free parameters.
  EXPECT_LT(AngleGap(Phase(start, 1, 6), Phase(start, 0, 5) + kPi), 1e-9);
  EXPECT_LT(AngleGap(Phase(start, 1, 2), Phase(start, 0, 3)), 1e-9);
  EXPECT_LT(AngleGap(Phase(start, 6, 8), Phase(start, 5, 7)), 1e-9);
  // Every loop still closes: the hip ring sums to a multiple of 2 pi.
  const double ring = Phase(start, 0, 1) + Phase(start, 1, 2) + Phase(start, 2, 3) + Phase(start, 3, 0);
  EXPECT_LT(AngleGap(ring, 0), 1e-9);
  // The current gait is where it starts, as far as the ties allow: the hip
  // and knee amplitudes and the hip-knee lag of leg 0 are the old gait's.
  const cpg::RobotConfig gait = cpg::ParseConfigXml(f.gait_xml, "gait");
  for (int id : {0, 1, 2, 3, 5, 6, 7, 8}) {
    EXPECT_NEAR(start.FindModule(id)->amplitude, gait.FindModule(id)->amplitude, 1e-9) << id;
  }
  EXPECT_LT(AngleGap(Phase(start, 0, 5), Phase(gait, 0, 5)), 1e-9);
  // The whole budget is spent: tying the amplitudes freed a place for an
  // offset the first step of the budget rule had fixed.
  EXPECT_EQ(plan.free.size(), 7u);
  EXPECT_EQ(std::count_if(plan.free.begin(), plan.free.end(),
                          [](const std::string& p) { return p.rfind("offset.", 0) == 0; }),
            1);
  EXPECT_NE(plan.explanation.find("symmetry ties"), std::string::npos) << plan.explanation;
}

TEST(AdaptationTest, BaseTiesOnlyStartsExactlyAtTheCurrentGait) {
  const Fixture f = Transformed();
  AdaptationOptions options;
  options.impose_symmetry = false;
  const AdaptationPlan plan = PlanAdaptation(f.graph, f.gait_xml, f.problem_xml, true, options);
  const cpg::RobotConfig start = Start(plan);
  const cpg::RobotConfig gait = cpg::ParseConfigXml(f.gait_xml, "gait");
  // The lags the old gait has (and the new body keeps) are its own.
  EXPECT_LT(AngleGap(Phase(start, 0, 5), Phase(gait, 0, 5)), 1e-9);
  EXPECT_LT(AngleGap(Phase(start, 1, 6), Phase(gait, 1, 6)), 1e-9);
  EXPECT_LT(AngleGap(Phase(start, 1, 2), Phase(gait, 1, 2)), 1e-9);
  EXPECT_LT(AngleGap(Phase(start, 0, 1), Phase(gait, 0, 1)), 1e-9);
  EXPECT_EQ(plan.explanation.find("symmetry ties"), std::string::npos) << plan.explanation;
  EXPECT_LE(plan.free.size(), 7u);
}

TEST(AdaptationTest, AnUnchangedBodyWithoutRulesStartsAtItsGait) {
  // "generated": the body did not change, so its gait is not projected.
  const Fixture f = Transformed();
  const AdaptationPlan plan = PlanAdaptation(f.graph, f.gait_xml, "", /*body_changed=*/false, {});
  EXPECT_EQ(plan.how, "generated");
  const cpg::RobotConfig start = Start(plan);
  const cpg::RobotConfig gait = cpg::ParseConfigXml(f.gait_xml, "gait");
  EXPECT_LT(AngleGap(Phase(start, 1, 6), Phase(gait, 1, 6)), 1e-9);
  EXPECT_LT(AngleGap(Phase(start, 1, 2), Phase(gait, 1, 2)), 1e-9);
}

TEST(AdaptationTest, AnUnchangedBodyRelearnsTheSameParameters) {
  const Fixture f = Transformed();
  const AdaptationPlan plan = PlanAdaptation(f.graph, f.gait_xml, f.problem_xml, false, {});
  EXPECT_EQ(plan.how, "same parameters");
  EXPECT_EQ(plan.free, (std::vector<std::string>{"amplitude.0", "amplitude.5", "offset.5", "phase.0.5",
                                                 "phase.0.1", "phase.1.2", "phase.2.3"}));
}

}  // namespace
}  // namespace yamor::lifelong
