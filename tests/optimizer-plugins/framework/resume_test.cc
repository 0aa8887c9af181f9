// Resuming a killed run (issue 17 §2): reading evaluations.csv back (torn
// last lines dropped, damage refused), run.toml, and Session resuming from
// every point a kill can leave the folder in, against an uninterrupted run.
#include "optimizer-plugins/framework/resume.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "common/format.h"
#include "common/status.h"
#include "optimizer-plugins/framework/session.h"
#include "tests/support/code_of.h"

namespace yamor::optimizer {
namespace {

namespace fs = std::filesystem;
using ::yamor::testing::CodeOf;

std::string TestPlugin(const std::string& name) {
  return std::string(TEST_PLUGIN_DIR) + "/" + name + ".so";
}

std::string ReadFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void WriteFile(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
}

// A bowl with its maximum at (0.3, -0.2); best.xml names the point.
double Bowl(const std::vector<std::pair<std::string, double>>& p) {
  const double x = p.at(0).second - 0.3, y = p.at(1).second + 0.2;
  return 1.0 - x * x - 2.0 * y * y;
}

Problem BowlProblem() {
  Problem problem = PlainProblem({{"x", -1.0, 1.0, -0.9}, {"y", -1.0, 1.0, 0.8}});
  problem.config_xml = [](const std::vector<double>& x) {
    return "<best x=\"" + FormatDouble(x[0]) + "\" y=\"" + FormatDouble(x[1]) + "\"/>\n";
  };
  return problem;
}

// The file without the columns and keys that measure time.
std::string WithoutTiming(const std::string& text, bool csv) {
  std::istringstream in(text);
  std::string line, out;
  while (std::getline(in, line)) {
    if (csv) {
      line = line.substr(0, line.rfind(','));  // wall_seconds is the last column
    } else if (line.find("\"wall_seconds\"") != std::string::npos ||
               line.find("\"evaluations_per_second\"") != std::string::npos) {
      continue;
    }
    out += line + "\n";
  }
  return out;
}

constexpr const char* kHeader = "index,x,y,velocity,distance,diverged,host,wall_seconds\n";

TEST(EvaluationRecord, ReadsRowsBackExactly) {
  const std::string text = std::string(kHeader) +
                           "0,-0.9,0.1,-0.5800000000000001,0,0,local,1e-06\n"
                           "1,0.30000000000000004,-0.2,1,0.25,1,\"[::1]:2224\",0.5\n";
  const EvaluationRecordFile record = ParseEvaluationRecord(text, "e.csv");
  EXPECT_FALSE(record.torn);
  EXPECT_EQ(record.columns, (std::vector<std::string>{"x", "y"}));
  ASSERT_EQ(record.rows.size(), 2u);
  EXPECT_EQ(record.rows[0].values, (std::vector<double>{-0.9, 0.1}));
  EXPECT_EQ(record.rows[0].evaluation.velocity, -0.5800000000000001);
  EXPECT_EQ(record.rows[1].values[0], 0.30000000000000004);
  EXPECT_TRUE(record.rows[1].evaluation.diverged);
  EXPECT_EQ(record.rows[1].evaluation.host, "[::1]:2224");
  EXPECT_EQ(record.rows[1].evaluation.wall_seconds, 0.5);
  EXPECT_EQ(record.valid_bytes, text.size());
}

TEST(EvaluationRecord, ATornLastLineIsDroppedWhereverTheCutFalls) {
  const std::string whole = std::string(kHeader) + "0,-0.9,0.1,-0.58,0,0,local,1e-06\n" +
                            "1,0.3,-0.2,1,0.25,0,local,0.5\n";
  const std::size_t second_row = whole.find("1,0.3");
  for (std::size_t cut = second_row + 1; cut < whole.size(); ++cut) {
    const EvaluationRecordFile record = ParseEvaluationRecord(whole.substr(0, cut), "e.csv");
    EXPECT_TRUE(record.torn) << cut;
    EXPECT_EQ(record.rows.size(), 1u) << cut;
    EXPECT_EQ(record.valid_bytes, second_row) << cut;
    EXPECT_NE(record.torn_reason.find("line 3"), std::string::npos) << record.torn_reason;
  }
  // A header cut short: nothing recorded.
  const EvaluationRecordFile header = ParseEvaluationRecord("index,x,y,vel", "e.csv");
  EXPECT_TRUE(header.torn);
  EXPECT_TRUE(header.columns.empty());
  EXPECT_EQ(header.valid_bytes, 0u);
  // Power loss can leave a complete but garbled last line (zeros).
  const EvaluationRecordFile zeros = ParseEvaluationRecord(
      std::string(kHeader) + "0,-0.9,0.1,-0.58,0,0,local,1e-06\n" + std::string(9, '\0') + "\n",
      "e.csv");
  EXPECT_TRUE(zeros.torn);
  EXPECT_EQ(zeros.rows.size(), 1u);
}

TEST(EvaluationRecord, DamageBeforeTheLastLineIsDataLoss) {
  const std::string text = std::string(kHeader) + "0,-0.9,0.1,-0.58,0,0,local,1e-06\n" +
                           "1,0.3,oops,1,0.25,0,local,0.5\n" + "2,0.3,-0.2,1,0.25,0,local,0.5\n";
  try {
    ParseEvaluationRecord(text, "e.csv");
    FAIL() << "accepted a damaged record";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kDataLoss);
    EXPECT_NE(std::string(e.what()).find("e.csv:3: value 'oops'"), std::string::npos) << e.what();
  }
  // Rows out of order are damage too.
  EXPECT_EQ(CodeOf([&] {
              ParseEvaluationRecord(std::string(kHeader) + "1,0,0,0,0,0,local,0\n" +
                                        "0,0,0,0,0,0,local,0\n",
                                    "e.csv");
            }),
            StatusCode::kDataLoss);
  EXPECT_EQ(CodeOf([&] { ParseEvaluationRecord("not,a,header\n0,1\n", "e.csv"); }),
            StatusCode::kDataLoss);
}

TEST(EvaluationRecord, SplitsQuotedFields) {
  std::vector<std::string> fields;
  ASSERT_TRUE(SplitCsvLine("a,\"b,c\",\"d\"\"e\",", fields));
  EXPECT_EQ(fields, (std::vector<std::string>{"a", "b,c", "d\"e", ""}));
  EXPECT_FALSE(SplitCsvLine("a,\"b", fields));
}

TEST(RunFile, RoundTripsAndNamesEveryDifference) {
  const fs::path path = fs::path(::testing::TempDir()) / "resume_run_file.toml";
  const RunIdentity identity = {{"seed", "3"}, {"field.max_evaluations", "40"},
                                {"evaluation", "world=quadruped warmup=1"}};
  WriteRunFile(path.string(), identity, {{"command", "yamor-optimize --seed 3 'a b'"}});
  std::map<std::string, std::string> info;
  EXPECT_EQ(ReadRunFile(path.string(), &info), identity);
  EXPECT_EQ(info.at("command"), "yamor-optimize --seed 3 'a b'");

  RunIdentity changed = identity;
  changed["seed"] = "4";
  changed.erase("evaluation");
  changed["plugin"] = "random 1.0.0";
  EXPECT_EQ(IdentityDifferences(identity, identity), "");
  const std::string why = IdentityDifferences(identity, changed);
  EXPECT_NE(why.find("seed: recorded '3', now '4'"), std::string::npos) << why;
  EXPECT_NE(why.find("evaluation: recorded 'world=quadruped warmup=1', now not set"),
            std::string::npos)
      << why;
  EXPECT_NE(why.find("plugin: not recorded, now 'random 1.0.0'"), std::string::npos) << why;
  EXPECT_EQ(Fingerprint("abc"), Fingerprint("abc"));
  EXPECT_NE(Fingerprint("abc"), Fingerprint("abd"));
}

class ResumeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::path(::testing::TempDir()) /
            ("resume_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(root_);
    fs::create_directories(root_);
  }

  SessionOptions Options(const fs::path& dir, bool resume) const {
    return SessionOptions{.label = "bowl",
                          .seed = 5,
                          .set = {{"random_start", "true"}, {"max_evaluations", "40"}},
                          .out_dir = dir.string(),
                          .evaluator_description = "local",
                          .resume = resume,
                          .identity = {{"configuration", "bowl v1"}}};
  }

  // Runs to the end in `dir`; returns the evaluations the evaluator made.
  long long RunIn(const fs::path& dir, bool resume, SessionResult* result = nullptr) {
    FunctionEvaluator evaluator(Bowl);
    Session session(plugin_, problem_, evaluator, Options(dir, resume));
    const SessionResult r = session.Run();
    if (result != nullptr) *result = r;
    return evaluator.Count();
  }

  LoadedPlugin plugin_ = LoadedPlugin::Load(TestPlugin("compass"));
  Problem problem_ = BowlProblem();
  fs::path root_;
};

TEST_F(ResumeTest, EveryCutOfTheRecordResumesToTheUninterruptedRun) {
  const fs::path reference = root_ / "reference";
  SessionResult whole;
  ASSERT_EQ(RunIn(reference, false, &whole), 40);
  ASSERT_EQ(whole.status, "budget");
  const std::string csv = ReadFile(reference / "evaluations.csv");
  const std::string summary = ReadFile(reference / "summary.json");
  const std::string best = ReadFile(reference / "best.xml");
  ASSERT_FALSE(best.empty());

  // A kill leaves run.toml, a prefix of evaluations.csv (cut anywhere, also
  // inside a line) and best.xml / summary.json from before or none.
  std::vector<std::size_t> cuts;
  for (std::size_t cut = 0; cut <= csv.size(); cut += 13) cuts.push_back(cut);
  for (std::size_t at = csv.find('\n'); at != std::string::npos; at = csv.find('\n', at + 1)) {
    cuts.push_back(at + 1);
  }
  for (std::size_t cut : cuts) {
    SCOPED_TRACE("cut at byte " + std::to_string(cut));
    const fs::path dir = root_ / ("cut" + std::to_string(cut));
    fs::create_directories(dir);
    fs::copy_file(reference / "run.toml", dir / "run.toml");
    WriteFile(dir / "evaluations.csv", csv.substr(0, cut));
    const EvaluationRecordFile kept = ParseEvaluationRecord(csv.substr(0, cut), "cut");
    SessionResult r;
    EXPECT_EQ(RunIn(dir, true, &r), 40 - static_cast<long long>(kept.rows.size()))
        << "recorded evaluations are not run again";
    EXPECT_EQ(r.status, "budget");
    EXPECT_EQ(WithoutTiming(ReadFile(dir / "evaluations.csv"), true), WithoutTiming(csv, true));
    EXPECT_EQ(WithoutTiming(ReadFile(dir / "summary.json"), false), WithoutTiming(summary, false));
    EXPECT_EQ(ReadFile(dir / "best.xml"), best);
    fs::remove_all(dir);
  }
}

TEST_F(ResumeTest, ResumingAFinishedRunRunsNothing) {
  const fs::path dir = root_ / "done";
  ASSERT_EQ(RunIn(dir, false), 40);
  const std::string csv = ReadFile(dir / "evaluations.csv");
  EXPECT_EQ(RunIn(dir, true), 0);
  EXPECT_EQ(ReadFile(dir / "evaluations.csv"), csv);
}

TEST_F(ResumeTest, AFolderWithNothingRecordedStartsTheRun) {
  EXPECT_EQ(RunIn(root_ / "fresh", true), 40);
  EXPECT_TRUE(fs::exists(root_ / "fresh" / "run.toml"));
}

TEST_F(ResumeTest, RefusesAnotherPluginSeedFieldOrConfigurationNamingIt) {
  const fs::path dir = root_ / "run";
  ASSERT_EQ(RunIn(dir, false), 40);
  FunctionEvaluator evaluator(Bowl);
  const auto refusal = [&](SessionOptions options, const Problem& problem) {
    try {
      Session session(plugin_, problem, evaluator, options);
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), StatusCode::kFailedPrecondition);
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  SessionOptions seed = Options(dir, true);
  seed.seed = 6;
  EXPECT_NE(refusal(seed, problem_).find("seed: recorded '5', now '6'"), std::string::npos);
  SessionOptions budget = Options(dir, true);
  budget.set["max_evaluations"] = "41";
  EXPECT_NE(refusal(budget, problem_).find("field.max_evaluations: recorded '40', now '41'"),
            std::string::npos);
  SessionOptions config = Options(dir, true);
  config.identity["configuration"] = "bowl v2";
  EXPECT_NE(refusal(config, problem_).find("configuration: recorded 'bowl v1', now 'bowl v2'"),
            std::string::npos);
  Problem wider = problem_;
  wider.parameters[0].max = 2.0;
  EXPECT_NE(refusal(Options(dir, true), wider).find("parameters: recorded"), std::string::npos);
  // Another plugin, or a rebuilt file of the same name and version.
  RunIdentity recorded = ReadRunFile((dir / "run.toml").string());
  EXPECT_EQ(recorded.at("plugin").rfind("compass ", 0), 0u) << recorded.at("plugin");
  recorded["plugin"] = "random 1.0.0";
  recorded["plugin_file"] = "fnv1a64:0000000000000000";
  WriteRunFile((dir / "run.toml").string(), recorded, {{"command", "yamor-optimize --seed 5"}});
  const std::string why = refusal(Options(dir, true), problem_);
  EXPECT_NE(why.find("plugin: recorded 'random 1.0.0', now 'compass "), std::string::npos) << why;
  EXPECT_NE(why.find("plugin_file: recorded 'fnv1a64:0000000000000000'"), std::string::npos)
      << why;
  EXPECT_NE(why.find("it was started as: yamor-optimize --seed 5"), std::string::npos) << why;
  EXPECT_EQ(evaluator.Count(), 0);
}

TEST_F(ResumeTest, RefusesEvaluationsWithoutARunFile) {
  const fs::path dir = root_ / "old";
  ASSERT_EQ(RunIn(dir, false), 40);
  fs::remove(dir / "run.toml");
  FunctionEvaluator evaluator(Bowl);
  EXPECT_EQ(CodeOf([&] { Session session(plugin_, problem_, evaluator, Options(dir, true)); }),
            StatusCode::kFailedPrecondition);
}

TEST_F(ResumeTest, ARecordThePluginDoesNotFollowFailsTheRun) {
  const fs::path dir = root_ / "edited";
  ASSERT_EQ(RunIn(dir, false), 40);
  std::string csv = ReadFile(dir / "evaluations.csv");
  // Keep 10 rows and change the x of row 5.
  std::istringstream in(csv);
  std::string line, kept;
  for (int i = 0; i < 11 && std::getline(in, line); ++i) {
    if (i == 6) line = "5,0.123" + line.substr(line.find(',', 2));
    kept += line + "\n";
  }
  WriteFile(dir / "evaluations.csv", kept);
  SessionResult r;
  RunIn(dir, true, &r);
  EXPECT_EQ(r.status, "failed");
  EXPECT_NE(r.error.find("evaluation 5 asks for {x="), std::string::npos) << r.error;
  EXPECT_NE(r.error.find("does not follow its record"), std::string::npos) << r.error;
}

}  // namespace
}  // namespace yamor::optimizer
