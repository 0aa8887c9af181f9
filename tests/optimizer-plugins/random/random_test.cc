// The example plugin through the real framework session.
#include <gtest/gtest.h>

#include "tests/optimizer-plugins/plugin_test_util.h"

namespace yamor::optimizer {
namespace {

using testing::LoadBuiltPlugin;
using testing::RunPlugin;
using testing::Sphere;

const std::vector<ProblemParameter> kBox = {{"a", -2.0, 2.0, 1.5}, {"b", 0.0, 1.0, 0.9}};

TEST(RandomPlugin, ShrinkingSearchApproachesTheMaximum) {
  const LoadedPlugin plugin = LoadBuiltPlugin("random");
  const auto run = RunPlugin(plugin, kBox, Sphere({0.4, 0.25}),
                             {{"max_evaluations", "801"}, {"shrink", "0.8"}}, 3);
  EXPECT_EQ(run.result.status, "budget");
  EXPECT_EQ(run.result.evaluations, 801);
  EXPECT_NEAR(run.result.best_point[0], 0.4, 1e-3);
  EXPECT_NEAR(run.result.best_point[1], 0.25, 1e-3);
}

TEST(RandomPlugin, EvaluatesTheStartThenBatchesInsideTheBounds) {
  const LoadedPlugin plugin = LoadBuiltPlugin("random");
  const auto run = RunPlugin(plugin, kBox, Sphere({0.0, 0.0}),
                             {{"max_evaluations", "41"}, {"batch", "8"}}, 5);
  ASSERT_EQ(run.records.size(), 41u);
  EXPECT_EQ(run.records[0].point, (std::vector<double>{1.5, 0.9}));
  for (const auto& r : run.records) {
    EXPECT_GE(r.point[0], -2.0);
    EXPECT_LE(r.point[0], 2.0);
    EXPECT_GE(r.point[1], 0.0);
    EXPECT_LE(r.point[1], 1.0);
  }
}

TEST(RandomPlugin, TheSeedDecidesThePoints) {
  const LoadedPlugin plugin = LoadBuiltPlugin("random");
  auto points = [&](std::uint64_t seed) {
    std::vector<std::vector<double>> out;
    for (const auto& r : RunPlugin(plugin, kBox, Sphere({0.0, 0.0}), {{"max_evaluations", "33"}}, seed).records) {
      out.push_back(r.point);
    }
    return out;
  };
  EXPECT_EQ(points(9), points(9));
  EXPECT_NE(points(9), points(10));
}

}  // namespace
}  // namespace yamor::optimizer
