// The grid plugin through the real session: the exact point set and order,
// bounds included, chunked batches, the landscape CSV of a two-parameter
// sweep, the budget, and refused field values.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <unistd.h>

#include "tests/optimizer-plugins/plugins/batch_recorder.h"

namespace yamor::optimizer::testing {
namespace {

namespace fs = std::filesystem;

class GridTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { plugin_ = new LoadedPlugin(LoadBuiltPlugin("grid")); }
  static void TearDownTestSuite() {
    delete plugin_;
    plugin_ = nullptr;
  }
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("yamor_grid_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  static std::string Read(const fs::path& path) {
    std::ifstream in(path);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }

  static LoadedPlugin* plugin_;
  fs::path dir_;
};
LoadedPlugin* GridTest::plugin_ = nullptr;

// a in [0, 1] starting at 0.5, b in [-1, 1] at 0.25, c in [2, 4] at 3.
std::vector<ProblemParameter> Abc() {
  return {{"a", 0.0, 1.0, 0.5}, {"b", -1.0, 1.0, 0.25}, {"c", 2.0, 4.0, 3.0}};
}

double Linear(const std::vector<double>& x) { return x[0] + 10.0 * x[2] - x[1]; }

TEST_F(GridTest, SweepsTheNamedParametersInGridOrder) {
  const PluginRun run = RunPlugin(*plugin_, Abc(), Linear, {{"parameters", "a, c"}, {"resolution", "3"}});
  ASSERT_EQ(run.result.status, "converged") << run.result.error;
  std::vector<std::vector<double>> points;
  for (const auto& r : run.records) points.push_back(r.point);
  // The first named parameter varies slowest; b stays at its start.
  const std::vector<std::vector<double>> expected = {
      {0.0, 0.25, 2.0}, {0.0, 0.25, 3.0}, {0.0, 0.25, 4.0}, {0.5, 0.25, 2.0}, {0.5, 0.25, 3.0},
      {0.5, 0.25, 4.0}, {1.0, 0.25, 2.0}, {1.0, 0.25, 3.0}, {1.0, 0.25, 4.0}};
  EXPECT_EQ(points, expected);
  EXPECT_EQ(run.result.best_point, (std::vector<double>{1.0, 0.25, 4.0}));
}

TEST_F(GridTest, OrderFollowsTheParametersField) {
  const PluginRun run = RunPlugin(*plugin_, Abc(), Linear, {{"parameters", "c,a"}, {"resolution", "2"}});
  ASSERT_EQ(run.result.status, "converged") << run.result.error;
  std::vector<std::vector<double>> points;
  for (const auto& r : run.records) points.push_back(r.point);
  const std::vector<std::vector<double>> expected = {
      {0.0, 0.25, 2.0}, {1.0, 0.25, 2.0}, {0.0, 0.25, 4.0}, {1.0, 0.25, 4.0}};
  EXPECT_EQ(points, expected);
}

TEST_F(GridTest, EmptyParametersSweepsAll) {
  const PluginRun run = RunPlugin(*plugin_, Abc(), Linear, {{"resolution", "2"}});
  ASSERT_EQ(run.result.status, "converged") << run.result.error;
  ASSERT_EQ(run.records.size(), 8u);
  EXPECT_EQ(run.records[0].point, (std::vector<double>{0.0, -1.0, 2.0}));
  EXPECT_EQ(run.records[1].point, (std::vector<double>{0.0, -1.0, 4.0}));
  EXPECT_EQ(run.records[2].point, (std::vector<double>{0.0, 1.0, 2.0}));
  EXPECT_EQ(run.records[7].point, (std::vector<double>{1.0, 1.0, 4.0}));
  EXPECT_EQ(run.result.best_velocity, 1.0 + 40.0 + 1.0);
}

TEST_F(GridTest, AwkwardRangesKeepEveryPointInsideWithBothBoundsExact) {
  std::vector<ProblemParameter> params = {{"p", -0.1, 0.3, 0.0}, {"q", 1e-9, 3e-9, 2e-9}};
  const PluginRun run = RunPlugin(
      *plugin_, params, [](const std::vector<double>& x) { return x[0] + x[1]; }, {{"resolution", "7"}});
  ASSERT_EQ(run.result.status, "converged") << run.result.error;
  ASSERT_EQ(run.records.size(), 49u);
  EXPECT_TRUE(AllInside(run.records, params));
  EXPECT_EQ(run.records.front().point, (std::vector<double>{-0.1, 1e-9}));
  EXPECT_EQ(run.records.back().point, (std::vector<double>{0.3, 3e-9}));
}

TEST_F(GridTest, BatchesAreChunksOfTheGrid) {
  SessionResult result;
  auto sizes = BatchSizes(*plugin_, Abc(), Linear, {{"parameters", "a,b"}, {"resolution", "3"}, {"batch", "4"}},
                          &result);
  EXPECT_EQ(sizes, (std::vector<std::size_t>{4, 4, 1}));
  EXPECT_EQ(result.status, "converged");
  sizes = BatchSizes(*plugin_, Abc(), Linear, {{"parameters", "a,b"}, {"resolution", "3"}, {"batch", "0"}});
  EXPECT_EQ(sizes, (std::vector<std::size_t>{9}));
  sizes = BatchSizes(*plugin_, Abc(), Linear, {{"resolution", "8"}});  // 512 points, default batch 256
  EXPECT_EQ(sizes, (std::vector<std::size_t>{256, 256}));
}

TEST_F(GridTest, WritesTheLandscapeCsv) {
  const fs::path csv = dir_ / "sub" / "landscape.csv";
  const PluginRun run = RunPlugin(*plugin_, Abc(), Linear,
                                  {{"parameters", "a,c"}, {"resolution", "3"}, {"landscape_csv", csv.string()}});
  ASSERT_EQ(run.result.status, "converged") << run.result.error;
  // value = a + 10 c - b with b = 0.25.
  EXPECT_EQ(Read(csv),
            "a,c,value\n"
            "0,2,19.75\n0,3,29.75\n0,4,39.75\n"
            "0.5,2,20.25\n0.5,3,30.25\n0.5,4,40.25\n"
            "1,2,20.75\n1,3,30.75\n1,4,40.75\n");
  EXPECT_FALSE(fs::exists(csv.string() + ".tmp"));
}

TEST_F(GridTest, LandscapeCsvReadsBackExactlyTheRecords) {
  const fs::path csv = dir_ / "landscape.csv";
  std::vector<ProblemParameter> params = {{"phase.0.1", 0.0, 2 * M_PI, 1.0}, {"offset.5", -M_PI / 2, 0.0, -0.3},
                                          {"amplitude.0", 0.0, M_PI / 4, 0.5}};
  const PluginRun run = RunPlugin(
      *plugin_, params, [](const std::vector<double>& x) { return std::sin(x[0]) * std::cos(3 * x[1]) + x[2]; },
      {{"parameters", "offset.5,phase.0.1"}, {"resolution", "5"}, {"landscape_csv", csv.string()}});
  ASSERT_EQ(run.result.status, "converged") << run.result.error;
  std::ifstream in(csv);
  std::string line;
  ASSERT_TRUE(std::getline(in, line));
  EXPECT_EQ(line, "offset.5,phase.0.1,value");
  std::size_t k = 0;
  while (std::getline(in, line)) {
    ASSERT_LT(k, run.records.size());
    double x = 0, y = 0, v = 0;
    char* end = nullptr;
    x = std::strtod(line.c_str(), &end);
    y = std::strtod(end + 1, &end);
    v = std::strtod(end + 1, &end);
    EXPECT_EQ(x, run.records[k].point[1]) << line;
    EXPECT_EQ(y, run.records[k].point[0]) << line;
    EXPECT_EQ(v, run.records[k].evaluation.velocity) << line;
    ++k;
  }
  EXPECT_EQ(k, 25u);
}

TEST_F(GridTest, BudgetEndsTheSweepWithoutALandscape) {
  const fs::path csv = dir_ / "landscape.csv";
  const PluginRun run = RunPlugin(*plugin_, Abc(), Linear,
                                  {{"parameters", "a,c"},
                                   {"resolution", "4"},
                                   {"batch", "3"},
                                   {"max_evaluations", "7"},
                                   {"landscape_csv", csv.string()}});
  EXPECT_EQ(run.result.status, "budget") << run.result.error;
  EXPECT_EQ(run.records.size(), 7u);
  EXPECT_FALSE(fs::exists(csv));
}

TEST_F(GridTest, HugeGridIsCutToTheBudget) {
  // 100000^3 points in one batch: only the budget's worth is built.
  SessionResult result;
  const auto sizes = BatchSizes(*plugin_, Abc(), Linear,
                                {{"resolution", "100000"}, {"batch", "0"}, {"max_evaluations", "50"}}, &result);
  EXPECT_EQ(sizes, (std::vector<std::size_t>{50}));
  EXPECT_EQ(result.status, "budget");
}

TEST_F(GridTest, RefusesUnknownDuplicateOrEmptyNames) {
  PluginRun run = RunPlugin(*plugin_, Abc(), Linear, {{"parameters", "a,zz"}});
  EXPECT_EQ(run.result.status, "failed");
  EXPECT_NE(run.result.error.find("'zz'"), std::string::npos) << run.result.error;
  EXPECT_NE(run.result.error.find("a, b, c"), std::string::npos) << run.result.error;
  EXPECT_EQ(run.result.evaluations, 0);
  run = RunPlugin(*plugin_, Abc(), Linear, {{"parameters", "a,a"}});
  EXPECT_EQ(run.result.status, "failed");
  EXPECT_NE(run.result.error.find("twice"), std::string::npos) << run.result.error;
  run = RunPlugin(*plugin_, Abc(), Linear, {{"parameters", "a,,b"}});
  EXPECT_EQ(run.result.status, "failed");
  EXPECT_NE(run.result.error.find("empty"), std::string::npos) << run.result.error;
}

TEST_F(GridTest, LandscapeNeedsExactlyTwoParameters) {
  const fs::path csv = dir_ / "landscape.csv";
  const PluginRun run = RunPlugin(*plugin_, Abc(), Linear, {{"resolution", "2"}, {"landscape_csv", csv.string()}});
  EXPECT_EQ(run.result.status, "failed");
  EXPECT_NE(run.result.error.find("exactly two"), std::string::npos) << run.result.error;
  EXPECT_EQ(run.result.evaluations, 0);
  EXPECT_FALSE(fs::exists(csv));
}

TEST_F(GridTest, DeterministicWhateverTheSeed) {
  const auto a = RunPlugin(*plugin_, Abc(), Linear, {{"resolution", "3"}}, 1);
  const auto b = RunPlugin(*plugin_, Abc(), Linear, {{"resolution", "3"}}, 99);
  EXPECT_TRUE(SameRecords(a.records, b.records));
}

}  // namespace
}  // namespace yamor::optimizer::testing
