// yamor-lifelong run in-process through lifelong::Run: --help, command lines
// it refuses (with the exit status a script sees), and a short life on a
// real yamord that ends at --max-time with its files written.
#include <unistd.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "optimizer-plugins/lifelong/run.h"
#include "tests/support/command_outcome.h"
#include "tests/support/yamord_process.h"

namespace yamor::lifelong {
namespace {

namespace fs = std::filesystem;

const std::string kSource = YAMOR_SOURCE_DIR;

using ::yamor::testing::CommandOutcome;
using ::yamor::testing::Contains;

CommandOutcome RunCommand(const std::vector<std::string>& args) {
  return ::yamor::testing::RunInProcess(
      [](const std::vector<std::string>& a, std::ostream& out, std::ostream& err) { return Run(a, out, err); },
      args);
}


class LifelongRunTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("lifelong_run_" + std::to_string(getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    if (!HasFailure()) fs::remove_all(dir_);
  }
  fs::path dir_;
};

TEST_F(LifelongRunTest, Help) {
  const CommandOutcome help = RunCommand({"--help"});
  EXPECT_EQ(help.status, 0);
  EXPECT_TRUE(Contains(help.out, "yamor-lifelong")) << help.out;
  EXPECT_TRUE(Contains(help.out, "--scenario")) << help.out;
}

TEST_F(LifelongRunTest, RefusedCommandLinesSayWhy) {
  const CommandOutcome no_out = RunCommand({"--config", "c.xml"});
  EXPECT_NE(no_out.status, 0);
  EXPECT_TRUE(Contains(no_out.err, "--out")) << no_out.err;

  const CommandOutcome no_config = RunCommand({"--out", (dir_ / "o").string()});
  EXPECT_EQ(no_config.status, 2);
  EXPECT_TRUE(Contains(no_config.err, "--config (or --scenario) is required")) << no_config.err;

  const CommandOutcome two = RunCommand({"--out", (dir_ / "o").string(), "--config",
                                  kSource + "/configs/lifelong/quadruped-walking.xml", "--host",
                                  "127.0.0.1:1,127.0.0.1:2"});
  EXPECT_EQ(two.status, 2);
  EXPECT_TRUE(Contains(two.err, "--host takes one daemon")) << two.err;

  const CommandOutcome scenario = RunCommand({"--out", (dir_ / "o").string(), "--scenario", "/nonexistent/s.toml"});
  EXPECT_EQ(scenario.status, 2);
  EXPECT_TRUE(Contains(scenario.err, "/nonexistent/s.toml")) << scenario.err;
}

TEST_F(LifelongRunTest, AShortLifeEndsAtItsTimeLimit) {
  ::yamor::testing::YamordProcess daemon(
      YAMORD_PATH, {"--listen", "127.0.0.1:0", "--log-level", "warn", "--workers", "1"});
  const int port = daemon.WaitForPort();
  ASSERT_GT(port, 0) << "yamord did not start";
  const fs::path scenario = dir_ / "walk.toml";
  std::ofstream(scenario) << "config = \"" << kSource
                          << "/configs/lifelong/quadruped-walking.xml\"\nseed = 1\nworld = \"quadruped\"\n";
  const fs::path out = dir_ / "life";
  const CommandOutcome life = RunCommand({"--host", "127.0.0.1:" + std::to_string(port), "--scenario",
                                   scenario.string(), "--out", out.string(), "--max-time", "6",
                                   "--window-periods", "2", "--no-plot", "--no-frames", "--quiet",
                                   "--log-level", "warn"});
  EXPECT_EQ(life.status, 0) << life.out << life.err;
  EXPECT_TRUE(Contains(life.out, "timeline:")) << life.out;
  EXPECT_TRUE(fs::exists(out / "timeline.csv"));
  EXPECT_TRUE(fs::exists(out / "events.jsonl"));
  EXPECT_TRUE(fs::exists(out / "gaits.sqlite"));
}

}  // namespace
}  // namespace yamor::lifelong
