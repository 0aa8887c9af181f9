// The pso plugin through the real session: sphere and boundary optima,
// Rastrigin's global maximum in 2-D, one batch per iteration, budget,
// determinism.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "tests/optimizer-plugins/plugins/batch_recorder.h"

namespace yamor::optimizer::testing {
namespace {

class PsoTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { plugin_ = new LoadedPlugin(LoadBuiltPlugin("pso")); }
  static void TearDownTestSuite() {
    delete plugin_;
    plugin_ = nullptr;
  }
  static LoadedPlugin* plugin_;
};
LoadedPlugin* PsoTest::plugin_ = nullptr;

TEST_F(PsoTest, DeclaresItsFields) {
  std::vector<std::string> names;
  for (const FieldSpec& f : plugin_->fields()) names.push_back(f.name);
  for (const char* expected : {"max_evaluations", "swarm_size", "inertia", "cognitive", "social",
                               "max_velocity", "boundary", "include_start", "max_iterations"}) {
    EXPECT_NE(std::find(names.begin(), names.end(), expected), names.end()) << expected;
  }
  EXPECT_EQ(plugin_->name(), "pso");
}

TEST_F(PsoTest, FindsShiftedSphereMaximum) {
  const auto params = Box(-5, 5, {0, 0, 0});
  const PluginRun run = RunPlugin(*plugin_, params, Sphere({1.5, -2.0, 0.7}), {{"max_evaluations", "3000"}});
  ASSERT_EQ(run.result.status, "budget") << run.result.error;
  EXPECT_EQ(run.result.evaluations, 3000);
  EXPECT_GT(run.result.best_velocity, -1e-6);
  EXPECT_NEAR(run.result.best_point[0], 1.5, 1e-3);
  EXPECT_NEAR(run.result.best_point[1], -2.0, 1e-3);
  EXPECT_NEAR(run.result.best_point[2], 0.7, 1e-3);
  EXPECT_TRUE(AllInside(run.records, params));
}

TEST_F(PsoTest, ClampedParticlesReachTheBoundaryOptimumExactly) {
  // The sphere's centre (7, -9) lies outside the box: the maximum is the
  // corner (5, -5), value -(2² + 4²) = -20. Clamping is the default.
  const auto params = Box(-5, 5, {0, 0});
  for (std::uint64_t seed : {1, 2, 3}) {
    const PluginRun run = RunPlugin(*plugin_, params, Sphere({7, -9}), {{"max_evaluations", "1000"}}, seed);
    ASSERT_EQ(run.result.status, "budget") << run.result.error;
    EXPECT_EQ(run.result.best_point, (std::vector<double>{5.0, -5.0})) << "seed " << seed;
    EXPECT_EQ(run.result.best_velocity, -20.0);
    EXPECT_TRUE(AllInside(run.records, params));
  }
}

TEST_F(PsoTest, ReflectedParticlesApproachTheBoundaryOptimum) {
  const auto params = Box(-5, 5, {0, 0});
  const PluginRun run = RunPlugin(*plugin_, params, Sphere({7, -9}),
                                  {{"max_evaluations", "4000"}, {"boundary", "reflect"}});
  ASSERT_EQ(run.result.status, "budget") << run.result.error;
  EXPECT_NEAR(run.result.best_point[0], 5.0, 1e-4);
  EXPECT_NEAR(run.result.best_point[1], -5.0, 1e-4);
  EXPECT_TRUE(AllInside(run.records, params));
}

TEST_F(PsoTest, FindsRastriginGlobalMaximumIn2D) {
  // Start far from the origin, in a local maximum near (3, -3).
  const auto params = Box(-5.12, 5.12, {3.0, -3.0});
  for (std::uint64_t seed : {1, 2, 3, 4, 5}) {
    const PluginRun run = RunPlugin(*plugin_, params, NegRastrigin, {{"max_evaluations", "4000"}}, seed);
    ASSERT_NE(run.result.status, "failed") << run.result.error;
    EXPECT_GT(run.result.best_velocity, -1e-3) << "seed " << seed;
    EXPECT_NEAR(run.result.best_point[0], 0.0, 1e-2) << "seed " << seed;
    EXPECT_NEAR(run.result.best_point[1], 0.0, 1e-2) << "seed " << seed;
  }
}

TEST_F(PsoTest, EachIterationIsOneBatchOfTheSwarm) {
  SessionResult result;
  // 5 full iterations of 13, then the budget cuts the sixth to 4.
  const auto sizes = BatchSizes(*plugin_, Box(-1, 1, {0, 0, 0}), Sphere({0.2, 0.1, -0.3}),
                                {{"swarm_size", "13"}, {"max_evaluations", "69"}}, &result);
  EXPECT_EQ(sizes, (std::vector<std::size_t>{13, 13, 13, 13, 13, 4}));
  EXPECT_EQ(result.status, "budget");
  EXPECT_EQ(result.evaluations, 69);
}

TEST_F(PsoTest, MaxIterationsEndsTheRunAsConverged) {
  const PluginRun run = RunPlugin(*plugin_, Box(-1, 1, {0, 0}), Sphere({0.5, 0.5}),
                                  {{"swarm_size", "10"}, {"max_iterations", "3"}});
  EXPECT_EQ(run.result.status, "converged") << run.result.error;
  EXPECT_EQ(run.result.evaluations, 30);
}

TEST_F(PsoTest, FirstParticleIsTheStartUnlessDisabled) {
  const auto params = Box(-1, 1, {0.25, -0.75});
  const PluginRun with = RunPlugin(*plugin_, params, Sphere({0, 0}), {{"max_evaluations", "20"}});
  ASSERT_FALSE(with.records.empty());
  EXPECT_EQ(with.records[0].point, (std::vector<double>{0.25, -0.75}));
  const PluginRun without =
      RunPlugin(*plugin_, params, Sphere({0, 0}), {{"max_evaluations", "20"}, {"include_start", "false"}});
  ASSERT_FALSE(without.records.empty());
  EXPECT_NE(without.records[0].point, (std::vector<double>{0.25, -0.75}));
}

TEST_F(PsoTest, DeterministicForASeed) {
  const auto params = Box(-5.12, 5.12, {1, 1, 1});
  const std::map<std::string, std::string> set = {{"max_evaluations", "300"}};
  const PluginRun a = RunPlugin(*plugin_, params, NegRastrigin, set, 42);
  const PluginRun b = RunPlugin(*plugin_, params, NegRastrigin, set, 42);
  const PluginRun c = RunPlugin(*plugin_, params, NegRastrigin, set, 43);
  ASSERT_EQ(a.records.size(), 300u);
  EXPECT_TRUE(SameRecords(a.records, b.records));
  EXPECT_FALSE(SameRecords(a.records, c.records));
}

TEST_F(PsoTest, StaysInsideNarrowAndAsymmetricBounds) {
  std::vector<ProblemParameter> params = {{"a", 0.0, 1e-3, 1e-3}, {"b", -0.1, 0.3, 0.3}, {"c", 100, 1e4, 100}};
  const PluginRun run = RunPlugin(
      *plugin_, params, [](const std::vector<double>& x) { return x[0] - x[1] + x[2]; },
      {{"max_evaluations", "400"}, {"max_velocity", "1"}, {"inertia", "1.5"}, {"boundary", "reflect"}});
  ASSERT_EQ(run.result.status, "budget") << run.result.error;
  EXPECT_TRUE(AllInside(run.records, params));
}

}  // namespace
}  // namespace yamor::optimizer::testing
