// The built powell plugin (plugins/powell.so) run through the real framework
// session on bounded analytic functions with known optima.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "tests/optimizer-plugins/plugin_test_util.h"

namespace yamor::optimizer::testing {
namespace {

using Set = std::map<std::string, std::string>;

const LoadedPlugin& Powell() {
  static const LoadedPlugin plugin = LoadBuiltPlugin("powell");
  return plugin;
}

std::vector<ProblemParameter> Square(double lo, double hi, std::vector<double> start) {
  std::vector<ProblemParameter> out;
  const char* names[] = {"x", "y", "z"};
  for (std::size_t i = 0; i < start.size(); ++i) out.push_back({names[i], lo, hi, start[i]});
  return out;
}

// The coupled quadratic of the core test: maximum 0 at (0.2, -0.1).
double Coupled(const std::vector<double>& x) {
  const double c = std::cos(M_PI / 6), s = std::sin(M_PI / 6);
  const double dx = x[0] - 0.2, dy = x[1] + 0.1;
  const double u = c * dx + s * dy, v = -s * dx + c * dy;
  return -(u * u + 100.0 * v * v);
}

// Every record finite and inside the box, and no point evaluated twice.
void ExpectCleanRecords(const PluginRun& run, const std::vector<ProblemParameter>& box) {
  std::set<std::vector<double>> seen;
  for (const EvaluationRecord& r : run.records) {
    EXPECT_TRUE(std::isfinite(r.evaluation.velocity));
    ASSERT_EQ(r.point.size(), box.size());
    for (std::size_t i = 0; i < box.size(); ++i) {
      EXPECT_TRUE(std::isfinite(r.point[i]));
      EXPECT_GE(r.point[i], box[i].min);
      EXPECT_LE(r.point[i], box[i].max);
    }
    EXPECT_TRUE(seen.insert(r.point).second) << "record " << r.index << " repeats a point";
  }
}

const Set kPrecise = {{"tolerance", "1e-12"}, {"line_tolerance", "1e-7"}, {"bad_value", "-1e6"},
                      {"interval_refinements", "12"}, {"max_evaluations", "5000"}};

// The variants as --set values.
const std::vector<Set> kVariants = {
    {{"line_search", "brent"}, {"bounds", "constant"}},
    {{"line_search", "brent"}, {"bounds", "stadium"}},
    {{"line_search", "brent"}, {"bounds", "easy-direction"}, {"direction_order", "statistics"}},
    {{"line_search", "interval"}, {"bounds", "constant"}},
    {{"line_search", "interval"}, {"bounds", "easy-direction"}, {"direction_order", "statistics"}},
};

Set With(Set base, const Set& more) {
  for (const auto& [k, v] : more) base[k] = v;
  return base;
}

std::string Describe(const Set& set) {
  std::string out;
  for (const auto& [k, v] : set) out += k + "=" + v + " ";
  return out;
}

TEST(PowellPlugin, EveryVariantFindsAShiftedSphere) {
  const auto box = Square(-1.0, 1.0, {-0.8, 0.7, -0.5});
  for (const Set& variant : kVariants) {
    SCOPED_TRACE(Describe(variant));
    const PluginRun run = RunPlugin(Powell(), box, Sphere({0.3, -0.2, 0.55}), With(kPrecise, variant));
    EXPECT_EQ(run.result.status, "converged") << run.result.error;
    ASSERT_TRUE(run.result.has_best);
    EXPECT_NEAR(run.result.best_point[0], 0.3, 1e-4);
    EXPECT_NEAR(run.result.best_point[1], -0.2, 1e-4);
    EXPECT_NEAR(run.result.best_point[2], 0.55, 1e-4);
    ExpectCleanRecords(run, box);
  }
}

TEST(PowellPlugin, EveryVariantFindsAMaximumOnABound) {
  const auto box = Square(-1.0, 1.0, {-0.5, 0.5});
  for (const Set& variant : kVariants) {
    SCOPED_TRACE(Describe(variant));
    const PluginRun run = RunPlugin(Powell(), box, Sphere({0.3, 1.7}), With(kPrecise, variant));
    EXPECT_EQ(run.result.status, "converged") << run.result.error;
    EXPECT_NEAR(run.result.best_point[0], 0.3, 1e-4);
    EXPECT_NEAR(run.result.best_point[1], 1.0, 1e-4);
    ExpectCleanRecords(run, box);
  }
}

TEST(PowellPlugin, NegatedRosenbrockWithinABudget) {
  // Not the classic (-1.2, 1): its x line already holds the optimum (1, 1),
  // which the interval search's whole-line grid finds at once.
  const auto box = Square(-2.0, 2.0, {-1.3, -0.7});
  for (const Set& variant : kVariants) {
    SCOPED_TRACE(Describe(variant));
    const PluginRun run = RunPlugin(Powell(), box, NegRosenbrock,
                                    With(kPrecise, With(variant, {{"max_evaluations", "4000"},
                                                                  {"interval_refinements", "15"}})));
    EXPECT_NE(run.result.status, "failed") << run.result.error;
    EXPECT_NEAR(run.result.best_point[0], 1.0, 2e-3);
    EXPECT_NEAR(run.result.best_point[1], 1.0, 4e-3);
    EXPECT_GT(run.result.best_velocity, -1e-5);
    ExpectCleanRecords(run, box);
  }
}

TEST(PowellPlugin, DirectionReplacementNeedsFewerEvaluations) {
  const auto box = Square(-1.0, 1.0, {-0.9, 0.8});
  auto evaluations_to_reach = [&](const char* replace) {
    const PluginRun run = RunPlugin(Powell(), box, Coupled,
                                    {{"replace_directions", replace}, {"tolerance", "0"},
                                     {"line_tolerance", "1e-6"}, {"max_evaluations", "3000"}});
    EXPECT_NE(run.result.status, "failed") << run.result.error;
    for (const EvaluationRecord& r : run.records) {
      if (r.evaluation.velocity >= -1e-8) return r.index + 1;
    }
    return 1000000LL;
  };
  const long long with = evaluations_to_reach("true");
  const long long without = evaluations_to_reach("false");
  EXPECT_LT(with, 200);
  EXPECT_LT(with, without);
}

// Records the size of every batch the session passes to the evaluator.
class Counting final : public Evaluator {
 public:
  explicit Counting(PointFunction f) : f_(std::move(f)) {}
  std::vector<Evaluation> EvaluateBatch(const std::vector<Candidate>& batch) override {
    sizes.push_back(batch.size());
    std::vector<Evaluation> out(batch.size());
    for (std::size_t k = 0; k < batch.size(); ++k) {
      std::vector<double> x;
      for (const auto& [name, value] : batch[k].parameters) x.push_back(value);
      out[k].velocity = f_(x);
      out[k].host = "local";
    }
    return out;
  }
  void RequestStop() override {}
  int Capacity() const override { return 10; }
  std::vector<std::size_t> sizes;  ///< Every batch's size, in order.

 private:
  PointFunction f_;
};

TEST(PowellPlugin, IntervalSearchSubmitsTenThenFive) {
  Problem problem = PlainProblem(Square(-1.0, 1.0, {-0.83, 0.71}));
  Counting evaluator(Sphere({0.31, -0.22}));
  Session session(Powell(), problem, evaluator,
                  {.seed = 1, .set = {{"line_search", "interval"}, {"max_iterations", "1"},
                                      {"replace_directions", "false"}}});
  const SessionResult r = session.Run();
  EXPECT_EQ(r.status, "converged") << r.error;
  EXPECT_EQ(evaluator.sizes, (std::vector<std::size_t>{1, 10, 5, 10, 5}));
}

TEST(PowellPlugin, SameSeedSameRecordsDifferentSeedDifferentPath) {
  const auto box = Square(-2.0, 2.0, {-1.2, 1.0});
  auto points = [&](std::uint64_t seed) {
    const PluginRun run = RunPlugin(Powell(), box, NegRosenbrock,
                                    {{"max_evaluations", "300"}, {"bad_value", "-1e6"}}, seed);
    std::vector<std::pair<std::vector<double>, double>> out;
    for (const EvaluationRecord& r : run.records) out.emplace_back(r.point, r.evaluation.velocity);
    return out;
  };
  EXPECT_EQ(points(5), points(5));
  EXPECT_NE(points(5), points(6));  // brent's first bracketing step is random
}

TEST(PowellPlugin, TheBudgetIsHonoured) {
  const auto box = Square(-1.0, 1.0, {-0.9, 0.8});
  for (const Set& variant : kVariants) {
    SCOPED_TRACE(Describe(variant));
    const PluginRun run =
        RunPlugin(Powell(), box, Coupled, With(variant, {{"max_evaluations", "23"}, {"tolerance", "0"}}));
    EXPECT_EQ(run.result.status, "budget");
    EXPECT_EQ(run.result.evaluations, 23);
    EXPECT_EQ(run.records.size(), 23u);
  }
}

TEST(PowellPlugin, StartsAtTheStartFieldOrTheConfiguration) {
  const auto box = Square(-1.0, 1.0, {-0.9, 0.8});
  PluginRun run = RunPlugin(Powell(), box, Coupled, {{"max_evaluations", "5"}});
  ASSERT_FALSE(run.records.empty());
  EXPECT_EQ(run.records[0].point, (std::vector<double>{-0.9, 0.8}));
  run = RunPlugin(Powell(), box, Coupled, {{"max_evaluations", "5"}, {"start", "0.25, -0.5"}});
  ASSERT_FALSE(run.records.empty());
  EXPECT_EQ(run.records[0].point, (std::vector<double>{0.25, -0.5}));
}

TEST(PowellPlugin, BadStartFieldsFailTheRunWithAClearMessage) {
  const auto box = Square(-1.0, 1.0, {-0.9, 0.8});
  const std::map<std::string, std::string> cases = {
      {"0.1", "field start has 1 value, the problem has 2 parameters (x, y)"},
      {"0.1,0.2,0.3", "field start has 3 values, the problem has 2 parameters (x, y)"},
      {"0.1,fast", "field start: value 2 ('fast', for y) is not a finite number"},
      {"0.1,1.5", "field start: y = 1.5 is outside [-1, 1]"},
  };
  for (const auto& [start, message] : cases) {
    SCOPED_TRACE(start);
    const PluginRun run = RunPlugin(Powell(), box, Coupled, {{"start", start}});
    EXPECT_EQ(run.result.status, "failed");
    EXPECT_EQ(run.result.error, message);
    EXPECT_TRUE(run.records.empty());
  }
}

TEST(PowellPlugin, DeclaresDocumentedFieldsWithValidDefaults) {
  std::set<std::string> names;
  for (const FieldSpec& f : Powell().fields()) names.insert(f.name);
  for (const char* expected :
       {"max_evaluations", "start", "line_search", "bounds", "bad_value", "malus", "direction_order",
        "replace_directions", "tolerance", "max_iterations", "step", "line_tolerance",
        "interval_points", "refine_points", "interval_refinements"}) {
    EXPECT_EQ(names.count(expected), 1u) << expected;
  }
  EXPECT_EQ(Powell().name(), "powell");
}

}  // namespace
}  // namespace yamor::optimizer::testing
