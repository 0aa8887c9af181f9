// The simplex plugin (NLopt Nelder–Mead) through the real session: sphere,
// Rosenbrock and boundary optima, one point per evaluation, the budget
// mapped to NLopt's forced stop, determinism.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "tests/optimizer-plugins/plugins/batch_recorder.h"

namespace yamor::optimizer::testing {
namespace {

class SimplexTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { plugin_ = new LoadedPlugin(LoadBuiltPlugin("simplex")); }
  static void TearDownTestSuite() {
    delete plugin_;
    plugin_ = nullptr;
  }
  static LoadedPlugin* plugin_;
};
LoadedPlugin* SimplexTest::plugin_ = nullptr;

TEST_F(SimplexTest, DeclaresItsFields) {
  std::vector<std::string> names;
  for (const FieldSpec& f : plugin_->fields()) names.push_back(f.name);
  for (const char* expected : {"max_evaluations", "initial_step", "xtol", "ftol"}) {
    EXPECT_NE(std::find(names.begin(), names.end(), expected), names.end()) << expected;
  }
}

TEST_F(SimplexTest, ConvergesOnShiftedSphere) {
  const auto params = Box(-5, 5, {0, 0, 0});
  const PluginRun run = RunPlugin(*plugin_, params, Sphere({1.5, -2.0, 0.7}),
                                  {{"max_evaluations", "3000"}, {"xtol", "1e-7"}, {"ftol", "0"}});
  ASSERT_EQ(run.result.status, "converged") << run.result.error;
  EXPECT_LT(run.result.evaluations, 3000);
  EXPECT_GT(run.result.best_velocity, -1e-8);
  EXPECT_NEAR(run.result.best_point[0], 1.5, 1e-4);
  EXPECT_NEAR(run.result.best_point[1], -2.0, 1e-4);
  EXPECT_NEAR(run.result.best_point[2], 0.7, 1e-4);
  EXPECT_TRUE(AllInside(run.records, params));
}

TEST_F(SimplexTest, FindsRosenbrockMaximum) {
  const auto params = Box(-2, 2, {-1.2, 1.0});
  const PluginRun run = RunPlugin(*plugin_, params, NegRosenbrock,
                                  {{"max_evaluations", "3000"}, {"xtol", "1e-9"}, {"ftol", "0"}});
  ASSERT_NE(run.result.status, "failed") << run.result.error;
  EXPECT_GT(run.result.best_velocity, -1e-6);
  EXPECT_NEAR(run.result.best_point[0], 1.0, 1e-2);
  EXPECT_NEAR(run.result.best_point[1], 1.0, 2e-2);
}

TEST_F(SimplexTest, FindsOptimumOnTheBoundary) {
  const auto params = Box(-5, 5, {0, 0});
  const PluginRun run = RunPlugin(*plugin_, params, Sphere({7, -9}), {{"max_evaluations", "2000"}});
  ASSERT_EQ(run.result.status, "converged") << run.result.error;
  EXPECT_NEAR(run.result.best_point[0], 5.0, 1e-3);
  EXPECT_NEAR(run.result.best_point[1], -5.0, 1e-3);
  EXPECT_TRUE(AllInside(run.records, params));
}

TEST_F(SimplexTest, StartOnTheUpperBoundStaysInside) {
  // Starting in the corner: the initial simplex must step inwards and no
  // point may round past a bound (an awkward range: -0.1 + 0.4 > 0.3).
  std::vector<ProblemParameter> params = {{"a", -0.1, 0.3, 0.3}, {"b", 100, 1e4, 1e4}};
  const PluginRun run = RunPlugin(*plugin_, params, [](const std::vector<double>& x) { return x[0] + x[1]; },
                                  {{"max_evaluations", "200"}});
  ASSERT_NE(run.result.status, "failed") << run.result.error;
  EXPECT_TRUE(AllInside(run.records, params));
  EXPECT_EQ(run.result.best_point, (std::vector<double>{0.3, 1e4}));
}

TEST_F(SimplexTest, EvaluatesOnePointAtATimeFromTheStart) {
  SessionResult result;
  const auto sizes = BatchSizes(*plugin_, Box(-1, 1, {0.1, 0.2}), Sphere({0.5, -0.5}), {{"max_evaluations", "50"}},
                                &result);
  ASSERT_FALSE(sizes.empty());
  EXPECT_TRUE(std::all_of(sizes.begin(), sizes.end(), [](std::size_t s) { return s == 1; }));
  const PluginRun run =
      RunPlugin(*plugin_, Box(-1, 1, {0.1, 0.2}), Sphere({0.5, -0.5}), {{"max_evaluations", "5"}});
  ASSERT_FALSE(run.records.empty());
  EXPECT_EQ(run.records[0].point, (std::vector<double>{0.1, 0.2}));
}

TEST_F(SimplexTest, BudgetBecomesAForcedStop) {
  const PluginRun run = RunPlugin(*plugin_, Box(-2, 2, {-1.2, 1.0}), NegRosenbrock,
                                  {{"max_evaluations", "17"}, {"xtol", "0"}, {"ftol", "0"}});
  EXPECT_EQ(run.result.status, "budget") << run.result.error;
  EXPECT_EQ(run.result.evaluations, 17);
}

TEST_F(SimplexTest, DeterministicForASeed) {
  const auto params = Box(-5.12, 5.12, {1, 2, -1});
  const std::map<std::string, std::string> set = {{"max_evaluations", "200"}};
  const PluginRun a = RunPlugin(*plugin_, params, NegRastrigin, set, 3);
  const PluginRun b = RunPlugin(*plugin_, params, NegRastrigin, set, 3);
  ASSERT_FALSE(a.records.empty());
  EXPECT_TRUE(SameRecords(a.records, b.records));
}

}  // namespace
}  // namespace yamor::optimizer::testing
