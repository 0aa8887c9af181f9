// The bayesopt plugin through the real loader and session: it learns Branin
// in 30 evaluations, submits its initial design and Kriging-believer batches
// as parallel batches, is deterministic for a seed, finds an optimum on the
// box's face, and on the quadruped's configuration every candidate obeys the
// <constrain> rules (the framework applies them; the plugin sees only the
// seven free parameters).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>

#include "optimizer-plugins/framework/optimization_config.h"
#include "optimizer-plugins/framework/run_setup.h"
#include "tests/optimizer-plugins/plugins/batch_recorder.h"

namespace yamor::optimizer::testing {
namespace {

class BayesOptTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { plugin_ = new LoadedPlugin(LoadBuiltPlugin("bayesopt")); }
  static void TearDownTestSuite() {
    delete plugin_;
    plugin_ = nullptr;
  }
  static LoadedPlugin* plugin_;
};
LoadedPlugin* BayesOptTest::plugin_ = nullptr;

// Negated Branin in its own units: maximum −0.397887.
double NegBranin(const std::vector<double>& x) {
  const double b = 5.1 / (4.0 * M_PI * M_PI), c = 5.0 / M_PI, t = 1.0 / (8.0 * M_PI);
  const double q = x[1] - b * x[0] * x[0] + c * x[0] - 6.0;
  return -(q * q + 10.0 * (1.0 - t) * std::cos(x[0]) + 10.0);
}

std::vector<ProblemParameter> BraninBox() { return {{"x0", -5, 10, 2.5}, {"x1", 0, 15, 7.5}}; }

TEST_F(BayesOptTest, DeclaresItsFields) {
  std::vector<std::string> names;
  for (const FieldSpec& f : plugin_->fields()) names.push_back(f.name);
  for (const char* expected : {"max_evaluations", "initial_points", "include_start", "acquisition", "kappa", "batch",
                               "fit_restarts", "noise_floor", "max_model_points", "periodic_phases"}) {
    EXPECT_NE(std::find(names.begin(), names.end(), expected), names.end()) << expected;
  }
}

TEST_F(BayesOptTest, LearnsBraninWithinThirtyEvaluations) {
  const auto params = BraninBox();
  for (std::uint64_t seed : {1, 2}) {
    const PluginRun run = RunPlugin(*plugin_, params, NegBranin, {{"max_evaluations", "30"}}, seed);
    ASSERT_EQ(run.result.status, "budget") << run.result.error;
    EXPECT_EQ(run.result.evaluations, 30);
    EXPECT_GT(run.result.best_velocity, -0.397887 - 0.05) << "seed " << seed;
    EXPECT_TRUE(AllInside(run.records, params));
    EXPECT_EQ(run.records.front().point, (std::vector<double>{2.5, 7.5}));  // the start comes first
  }
}

TEST_F(BayesOptTest, TheInitialDesignAndEachProposalAreOneBatch) {
  EXPECT_EQ(BatchSizes(*plugin_, BraninBox(), NegBranin, {{"max_evaluations", "19"}, {"batch", "4"}}),
            (std::vector<std::size_t>{5, 4, 4, 4, 2}));
  EXPECT_EQ(BatchSizes(*plugin_, BraninBox(), NegBranin,
                       {{"max_evaluations", "10"}, {"initial_points", "3"}, {"acquisition", "ucb"}}),
            (std::vector<std::size_t>{3, 1, 1, 1, 1, 1, 1, 1}));
}

TEST_F(BayesOptTest, ABatchOfFourHoldsDistinctPoints) {
  const PluginRun run = RunPlugin(*plugin_, BraninBox(), NegBranin, {{"max_evaluations", "21"}, {"batch", "4"}});
  ASSERT_EQ(run.result.status, "budget") << run.result.error;
  for (std::size_t a = 0; a < run.records.size(); ++a) {
    for (std::size_t b = 0; b < a; ++b) EXPECT_NE(run.records[a].point, run.records[b].point) << a << " " << b;
  }
}

TEST_F(BayesOptTest, TheSameSeedGivesTheSameRun) {
  const std::map<std::string, std::string> set = {{"max_evaluations", "12"}, {"batch", "2"}};
  const PluginRun a = RunPlugin(*plugin_, BraninBox(), NegBranin, set, 7);
  const PluginRun b = RunPlugin(*plugin_, BraninBox(), NegBranin, set, 7);
  const PluginRun c = RunPlugin(*plugin_, BraninBox(), NegBranin, set, 8);
  EXPECT_TRUE(SameRecords(a.records, b.records));
  EXPECT_FALSE(SameRecords(a.records, c.records));
}

TEST_F(BayesOptTest, FindsAnOptimumOnTheBoxFace) {
  // Maximum at x0 = 5 (upper bound), x1 = 1 inside; no start point.
  const auto params = Box(-5, 5, {0, 0});
  const PluginRun run = RunPlugin(*plugin_, params, Sphere({7, 1}),
                                  {{"max_evaluations", "25"}, {"include_start", "false"}});
  ASSERT_EQ(run.result.status, "budget") << run.result.error;
  EXPECT_NEAR(run.result.best_point[0], 5.0, 0.05);
  EXPECT_NEAR(run.result.best_point[1], 1.0, 0.2);
}

// A host behind the raw ABI context that answers NaN in a third of the box
// (x0 > 6, where a simulation would fail; the session refuses non-finite
// values, but the ABI does not): the run goes on to its budget and finds a
// maximum outside that region.
struct NanHost {
  long long budget = 24;
  std::vector<std::vector<double>> points;
  std::vector<double> values;
  YamorParameter parameters[2] = {{"x0", -5, 10, 2.5}, {"x1", 0, 15, 7.5}};
  std::uint64_t state = 12345;
};

TEST_F(BayesOptTest, ANonFiniteValueDoesNotPoisonTheRun) {
  NanHost host;
  YamorOptimizerContext context{};
  context.abi_version = YAMOR_OPTIMIZER_ABI_VERSION;
  context.struct_size = sizeof(YamorOptimizerContext);
  context.host = &host;
  context.parameter_count = 2;
  context.parameters = host.parameters;
  context.seed = 1;
  context.get_field = [](void*, const char* name, const char** value) -> int32_t {
    static const std::map<std::string, std::string> fields = {
        {"max_evaluations", "24"}, {"initial_points", "0"}, {"include_start", "true"}, {"acquisition", "ei"},
        {"kappa", "2"},           {"batch", "2"},          {"fit_restarts", "2"},     {"noise_floor", "1e-6"},
        {"max_model_points", "300"}, {"periodic_phases", "true"}, {"trust_region", "0"}};
    const auto it = fields.find(name);
    if (it == fields.end()) return YAMOR_NOT_FOUND;
    *value = it->second.c_str();
    return YAMOR_OK;
  };
  context.evaluate = [](void* h, const double* points, size_t count, double* values, size_t* evaluated) -> int32_t {
    auto* self = static_cast<NanHost*>(h);
    *evaluated = 0;
    for (size_t k = 0; k < count; ++k) {
      if (static_cast<long long>(self->points.size()) >= self->budget) return YAMOR_STOPPED;
      const std::vector<double> x(points + 2 * k, points + 2 * k + 2);
      values[k] = x[0] > 6.0 ? std::nan("") : NegBranin(x);
      self->points.push_back(x);
      self->values.push_back(values[k]);
      ++*evaluated;
    }
    return YAMOR_OK;
  };
  context.progress = [](void*, double, const char*) {};
  context.log = [](void*, int32_t, const char*) {};
  context.stop_requested = [](void*) -> int32_t { return 0; };
  context.random = [](void* h) -> std::uint64_t {
    auto& s = static_cast<NanHost*>(h)->state;  // splitmix64
    std::uint64_t z = (s += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  };
  context.last_error = [](void*) -> const char* { return ""; };
  char error[256] = "";
  EXPECT_EQ(plugin_->api().run(&context, error, sizeof(error)), YAMOR_STOPPED) << error;
  ASSERT_EQ(host.points.size(), 24u);
  double best = -1e300;
  int failed = 0;
  for (double v : host.values) {
    if (std::isfinite(v)) best = std::max(best, v);
    failed += std::isfinite(v) ? 0 : 1;
  }
  EXPECT_GT(failed, 0);
  EXPECT_GT(best, -0.397887 - 0.1);
  for (const auto& p : host.points) {
    EXPECT_TRUE(p[0] >= -5 && p[0] <= 10 && p[1] >= 0 && p[1] <= 15);
  }
}

TEST_F(BayesOptTest, QuadrupedCandidatesObeyTheConstrainRules) {
  // The thesis's Table 6.1 problem: 7 free parameters, the rest tied by
  // <constrain>. A stand-in for the walk: a smooth function of the free values.
  const OptimizationConfig config = OptimizationConfig::LoadFile(
      (std::filesystem::path(YAMOR_SOURCE_DIR) / "configs" / "optimize" / "quadruped-7.xml").string());
  const Problem problem = MakeProblem(config);
  ASSERT_EQ(problem.parameters.size(), 7u);
  std::vector<Candidate> seen;
  FunctionEvaluator evaluator([&](const std::vector<std::pair<std::string, double>>& named) {
    seen.push_back({named});
    std::map<std::string, double> v(named.begin(), named.end());
    return -std::pow(v.at("amplitude.0") - 0.6, 2) - std::pow(v.at("phase.0.5") - 2.0, 2);
  });
  Session session(*plugin_, problem, evaluator,
                  {.seed = 3, .set = {{"max_evaluations", "14"}, {"batch", "3"}, {"periodic_phases", "true"}}});
  const SessionResult result = session.Run();
  ASSERT_EQ(result.status, "budget") << result.error;
  ASSERT_EQ(seen.size(), 14u);
  for (const Candidate& c : seen) {
    std::map<std::string, double> v(c.parameters.begin(), c.parameters.end());
    ASSERT_GT(v.size(), 7u);  // the constrained parameters are set too
    EXPECT_EQ(v.at("amplitude.1"), v.at("amplitude.0"));
    EXPECT_EQ(v.at("amplitude.8"), v.at("amplitude.5"));
    EXPECT_EQ(v.at("offset.7"), v.at("offset.5"));
    EXPECT_EQ(v.at("phase.2.7"), v.at("phase.0.5"));
  }
}

}  // namespace
}  // namespace yamor::optimizer::testing
