// One test per rule of docs/cpg_build.md, each on the step that implements it
// (cpg/problem_steps.h, cpg/phase_system.h) and a small hand-made body or
// class set, so a broken rule names itself. The whole-problem tests are in
// graph_test.cc and base_start_test.cc; CpgGolden keeps every generated
// problem byte-identical.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <set>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "common/status.h"
#include "cpg/network_builder.h"
#include "cpg/phase_system.h"
#include "cpg/problem_steps.h"
#include "cpg/symmetry.h"

namespace yamor::cpg {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;
using ::testing::Pair;

constexpr double kPi = std::numbers::pi;
constexpr Connector F = Connector::kFront, R = Connector::kRear, L = Connector::kLeft, Ri = Connector::kRight,
                    T = Connector::kTop;

// configs/worlds/trebuchet.xml with arm 1 passive: legs 7 and 12 on the
// left and right of beam 10, mirror images with reversed servos.
ModuleGraph Trebuchet() {
  std::vector<GraphModule> modules = {{1, false}, {7, true}, {10, true}, {12, true}};
  std::vector<GraphEdge> edges = {{7, F, 10, L, 0}, {12, F, 10, Ri, 12}, {10, F, 1, R, 0}};
  return ModuleGraph(10, modules, edges);
}

// A ring 0-1-2-3 as edges (u < v).
std::vector<NetworkEdge> Ring() { return {{0, 1}, {0, 3}, {1, 2}, {2, 3}}; }

ModuleParams Module(ModuleId id, double amplitude, double offset, double min_angle = -1.57,
                    double max_angle = 1.57) {
  return {.id = id, .amplitude = amplitude, .offset = offset, .speed = 0.5, .min_angle = min_angle,
          .max_angle = max_angle};
}

std::vector<std::string> Names(const std::vector<FreeParameter>& params) {
  std::vector<std::string> out;
  for (const FreeParameter& p : params) out.push_back(p.param);
  return out;
}

// --- §2 Couplings of the base -------------------------------------------------

TEST(KeepBaseCouplingsTest, ABaseCouplingTheBodyDoesNotGiveStaysOut) {
  // 4 hangs off driven 3, which sits on passive 1 with 0: 0-4 runs through
  // the oscillator 3, not across passive modules only (the transformed
  // quadruped's stale 2-7); 9 is not in the body; 3-3 is no coupling.
  const ModuleGraph g(1, {{0}, {1, false}, {3}, {4}}, {{0, F, 1, L, 0}, {3, F, 1, T, 0}, {4, F, 3, R, 0}});
  CpgNetwork net = BuildNetwork(g);
  const std::vector<NetworkEdge> before = net.edges;
  RobotConfig base;
  base.couplings = {{0, 4, 0.5, 1.0}, {4, 0, -0.5, 1.0}, {0, 9, 1.0, 1.0}, {3, 3, 1.0, 1.0}};
  std::vector<std::string> notes;
  KeepBaseCouplings(g, base, net, notes);
  EXPECT_EQ(net.edges, before);
  EXPECT_THAT(notes, IsEmpty());
}

TEST(KeepBaseCouplingsTest, ACouplingOnlyTheBaseHasJoinsTheNetworkMarkedAndNamed) {
  // Driven 0 and 2 on adjacent faces of passive 1, and 3 on the face
  // opposite 0: the rule couples 0-2 and 2-3 (adjacent) but not 0-3
  // (opposite, already joined through 2); the base's 0-3 stays.
  const ModuleGraph g(1, {{0}, {1, false}, {2}, {3}},
                      {{0, F, 1, L, 0}, {2, F, 1, T, 0}, {3, F, 1, Ri, 0}});
  CpgNetwork net = BuildNetwork(g);
  ASSERT_EQ(net.FindEdge(0, 3), nullptr);
  RobotConfig base;
  base.couplings = {{3, 0, 2.0, 1.0}};
  std::vector<std::string> notes;
  KeepBaseCouplings(g, base, net, notes);
  const NetworkEdge* kept = net.FindEdge(0, 3);
  ASSERT_NE(kept, nullptr);
  EXPECT_TRUE(kept->from_base);
  EXPECT_FALSE(kept->physical);
  EXPECT_THAT(notes, ElementsAre(HasSubstr("coupling 0-3 is not one the construction rule gives")));
  EXPECT_TRUE(std::is_sorted(net.edges.begin(), net.edges.end(), [](const NetworkEdge& x, const NetworkEdge& y) {
    return std::pair{x.u, x.v} < std::pair{y.u, y.v};
  }));
}

// --- §4 Ties ----------------------------------------------------------------

TEST(SymmetryTiesTest, MirroredLegsShareAmplitudeOffsetBySignAndPhasePlusPi) {
  const ModuleGraph g = Trebuchet();
  const CpgNetwork net = BuildNetwork(g);
  ASSERT_THAT(net.oscillators, ElementsAre(7, 10, 12));
  ASSERT_EQ(net.edges.size(), 2u);  // 7-10, 10-12
  const ModuleGraph piece = g.Subgraph(net.piece);
  // The mirror across the beam, the one element gravity keeps on the real
  // trebuchet (the hand-made graph has no orientations to drop the others).
  std::vector<Symmetry> mirror;
  for (const Symmetry& s : FindSymmetries(piece).elements) {
    if (s.mirror && s.image[piece.IndexOf(7)] == piece.IndexOf(12) && s.ServoSign(piece.IndexOf(10)) > 0) {
      mirror.push_back(s);
    }
  }
  ASSERT_EQ(mirror.size(), 1u);
  std::vector<std::string> notes;
  const ParameterTies ties = SymmetryTies(piece, mirror, {7, 10, 12}, net, {}, notes);
  EXPECT_THAT(ties.amplitudes, ElementsAre(Pair(7, ElementsAre(7, 12)), Pair(10, ElementsAre(10))));
  // offset.12 = -offset.7: the mirror reverses the legs' servos.
  EXPECT_THAT(ties.offsets,
              ElementsAre(Pair(7, ElementsAre(Pair(7, 1), Pair(12, -1))), Pair(10, ElementsAre(Pair(10, 1)))));
  // 7 -> 10 maps onto 12 -> 10 = -(10 -> 12), plus π (one servo reversed).
  ASSERT_EQ(ties.phases.size(), 2u);
  std::vector<EdgeTie> phases = ties.phases;
  Normalise(phases);
  EXPECT_EQ(phases[0].cls, phases[1].cls);
  EXPECT_EQ(phases[1].sign, -1);
  EXPECT_EQ(phases[1].pi, 1);
  EXPECT_THAT(notes, IsEmpty());
}

TEST(SymmetryTiesTest, WhereAMirrorReversesAMovingModuleOntoItselfOffsetsFallBackToRotations) {
  // The whole group of the hand-made trebuchet: a mirror maps beam 10 onto
  // its own reverse, so the offsets are tied by the half turn about 10
  // alone (7 onto 12, servos kept); amplitudes still by every element.
  const ModuleGraph g = Trebuchet();
  const CpgNetwork net = BuildNetwork(g);
  const ModuleGraph piece = g.Subgraph(net.piece);
  std::vector<std::string> notes;
  const ParameterTies ties = SymmetryTies(piece, FindSymmetries(piece).elements, {7, 10, 12}, net, {}, notes);
  EXPECT_THAT(ties.amplitudes, ElementsAre(Pair(7, ElementsAre(7, 12)), Pair(10, ElementsAre(10))));
  EXPECT_THAT(ties.offsets,
              ElementsAre(Pair(7, ElementsAre(Pair(7, 1), Pair(12, 1))), Pair(10, ElementsAre(Pair(10, 1)))));
  EXPECT_THAT(notes, ElementsAre(HasSubstr("module(s) 7 12: a mirror maps one of them onto its own reverse"),
                                 HasSubstr("module(s) 10: a mirror maps one of them onto its own reverse")));
}

TEST(SymmetryTiesTest, NoSymmetryLeavesEveryParameterAlone) {
  const ModuleGraph g = Trebuchet();
  const CpgNetwork net = BuildNetwork(g);
  std::vector<std::string> notes;
  const ParameterTies ties = SymmetryTies(g.Subgraph(net.piece), {}, {7, 10, 12}, net, {}, notes);
  EXPECT_EQ(ties.amplitudes.size(), 3u);
  EXPECT_EQ(ties.offsets.size(), 3u);
  std::vector<EdgeTie> phases = ties.phases;
  Normalise(phases);
  EXPECT_NE(phases[0].cls, phases[1].cls);
}

TEST(SymmetryTiesTest, AKeepFreeCouplingIsTiedToNothing) {
  const ModuleGraph g = Trebuchet();
  const CpgNetwork net = BuildNetwork(g);
  const ModuleGraph piece = g.Subgraph(net.piece);
  std::vector<std::string> notes;
  const ParameterTies ties =
      SymmetryTies(piece, FindSymmetries(piece).elements, {7, 10, 12}, net, /*keep_free=*/{0}, notes);
  std::vector<EdgeTie> phases = ties.phases;
  Normalise(phases);
  EXPECT_NE(phases[0].cls, phases[1].cls);
}

// --- §6 rule 1: a tie the base contradicts is not imposed --------------------

TEST(SplitTiesTest, ClassesSplitIntoGroupsOfEqualBaseValuesAndTheUnconfiguredJoinTheFirst) {
  ParameterTies ties;
  ties.amplitudes = {{0, {0, 1, 2, 3}}};
  ties.offsets = {{0, {{0, 1}, {1, -1}, {2, 1}, {3, 1}}}};
  const std::vector<NetworkEdge> edges = {{0, 1}, {1, 2}, {2, 3}};
  // 1-2 = -(0-1) + π, 2-3 = 0-1.
  ties.phases = {{.cls = 0}, {.cls = 0, .sign = -1, .pi = 1}, {.cls = 0}};
  RobotConfig base;
  // 0 and 1 agree (offset 1 = -offset 0), 2 differs in both; 3 is new.
  base.modules = {Module(0, 0.5, 0.2), Module(1, 0.5, -0.2), Module(2, 0.7, 0.3)};
  // 0-1 = 1.0, 1-2 = -1.0 + π (agrees), 2-3 = 2.0 (differs).
  base.couplings = {{0, 1, 1.0, 1.0}, {1, 2, -1.0 + kPi, 1.0}, {2, 3, 2.0, 1.0}};
  std::vector<std::string> notes;
  SplitTiesTheBaseContradicts(ties, base, BasePhasesOf(base, edges), edges, notes);
  EXPECT_THAT(ties.amplitudes, ElementsAre(Pair(0, ElementsAre(0, 1, 3)), Pair(2, ElementsAre(2))));
  EXPECT_THAT(ties.offsets, ElementsAre(Pair(0, ElementsAre(Pair(0, 1), Pair(1, -1), Pair(3, 1))),
                                        Pair(2, ElementsAre(Pair(2, 1)))));
  EXPECT_EQ(ties.phases[0].cls, ties.phases[1].cls);
  EXPECT_NE(ties.phases[0].cls, ties.phases[2].cls);
  EXPECT_THAT(notes, ElementsAre(HasSubstr("module(s) 0 1 2 3 are symmetric but their base amplitudes differ"),
                                 HasSubstr("module(s) 0 1 2 3 are symmetric but their base offsets differ"),
                                 HasSubstr("couplings 0-1 1-2 2-3 are symmetric but their base phases differ")));
}

TEST(SplitTiesTest, ARepresentativeWithAReversedServoBecomesPositive) {
  // The group {1, 2} of an offset class whose members carry sign -1 gets
  // representative 1 with sign +1, 2 relative to it.
  ParameterTies ties;
  ties.offsets = {{0, {{0, 1}, {1, -1}, {2, -1}}}};
  RobotConfig base;
  base.modules = {Module(0, 0.5, 0.4), Module(1, 0.5, 0.1), Module(2, 0.5, 0.1)};
  std::vector<std::string> notes;
  SplitTiesTheBaseContradicts(ties, base, BasePhasesOf(base, {}), {}, notes);
  EXPECT_THAT(ties.offsets, ElementsAre(Pair(0, ElementsAre(Pair(0, 1))),
                                        Pair(1, ElementsAre(Pair(1, 1), Pair(2, 1)))));
}

TEST(SplitTiesTest, TiesTheBaseSatisfiesStay) {
  ParameterTies ties;
  ties.amplitudes = {{7, {7, 12}}};
  ties.offsets = {{7, {{7, 1}, {12, -1}}}};
  RobotConfig base;
  base.modules = {Module(7, 1.0, 0.8), Module(12, 1.0, -0.8)};  // the trebuchet's legs
  std::vector<std::string> notes;
  SplitTiesTheBaseContradicts(ties, base, BasePhasesOf(base, {}), {}, notes);
  EXPECT_THAT(ties.amplitudes, ElementsAre(Pair(7, ElementsAre(7, 12))));
  EXPECT_THAT(ties.offsets, ElementsAre(Pair(7, ElementsAre(Pair(7, 1), Pair(12, -1)))));
  EXPECT_THAT(notes, IsEmpty());
}

// --- §3 Loop constraints ---------------------------------------------------

TEST(SpanningTreeTest, ARingsClosingEdgeIsTheOneLeftOut) {
  const std::vector<bool> in_tree = SpanningTree({0, 1, 2, 3}, Ring(), {});
  EXPECT_THAT(in_tree, ElementsAre(true, false, true, true));  // 0-3 closes the ring
  const std::vector<Cycle> cycles = FundamentalCycles({0, 1, 2, 3}, Ring(), in_tree);
  ASSERT_EQ(cycles.size(), 1u);
  EXPECT_EQ(cycles[0].text, "0-3-2-1-0");
  // 0->3 forward, then 3->2, 2->1, 1->0 against their (small, large) order.
  EXPECT_THAT(cycles[0].terms, ElementsAre(Pair(1, 1), Pair(3, -1), Pair(2, -1), Pair(0, -1)));
}

TEST(SpanningTreeTest, KeepFreeEdgesGoFirstAndMayNotCloseALoop) {
  EXPECT_THAT(SpanningTree({0, 1, 2, 3}, Ring(), /*keep_free=*/{1}), ElementsAre(true, true, true, false));
  try {
    SpanningTree({0, 1, 2, 3}, Ring(), {0, 1, 2, 3});
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kInvalidArgument);
    EXPECT_THAT(e.what(), HasSubstr("close a loop"));
  }
}

TEST(SolvePhasesTest, ALoopConstrainsTheCouplingTheBaseDoesNotGive) {
  // A triangle: without a base the non-tree edge 0-2 is constrained; when
  // the base gives 0-2 and 0-1 but not 1-2, 1-2 is.
  const std::vector<NetworkEdge> edges = {{0, 1}, {0, 2}, {1, 2}};
  std::vector<EdgeTie> ties = {{.cls = 0}, {.cls = 1}, {.cls = 2}};
  EXPECT_THAT(SolvePhases({0, 1, 2}, edges, ties, {}).free_classes, ElementsAre(0, 2));
  const PhaseSolution base = SolvePhases({0, 1, 2}, edges, ties, {}, {true, true, false});
  EXPECT_THAT(base.free_classes, ElementsAre(0, 1));
  EXPECT_THAT(base.loops, ElementsAre("0-2-1-0"));
}

TEST(SolvePhasesTest, TiedCouplingsThatFormALoopAreSplitApart) {
  // Four equal lags round a ring would fix the lag to a multiple of π/2.
  const std::vector<EdgeTie> one_class(4, EdgeTie{.cls = 0});
  const PhaseSolution sol = SolvePhases({0, 1, 2, 3}, Ring(), one_class, {});
  EXPECT_EQ(sol.free_classes.size(), 3u);
  EXPECT_THAT(sol.untied, ElementsAre(HasSubstr("couplings 0-1 0-3 1-2 2-3 are symmetric but not tied")));
}

TEST(PhaseRulesTest, ALoopTheBaseGivesKeepsTheBasesSum) {
  // Back-links not opposite (the dog's 10->11 and 11->10): the rule keeps
  // their sum and a note says so.
  const std::vector<NetworkEdge> edges = {{0, 1}};
  const PhaseSolution sol = SolvePhases({0, 1}, edges, {EdgeTie{}}, {});
  BasePhases base{.forward = {1.0}, .backward = {-0.75}};
  std::vector<std::string> notes;
  const std::vector<TiedParameter> rules = PhaseRules(sol, edges, &base, &notes);
  ASSERT_EQ(rules.size(), 1u);
  EXPECT_EQ(rules[0].param, "phase.1.0");
  EXPECT_EQ(rules[0].expr, "M2Pi(phase.0.1() - 0.25)");
  EXPECT_THAT(notes, ElementsAre(HasSubstr("couplings 0-1 are not opposite")));
  EXPECT_EQ(PhaseRules(sol, edges)[0].expr, "-phase.0.1()");
}

// --- §6 Warm start ---------------------------------------------------------

TEST(WarmStartProblemTest, ANewModuleTakesItsOrbitsValuesMirroredAndANewCouplingItsClasssPhase) {
  const ModuleGraph g = Trebuchet();
  const CpgNetwork net = BuildNetwork(g);
  ParameterTies ties;
  ties.amplitudes = {{7, {7, 12}}, {10, {10}}};
  ties.offsets = {{7, {{7, 1}, {12, -1}}}, {10, {{10, 1}}}};
  ties.phases = {{.cls = 0}, {.cls = 0, .sign = -1, .pi = 1}};  // 10-12 = -(7-10) + π
  RobotConfig base;
  base.master_id = 10;
  base.modules = {Module(7, 1.0, 0.8, 1.0, 1.57), Module(10, 0.3, 0.0)};
  base.couplings = {{7, 10, -3.0, 1.0}, {10, 7, 3.0, 1.0}};
  const RobotConfig robot = WarmStartProblem(g, net, base, {7, 10, 12}, ties, {});
  const ModuleParams* leg = robot.FindModule(12);
  ASSERT_NE(leg, nullptr);
  EXPECT_EQ(leg->amplitude, 1.0);
  EXPECT_EQ(leg->offset, -0.8);
  EXPECT_EQ(leg->min_angle, -1.57);
  EXPECT_EQ(leg->max_angle, -1.0);
  // 10->12 = 3.0 + π, started in [0, 2π); 12->10 its negative.
  EXPECT_NEAR(robot.FindCoupling(10, 12)->phase, std::fmod(3.0 + kPi, 2 * kPi), 1e-12);
  EXPECT_NEAR(robot.FindCoupling(12, 10)->phase, 2 * kPi - std::fmod(3.0 + kPi, 2 * kPi), 1e-12);
  EXPECT_NEAR(robot.FindCoupling(7, 10)->phase, 2 * kPi - 3.0, 1e-12);  // the base's, in [0, 2π)
  EXPECT_EQ(*robot.FindModule(7), base.modules[0]);  // a survivor keeps the base's values, unclamped
}

TEST(StartTiedMembersTogetherTest, MembersStartAtTheBasesValueAndNewClassesAreClamped) {
  RobotConfig robot;
  // The warm start gave module 1 the base's values; 0 and 2 are new.
  robot.modules = {Module(0, 0.4, 0.7), Module(1, 0.9, -0.3), Module(2, 2.0, 2.0, -1.0, 1.0)};
  RobotConfig base;
  base.modules = {Module(1, 0.9, -0.3)};
  const BaseClasses classes = StartTiedMembersTogether(robot, {{0, {0, 1}}, {2, {2}}},
                                                       {{0, {{0, 1}, {1, -1}}}, {2, {{2, 1}}}}, base);
  EXPECT_EQ(robot.FindModule(0)->amplitude, 0.9);  // where the base puts the class
  EXPECT_EQ(robot.FindModule(0)->offset, 0.3);     // offset.0 = -offset.1
  EXPECT_EQ(robot.FindModule(2)->amplitude, 1.0);  // new: clamped to half the limit range
  EXPECT_EQ(robot.FindModule(2)->offset, 1.0);     // and into the limits
  EXPECT_THAT(classes.amplitudes, ElementsAre(0));
  EXPECT_THAT(classes.offsets, ElementsAre(0));
}

// --- §6 rule 3: a box holds the base value -----------------------------------

TEST(WidenBoxesToBaseTest, OnlyBoxesOfClassesTheBaseConfiguresWiden) {
  RobotConfig robot;
  robot.modules = {Module(7, 1.0, 0.8, 1.0, 1.57), Module(9, 1.0, 0.8, 1.0, 1.57)};
  Candidates free;
  free.amplitudes = {{"amplitude.7", 0, 0.285, ""}, {"amplitude.9", 0, 0.285, ""}};
  free.offsets = {{"offset.7", 1.0, 1.57, ""}, {"offset.9", 1.0, 1.57, ""}};
  WidenBoxesToBase(free, {.amplitudes = {7}, .offsets = {7}}, robot);
  EXPECT_EQ(free.amplitudes[0].max, 1.0);
  EXPECT_EQ(free.offsets[0].min, 0.8);
  EXPECT_EQ(free.offsets[0].max, 1.57);
  EXPECT_EQ(free.amplitudes[1].max, 0.285);
  EXPECT_EQ(free.offsets[1].min, 1.0);
}

// --- Candidates ----------------------------------------------------------------

TEST(MakeCandidatesTest, OnePerClassWithTheTightestAmplitudeBox) {
  const std::vector<NetworkEdge> edges = {{0, 1}};
  const PhaseSolution sol = SolvePhases({0, 1}, edges, {EdgeTie{}}, {});
  ParameterTies ties;
  ties.amplitudes = {{0, {0, 1}}};
  ties.offsets = {{0, {{0, 1}, {1, -1}}}};
  RobotConfig robot;
  robot.modules = {Module(0, 0.1, 0.0, -1.0, 1.0), Module(1, 0.1, 0.0, -0.5, 0.5)};
  const Candidates c = MakeCandidates(ties, sol, edges, robot);
  ASSERT_EQ(c.Total(), 3u);
  EXPECT_EQ(c.amplitudes[0].max, 0.5);  // module 1's limits are the tighter
  EXPECT_EQ(c.amplitudes[0].note, "amplitude of module(s) 0 1");
  EXPECT_EQ(c.offsets[0].min, -1.0);  // the representative's limits
  EXPECT_EQ(c.phases[0].param, "phase.0.1");
  EXPECT_EQ(c.phases[0].max, 2 * kPi);
}

// --- §4 Budget rule, step by step ----------------------------------------------

BudgetState State(size_t budget, int amplitudes, int offsets, int phases) {
  BudgetState s{.budget = budget};
  for (int i = 0; i < amplitudes; ++i) {
    s.free.amplitudes.push_back({"amplitude." + std::to_string(i), 0, 1, ""});
    s.amplitude_classes[i] = {i};
  }
  for (int i = 0; i < offsets; ++i) s.free.offsets.push_back({"offset." + std::to_string(i), -1, 1, ""});
  for (int i = 0; i < phases; ++i) s.free.phases.push_back({"phase.0." + std::to_string(i + 1), 0, 2 * kPi, ""});
  return s;
}

TEST(BudgetRuleTest, Step1FixesOffsetsFromTheBackOnlyWhileAboveTheBudget) {
  BudgetState s = State(4, 2, 3, 1);
  FixOffsets(s);
  EXPECT_THAT(Names(s.free.offsets), ElementsAre("offset.0"));
  EXPECT_THAT(s.fixed, ElementsAre("offset.2", "offset.1"));
  EXPECT_THAT(Names(s.fixed_offsets), ElementsAre("offset.2", "offset.1"));
  BudgetState within = State(6, 2, 3, 1);
  FixOffsets(within);
  EXPECT_THAT(within.fixed, IsEmpty());
}

TEST(BudgetRuleTest, Step2TiesAmplitudesWithTheSameKeyToTheSmallestIdWithTheTightestBox) {
  RobotConfig robot;
  robot.modules = {Module(0, 0.5, 0, -0.4, 0.4), Module(1, 0.5, 0, -0.8, 0.8), Module(2, 0.5, 0, -0.8, 0.8),
                   Module(3, 0.7, 0, -0.8, 0.8)};
  BudgetState s = State(1, 0, 0, 0);
  s.amplitude_classes = {{0, {0}}, {1, {1}}, {2, {2}}, {3, {3}}};
  s.free.amplitudes = {{"amplitude.0", 0, 0.4, ""}, {"amplitude.1", 0, 0.8, ""}, {"amplitude.2", 0, 0.8, ""},
                       {"amplitude.3", 0, 0.8, ""}};
  const auto limits = [](const ModuleParams& p) { return AmplitudeKey{p.min_angle, p.max_angle, p.amplitude}; };
  TieAmplitudes(s, robot, limits, "same limit angles");
  // 1 and 2 share limits and start amplitude; 3's start amplitude differs
  // (§6 rule 2), 0's limits differ. The candidates come in key order, which
  // decides what step 4 fixes first.
  EXPECT_THAT(s.amplitude_classes,
              ElementsAre(Pair(0, ElementsAre(0)), Pair(1, ElementsAre(1, 2)), Pair(3, ElementsAre(3))));
  EXPECT_THAT(Names(s.free.amplitudes), ElementsAre("amplitude.1", "amplitude.3", "amplitude.0"));
  EXPECT_THAT(s.notes, ElementsAre("the budget rule ties the amplitudes of 1 2 (same limit angles) to amplitude.1"));
  // 2b: every amplitude with the same start amplitude; the box the tightest.
  TieAmplitudes(s, robot, [](const ModuleParams& p) { return AmplitudeKey{0, 0, p.amplitude}; },
                "every driven module");
  EXPECT_THAT(s.amplitude_classes, ElementsAre(Pair(0, ElementsAre(0, 1, 2)), Pair(3, ElementsAre(3))));
  ASSERT_EQ(s.free.amplitudes.size(), 2u);
  EXPECT_EQ(s.free.amplitudes[0].max, 0.4);
  EXPECT_THAT(s.free.amplitudes[0].note, HasSubstr("(tied by the budget rule)"));
}

TEST(BudgetRuleTest, Step2IsANoOpWhenNoTwoClassesShareAKey) {
  RobotConfig robot;
  robot.modules = {Module(0, 0.5, 0), Module(1, 0.6, 0)};
  BudgetState s = State(1, 2, 0, 0);
  s.free.amplitudes[0].note = "kept";
  TieAmplitudes(s, robot, [](const ModuleParams& p) { return AmplitudeKey{0, 0, p.amplitude}; }, "x");
  EXPECT_EQ(s.free.amplitudes.size(), 2u);
  EXPECT_EQ(s.free.amplitudes[0].note, "kept");
  EXPECT_THAT(s.notes, IsEmpty());
}

TEST(BudgetRuleTest, Steps3And4FixPhasesThenAmplitudesFromTheBack) {
  BudgetState s = State(1, 2, 0, 2);
  FixPhases(s);
  EXPECT_THAT(s.fixed, ElementsAre("phase.0.2", "phase.0.1"));
  FixAmplitudes(s);
  EXPECT_THAT(s.fixed, ElementsAre("phase.0.2", "phase.0.1", "amplitude.1"));
  EXPECT_THAT(Names(s.free.amplitudes), ElementsAre("amplitude.0"));
}

TEST(BudgetRuleTest, Step5FreesTheLastFixedOffsetsFirstUpToTheBudget) {
  BudgetState s = State(3, 1, 0, 0);
  s.fixed = {"offset.2", "phase.0.1", "offset.1", "offset.0"};
  s.fixed_offsets = {{"offset.2", -1, 1, ""}, {"offset.1", -1, 1, ""}, {"offset.0", -1, 1, ""}};
  FreeFixedOffsets(s);
  EXPECT_THAT(Names(s.free.offsets), ElementsAre("offset.0", "offset.1"));
  EXPECT_THAT(s.fixed, ElementsAre("offset.2", "phase.0.1"));
  EXPECT_THAT(Names(s.fixed_offsets), ElementsAre("offset.2"));
}

TEST(BudgetRuleTest, AllStepsInOrder) {
  // 4 hip-like and 4 knee-like amplitudes, 2 offsets, 3 phases: 13 > 7.
  RobotConfig robot;
  for (int i = 0; i < 8; ++i) {
    robot.modules.push_back(Module(i, i < 4 ? 0.7 : 0.3, 0, i < 4 ? -0.78 : -1.57, i < 4 ? 0.78 : 1.57));
  }
  BudgetState s = State(7, 8, 2, 3);
  ApplyBudgetRule(s, robot, /*seed=*/1);
  // (1) both offsets fixed (13 -> 11), (2) the amplitudes tied to two (5),
  // (5) the budget has room for two: both offsets come back.
  EXPECT_THAT(Names(s.free.amplitudes), ElementsAre("amplitude.4", "amplitude.0"));  // key order
  EXPECT_EQ(s.free.offsets.size(), 2u);
  EXPECT_EQ(s.free.phases.size(), 3u);
  EXPECT_THAT(s.fixed, IsEmpty());
  EXPECT_EQ(s.free.Total(), 7u);
  // A budget of 1: every offset, then both phases and all but one amplitude.
  BudgetState tight = State(1, 8, 2, 3);
  ApplyBudgetRule(tight, robot, /*seed=*/1);
  EXPECT_EQ(tight.free.Total(), 1u);
  EXPECT_THAT(Names(tight.free.amplitudes), ElementsAre("amplitude.4"));
  EXPECT_EQ(tight.fixed.size(), 2u + 3u + 1u);
}

TEST(BudgetRuleTest, TheSeedOnlyChoosesWhatToFix) {
  RobotConfig robot;
  for (int i = 0; i < 2; ++i) robot.modules.push_back(Module(i, 0.5, 0));
  std::set<std::vector<std::string>> fixed;
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    BudgetState s = State(3, 2, 0, 6);
    ApplyBudgetRule(s, robot, seed);
    EXPECT_EQ(s.free.Total(), 3u);
    fixed.insert(s.fixed);
    BudgetState again = State(3, 2, 0, 6);
    ApplyBudgetRule(again, robot, seed);
    EXPECT_EQ(again.fixed, s.fixed) << "seed " << seed;
  }
  EXPECT_GT(fixed.size(), 1u);
}

}  // namespace
}  // namespace yamor::cpg
