// The cmaes plugin through the real session: sphere, Rosenbrock and boundary
// optima, Rastrigin's global maximum in 2-D with IPOP restarts, one batch of
// lambda per generation, tolerances, budget, determinism.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "tests/optimizer-plugins/plugins/batch_recorder.h"

namespace yamor::optimizer::testing {
namespace {

class CmaesTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { plugin_ = new LoadedPlugin(LoadBuiltPlugin("cmaes")); }
  static void TearDownTestSuite() {
    delete plugin_;
    plugin_ = nullptr;
  }
  static LoadedPlugin* plugin_;
};
LoadedPlugin* CmaesTest::plugin_ = nullptr;

TEST_F(CmaesTest, DeclaresItsFields) {
  std::vector<std::string> names;
  for (const FieldSpec& f : plugin_->fields()) names.push_back(f.name);
  for (const char* expected : {"max_evaluations", "sigma", "population", "xtol", "ftol", "restarts",
                               "random_start"}) {
    EXPECT_NE(std::find(names.begin(), names.end(), expected), names.end()) << expected;
  }
}

TEST_F(CmaesTest, ConvergesOnShiftedSphereBeforeTheBudget) {
  const auto params = Box(-5, 5, {0, 0, 0, 0});
  const PluginRun run =
      RunPlugin(*plugin_, params, Sphere({1.5, -2.0, 0.7, -4.2}), {{"max_evaluations", "5000"}});
  ASSERT_EQ(run.result.status, "converged") << run.result.error;
  EXPECT_LT(run.result.evaluations, 5000);
  EXPECT_GT(run.result.best_velocity, -1e-9);
  EXPECT_NEAR(run.result.best_point[3], -4.2, 1e-4);
  EXPECT_TRUE(AllInside(run.records, params));
}

TEST_F(CmaesTest, WorksInOneDimension) {
  SessionResult result;
  const auto sizes = BatchSizes(*plugin_, Box(0, 10, {9}), Sphere({2.5}), {{"max_evaluations", "2000"}}, &result);
  ASSERT_EQ(result.status, "converged") << result.error;
  EXPECT_EQ(sizes.front(), 4u);  // 4 + floor(3 ln 1)
  EXPECT_NEAR(result.best_point[0], 2.5, 1e-5);
}

TEST_F(CmaesTest, FindsRosenbrockMaximum) {
  const auto params = Box(-2, 2, {-1.2, 1.0});
  const PluginRun run = RunPlugin(*plugin_, params, NegRosenbrock, {{"max_evaluations", "3000"}});
  ASSERT_NE(run.result.status, "failed") << run.result.error;
  EXPECT_GT(run.result.best_velocity, -1e-8);
  EXPECT_NEAR(run.result.best_point[0], 1.0, 1e-3);
  EXPECT_NEAR(run.result.best_point[1], 1.0, 1e-3);
}

TEST_F(CmaesTest, FindsOptimumOnTheBoundary) {
  // Maximum at the corner (5, -5) of the box, and one coordinate interior.
  const auto params = Box(-5, 5, {0, 0, 0});
  const PluginRun run = RunPlugin(*plugin_, params, Sphere({7, -9, 1}), {{"max_evaluations", "2000"}});
  ASSERT_NE(run.result.status, "failed") << run.result.error;
  EXPECT_NEAR(run.result.best_point[0], 5.0, 1e-6);
  EXPECT_NEAR(run.result.best_point[1], -5.0, 1e-6);
  EXPECT_NEAR(run.result.best_point[2], 1.0, 1e-4);
  EXPECT_TRUE(AllInside(run.records, params));
}

TEST_F(CmaesTest, FindsRastriginGlobalMaximumIn2DWithRestarts) {
  const auto params = Box(-5.12, 5.12, {3.0, -3.0});
  for (std::uint64_t seed : {1, 2, 3, 4, 5}) {
    const PluginRun run = RunPlugin(*plugin_, params, NegRastrigin,
                                    {{"max_evaluations", "10000"}, {"restarts", "9"}}, seed);
    ASSERT_NE(run.result.status, "failed") << run.result.error;
    EXPECT_GT(run.result.best_velocity, -1e-3) << "seed " << seed;
    EXPECT_NEAR(run.result.best_point[0], 0.0, 1e-2) << "seed " << seed;
    EXPECT_NEAR(run.result.best_point[1], 0.0, 1e-2) << "seed " << seed;
  }
}

TEST_F(CmaesTest, EachGenerationIsOneBatchOfTheDefaultPopulation) {
  // lambda = 4 + floor(3 ln n): 6 for n = 2, 9 for n = 7.
  SessionResult result;
  auto sizes = BatchSizes(*plugin_, Box(-1, 1, {0, 0}), Sphere({0.3, 0.3}), {{"max_evaluations", "40"}}, &result);
  EXPECT_EQ(sizes, (std::vector<std::size_t>{6, 6, 6, 6, 6, 6, 4}));
  EXPECT_EQ(result.status, "budget");
  EXPECT_EQ(result.evaluations, 40);
  sizes = BatchSizes(*plugin_, Box(-1, 1, std::vector<double>(7, 0.0)), Sphere(std::vector<double>(7, 0.1)),
                     {{"max_evaluations", "27"}});
  EXPECT_EQ(sizes, (std::vector<std::size_t>{9, 9, 9}));
  sizes = BatchSizes(*plugin_, Box(-1, 1, {0, 0}), Sphere({0.3, 0.3}),
                     {{"max_evaluations", "50"}, {"population", "25"}});
  EXPECT_EQ(sizes, (std::vector<std::size_t>{25, 25}));
}

TEST_F(CmaesTest, RestartsDoubleThePopulation) {
  SessionResult result;
  const auto sizes = BatchSizes(*plugin_, Box(-1, 1, {0, 0}), Sphere({0.3, -0.2}),
                                {{"max_evaluations", "100000"}, {"restarts", "2"}, {"xtol", "1e-3"}}, &result);
  ASSERT_EQ(result.status, "converged") << result.error;
  ASSERT_FALSE(sizes.empty());
  EXPECT_EQ(sizes.front(), 6u);
  EXPECT_EQ(sizes.back(), 24u);
  EXPECT_NE(std::find(sizes.begin(), sizes.end(), 12u), sizes.end());
  for (std::size_t s : sizes) EXPECT_TRUE(s == 6 || s == 12 || s == 24) << s;
}

TEST_F(CmaesTest, FirstMeanIsTheStart) {
  // With a tiny sigma every first-generation sample is close to the start.
  const PluginRun run = RunPlugin(*plugin_, Box(-10, 10, {4, -6}), Sphere({0, 0}),
                                  {{"max_evaluations", "6"}, {"sigma", "1e-4"}});
  ASSERT_EQ(run.records.size(), 6u);
  for (const auto& r : run.records) {
    EXPECT_NEAR(r.point[0], 4.0, 0.02);
    EXPECT_NEAR(r.point[1], -6.0, 0.02);
  }
}

TEST_F(CmaesTest, DeterministicForASeed) {
  const auto params = Box(-5.12, 5.12, {1, 1, 1});
  const std::map<std::string, std::string> set = {{"max_evaluations", "300"}};
  const PluginRun a = RunPlugin(*plugin_, params, NegRastrigin, set, 7);
  const PluginRun b = RunPlugin(*plugin_, params, NegRastrigin, set, 7);
  const PluginRun c = RunPlugin(*plugin_, params, NegRastrigin, set, 8);
  ASSERT_EQ(a.records.size(), 300u);
  EXPECT_TRUE(SameRecords(a.records, b.records));
  EXPECT_FALSE(SameRecords(a.records, c.records));
}

TEST_F(CmaesTest, StaysInsideTheBoxWithAHugeSigma) {
  std::vector<ProblemParameter> params = {{"a", 0.0, 1e-3, 1e-3}, {"b", -0.1, 0.3, 0.3}, {"c", 100, 1e4, 100}};
  // Linear, equally steep in normalized coordinates: maximum at a corner.
  const PluginRun run = RunPlugin(
      *plugin_, params, [](const std::vector<double>& x) { return x[0] / 1e-3 - x[1] / 0.4 + x[2] / 9900; },
      {{"max_evaluations", "500"}, {"sigma", "1"}});
  ASSERT_NE(run.result.status, "failed") << run.result.error;
  EXPECT_TRUE(AllInside(run.records, params));
  EXPECT_EQ(run.result.best_point, (std::vector<double>{1e-3, -0.1, 1e4}));
}

TEST_F(CmaesTest, PopulationOfOneFails) {
  const PluginRun run = RunPlugin(*plugin_, Box(-1, 1, {0}), Sphere({0}), {{"population", "1"}});
  EXPECT_EQ(run.result.status, "failed");
  EXPECT_NE(run.result.error.find("population"), std::string::npos) << run.result.error;
  EXPECT_EQ(run.result.evaluations, 0);
}

}  // namespace
}  // namespace yamor::optimizer::testing
