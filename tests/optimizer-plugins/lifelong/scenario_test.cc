#include "optimizer-plugins/lifelong/scenario.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "common/status.h"

namespace yamor::lifelong {
namespace {

namespace fs = std::filesystem;

const fs::path kScenarios = fs::path(YAMOR_SOURCE_DIR) / "configs" / "lifelong";

TEST(Scenario, EveryShippedScenarioLoads) {
  int count = 0;
  for (const auto& entry : fs::directory_iterator(kScenarios)) {
    if (entry.path().extension() != ".toml") continue;
    SCOPED_TRACE(entry.path().string());
    const Scenario s = Scenario::Load(entry.path().string());
    EXPECT_FALSE(s.description.empty());
    EXPECT_TRUE(fs::exists(s.config_path));
    EXPECT_TRUE(!s.world.empty() || !s.morphology_xml.empty());
    // A scenario changes something: on a schedule, or through its world
    // (table.toml: the robot walks off a table by itself).
    EXPECT_TRUE(!s.changes.empty() || s.morphology_xml.find("<box") != std::string::npos);
    ++count;
  }
  EXPECT_GE(count, 7);
}

TEST(Scenario, TheTransformationScenarioReadsItsScript) {
  const Scenario s = Scenario::Load((kScenarios / "transform.toml").string());
  EXPECT_EQ(s.world, "quadruped");
  ASSERT_EQ(s.changes.size(), 1u);
  EXPECT_EQ(s.changes[0].action, "script");
  EXPECT_DOUBLE_EQ(s.changes[0].at, 240);
  EXPECT_NE(s.changes[0].script_xml.find("<script>"), std::string::npos);
  ASSERT_FALSE(s.options.empty());
  EXPECT_EQ(s.options[0].first, "max-time");
}

class ScenarioFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("scenario_test_" + std::to_string(getpid()));
    fs::create_directories(dir_);
    std::ofstream(dir_ / "gait.xml") << "<yamorconfig/>";
  }
  void TearDown() override { fs::remove_all(dir_); }
  // The error of loading `text`, or "" when it loads.
  std::string Error(const std::string& text, StatusCode* code = nullptr) {
    const fs::path path = dir_ / "s.toml";
    std::ofstream(path) << text;
    try {
      Scenario::Load(path.string());
    } catch (const yamor::Error& e) {
      if (code) *code = e.code();
      return e.what();
    }
    return "";
  }
  fs::path dir_;
};

TEST_F(ScenarioFileTest, ChangesAreSortedByTime) {
  const fs::path path = dir_ / "s.toml";
  std::ofstream(path) << "config = \"gait.xml\"\nworld = \"quadruped\"\n"
                         "[[change]]\nat = 50\ndo = \"upside_down\"\n"
                         "[[change]]\nat = 10\ndo = \"ground\"\nfriction = 0.1\n";
  const Scenario s = Scenario::Load(path.string());
  ASSERT_EQ(s.changes.size(), 2u);
  EXPECT_EQ(s.changes[0].action, "ground");
  EXPECT_EQ(*s.changes[0].friction, 0.1);
  EXPECT_EQ(s.changes[0].Describe(), "ground friction 0.1");
  EXPECT_EQ(s.changes[1].line, 3);
}

TEST_F(ScenarioFileTest, MistakesNameTheFileLineAndKey) {
  const std::string head = "config = \"gait.xml\"\n";
  StatusCode code = StatusCode::kOk;
  std::string e = Error(head + "[[change]]\nat = 5\ndo = \"explode\"\n", &code);
  EXPECT_EQ(code, StatusCode::kInvalidArgument);
  EXPECT_NE(e.find("s.toml:4"), std::string::npos) << e;
  EXPECT_NE(e.find("explode"), std::string::npos) << e;
  e = Error(head + "[[change]]\nat = 5\ndo = \"motor_defect\"\nmodule = 3\n");
  EXPECT_NE(e.find("needs defect"), std::string::npos) << e;
  e = Error(head + "[[change]]\nat = 5\ndo = \"motor_defect\"\nmodule = 300\ndefect = \"limp\"\n");
  EXPECT_NE(e.find("0..254"), std::string::npos) << e;
  // Floats are refused before toml++ converts them (out of int64's range
  // its conversion is undefined behaviour).
  e = Error(head + "[[change]]\nat = 5\ndo = \"motor_defect\"\nmodule = 9.3e19\ndefect = \"limp\"\n");
  EXPECT_NE(e.find("0..254"), std::string::npos) << e;
  e = Error(head + "seed = 9.3e19\n");
  EXPECT_NE(e.find("seed must be an integer >= 0"), std::string::npos) << e;
  e = Error(head + "[[change]]\nat = 5\ndo = \"ground\"\nfrition = 0.1\n");
  EXPECT_NE(e.find("ground change without"), std::string::npos) << e;
  e = Error(head + "[[change]]\nat = 5\ndo = \"upside_down\"\nmodule = 1\n");
  EXPECT_NE(e.find("unknown key 'module'"), std::string::npos) << e;
  e = Error(head + "[[change]]\ndo = \"upside_down\"\n");
  EXPECT_NE(e.find("without at"), std::string::npos) << e;
  e = Error(head + "wrld = \"x\"\n");
  EXPECT_NE(e.find("unknown key 'wrld'"), std::string::npos) << e;
  e = Error("world = \"quadruped\"\n");
  EXPECT_NE(e.find("no config"), std::string::npos) << e;
  e = Error("config = \"missing.xml\"\n", &code);
  EXPECT_EQ(code, StatusCode::kNotFound);
  e = Error(head + "[[change]]\nat = 5\ndo = \"script\"\nfile = \"none.xml\"\n", &code);
  EXPECT_EQ(code, StatusCode::kNotFound);
  e = Error(head + "this is = not toml = at all\n", &code);
  EXPECT_EQ(code, StatusCode::kInvalidArgument);
  EXPECT_NE(e.find("s.toml:"), std::string::npos) << e;
}

}  // namespace
}  // namespace yamor::lifelong
