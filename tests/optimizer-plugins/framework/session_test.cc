#include "optimizer-plugins/framework/session.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "common/format.h"
#include "common/status.h"

namespace yamor::optimizer {
namespace {

namespace fs = std::filesystem;

std::string TestPlugin(const std::string& name) {
  return std::string(TEST_PLUGIN_DIR) + "/" + name + ".so";
}

// A smooth bowl with its maximum 1 at (0.3, -0.2).
double Bowl(const std::vector<std::pair<std::string, double>>& p) {
  const double x = p.at(0).second - 0.3, y = p.at(1).second + 0.2;
  return 1.0 - x * x - 2.0 * y * y;
}

Problem BowlProblem() {
  return PlainProblem({{"x", -1.0, 1.0, -0.9}, {"y", -1.0, 1.0, 0.8}});
}

std::string ReadFile(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(Session, CompassSearchFindsTheMaximumOfABowl) {
  LoadedPlugin plugin = LoadedPlugin::Load(TestPlugin("compass"));
  Problem problem = BowlProblem();
  FunctionEvaluator evaluator(Bowl);
  Session session(plugin, problem, evaluator, {.seed = 1, .set = {{"tolerance", "1e-6"}}});
  const SessionResult r = session.Run();
  EXPECT_EQ(r.status, "converged");
  ASSERT_TRUE(r.has_best);
  EXPECT_NEAR(r.best_point[0], 0.3, 1e-4);
  EXPECT_NEAR(r.best_point[1], -0.2, 1e-4);
  EXPECT_NEAR(r.best_velocity, 1.0, 1e-7);
  EXPECT_EQ(r.evaluations, evaluator.Count());
  EXPECT_EQ(static_cast<long long>(session.Records().size()), r.evaluations);
}

TEST(Session, TheBudgetCutsABatchAndStopsThePlugin) {
  LoadedPlugin plugin = LoadedPlugin::Load(TestPlugin("compass"));
  Problem problem = BowlProblem();
  FunctionEvaluator evaluator(Bowl);
  // 1 start evaluation + batches of 4: a budget of 7 cuts the second batch.
  Session session(plugin, problem, evaluator, {.set = {{"max_evaluations", "7"}}});
  const SessionResult r = session.Run();
  EXPECT_EQ(r.status, "budget");
  EXPECT_EQ(r.evaluations, 7);
  EXPECT_EQ(evaluator.Count(), 7);
}

TEST(Session, SameSeedSameRunDifferentSeedDifferentStart) {
  LoadedPlugin plugin = LoadedPlugin::Load(TestPlugin("compass"));
  Problem problem = BowlProblem();
  auto run = [&](std::uint64_t seed) {
    FunctionEvaluator evaluator(Bowl);
    Session session(plugin, problem, evaluator,
                    {.seed = seed, .set = {{"random_start", "true"}, {"max_evaluations", "40"}}});
    session.Run();
    std::vector<std::vector<double>> points;
    for (const auto& r : session.Records()) points.push_back(r.point);
    return points;
  };
  EXPECT_EQ(run(7), run(7));
  EXPECT_NE(run(7).front(), run(8).front());
}

TEST(Session, WritesTheResultsFolder) {
  const fs::path out = fs::path(::testing::TempDir()) / "session_results";
  fs::remove_all(out);
  LoadedPlugin plugin = LoadedPlugin::Load(TestPlugin("compass"));
  Problem problem = BowlProblem();
  problem.config_xml = [](const std::vector<double>& x) {
    return "<best x=\"" + FormatDouble(x[0]) + "\"/>\n";
  };
  FunctionEvaluator evaluator(Bowl);
  Session session(plugin, problem, evaluator,
                  {.label = "bowl", .seed = 3, .set = {{"max_evaluations", "30"}}, .out_dir = out.string()});
  const SessionResult r = session.Run();

  const std::string csv = ReadFile(out / "evaluations.csv");
  std::istringstream lines(csv);
  std::string header;
  std::getline(lines, header);
  EXPECT_EQ(header, "index,x,y,velocity,distance,diverged,host,wall_seconds");
  int rows = 0;
  std::string line;
  double best_in_csv = -1e9;
  while (std::getline(lines, line)) {
    ++rows;
    EXPECT_EQ(line.find("nan"), std::string::npos) << line;
    std::vector<std::string> cells;
    std::stringstream ls(line);
    std::string cell;
    while (std::getline(ls, cell, ',')) cells.push_back(cell);
    ASSERT_EQ(cells.size(), 8u) << line;
    EXPECT_EQ(cells[6], "local");
    best_in_csv = std::max(best_in_csv, std::stod(cells[3]));
  }
  EXPECT_EQ(rows, 30);
  EXPECT_EQ(best_in_csv, r.best_velocity);

  EXPECT_EQ(ReadFile(out / "best.xml"), "<best x=\"" + FormatDouble(r.best_point[0]) + "\"/>\n");
  const std::string summary = ReadFile(out / "summary.json");
  EXPECT_NE(summary.find("\"status\": \"budget\""), std::string::npos) << summary;
  EXPECT_NE(summary.find("\"evaluations\": 30"), std::string::npos) << summary;
  EXPECT_NE(summary.find("\"velocity\": " + FormatDouble(r.best_velocity)), std::string::npos) << summary;
  EXPECT_NE(summary.find("\"max_evaluations\": \"30\""), std::string::npos) << summary;
  EXPECT_NE(summary.find("\"live\": false"), std::string::npos) << summary;
  EXPECT_NE(summary.find("\"robot_seconds\": 0,"), std::string::npos) << summary;
}

// A live run (yamor-optimize --live) records each trial's robot time.
TEST(Session, ALiveRunRecordsTheRobotTime) {
  // Each evaluation "spent" 2.5 robot seconds.
  class RobotClock final : public Evaluator {
   public:
    std::vector<Evaluation> EvaluateBatch(const std::vector<Candidate>& batch) override {
      std::vector<Evaluation> out;
      for (const Candidate& c : batch) {
        out.push_back(Evaluation{.velocity = Bowl(c.parameters), .host = "robot", .robot_seconds = 2.5});
      }
      return out;
    }
    void RequestStop() override {}
    int Capacity() const override { return 1; }
  };
  const fs::path out = fs::path(::testing::TempDir()) / "session_live";
  fs::remove_all(out);
  LoadedPlugin plugin = LoadedPlugin::Load(TestPlugin("compass"));
  Problem problem = BowlProblem();
  RobotClock evaluator;
  Session session(plugin, problem, evaluator,
                  {.set = {{"max_evaluations", "6"}}, .out_dir = out.string(),
                   .evaluator_description = "live robot:1", .live = true});
  const SessionResult r = session.Run();
  EXPECT_EQ(r.evaluations, 6);
  EXPECT_DOUBLE_EQ(r.robot_seconds, 15.0);
  std::istringstream lines(ReadFile(out / "evaluations.csv"));
  std::string line;
  std::getline(lines, line);
  EXPECT_EQ(line, "index,x,y,velocity,distance,diverged,host,wall_seconds,robot_seconds");
  std::getline(lines, line);
  EXPECT_EQ(line.substr(line.rfind(',')), ",2.5") << line;
  const std::string summary = ReadFile(out / "summary.json");
  EXPECT_NE(summary.find("\"live\": true"), std::string::npos) << summary;
  EXPECT_NE(summary.find("\"robot_seconds\": 15,"), std::string::npos) << summary;
  EXPECT_NE(summary.find("\"evaluator\": \"live robot:1\""), std::string::npos) << summary;
}

TEST(Session, APluginErrorEndsTheRunAsFailedWithItsMessage) {
  LoadedPlugin plugin = LoadedPlugin::Load(TestPlugin("throws"));
  Problem problem = BowlProblem();
  FunctionEvaluator evaluator(Bowl);
  Session session(plugin, problem, evaluator, {});
  const SessionResult r = session.Run();
  EXPECT_EQ(r.status, "failed");
  EXPECT_EQ(r.error, "the test plugin gives up");
  EXPECT_EQ(r.evaluations, 1);  // the evaluation before the failure is kept
}

TEST(Session, APointOutsideTheBoundsIsRefusedNamingTheParameter) {
  LoadedPlugin plugin = LoadedPlugin::Load(TestPlugin("out_of_bounds"));
  Problem problem = BowlProblem();
  FunctionEvaluator evaluator(Bowl);
  Session session(plugin, problem, evaluator, {});
  const SessionResult r = session.Run();
  EXPECT_EQ(r.status, "failed");
  EXPECT_NE(r.error.find("sets x = 2, outside [-1, 1]"), std::string::npos) << r.error;
  EXPECT_EQ(evaluator.Count(), 0);
}

TEST(Session, AnEvaluatorFailureFailsTheRun) {
  LoadedPlugin plugin = LoadedPlugin::Load(TestPlugin("compass"));
  Problem problem = BowlProblem();
  int calls = 0;
  FunctionEvaluator evaluator([&](const auto& p) {
    if (++calls == 5) throw Error(StatusCode::kUnavailable, "every host is down");
    return Bowl(p);
  });
  Session session(plugin, problem, evaluator, {});
  const SessionResult r = session.Run();
  EXPECT_EQ(r.status, "failed");
  EXPECT_NE(r.error.find("UNAVAILABLE: every host is down"), std::string::npos) << r.error;
  EXPECT_EQ(r.evaluations, 1);  // the failed batch is not recorded
}

TEST(Session, StopEndsTheRunAsStopped) {
  LoadedPlugin plugin = LoadedPlugin::Load(TestPlugin("compass"));
  Problem problem = BowlProblem();
  Session* current = nullptr;
  FunctionEvaluator evaluator([&](const auto& p) {
    current->RequestStop();
    return Bowl(p);
  });
  Session session(plugin, problem, evaluator, {});
  current = &session;
  const SessionResult r = session.Run();
  EXPECT_EQ(r.status, "stopped");
  EXPECT_EQ(r.evaluations, 1);
}

TEST(Session, RejectsABadProblemOrBadFields) {
  LoadedPlugin plugin = LoadedPlugin::Load(TestPlugin("compass"));
  FunctionEvaluator evaluator(Bowl);
  Problem bad_start = PlainProblem({{"x", 0.0, 1.0, 2.0}});
  EXPECT_THROW(Session(plugin, bad_start, evaluator, {}), Error);
  Problem bad_bounds = PlainProblem({{"x", 1.0, 1.0, 1.0}});
  EXPECT_THROW(Session(plugin, bad_bounds, evaluator, {}), Error);
  Problem ok = BowlProblem();
  EXPECT_THROW(Session(plugin, ok, evaluator, {.set = {{"nosuch", "1"}}}), Error);
}

}  // namespace
}  // namespace yamor::optimizer
