// yamor-optimize run in-process through optimize::Run: --help and
// --list-plugins, command lines it refuses (with the exit status a script
// sees), and a short run of the random plugin against a real yamord.
#include <unistd.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "optimizer-plugins/optimize/run.h"
#include "tests/support/command_outcome.h"
#include "tests/support/yamord_process.h"

namespace yamor::optimize {
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


TEST(OptimizeRunTest, HelpAndThePluginList) {
  const CommandOutcome help = RunCommand({"--help"});
  EXPECT_EQ(help.status, 0);
  EXPECT_TRUE(Contains(help.out, "yamor-optimize")) << help.out;
  EXPECT_TRUE(Contains(help.out, "--plugin")) << help.out;
  EXPECT_TRUE(Contains(help.out, "--live")) << help.out;

  const CommandOutcome list = RunCommand({"--list-plugins"});
  EXPECT_EQ(list.status, 0) << list.out << list.err;
  EXPECT_TRUE(Contains(list.out, "random")) << list.out;
  EXPECT_TRUE(Contains(list.out, "--set max_evaluations=")) << list.out;
}

TEST(OptimizeRunTest, RefusedCommandLinesSayWhy) {
  const CommandOutcome unknown = RunCommand({"--no-such-option"});
  EXPECT_NE(unknown.status, 0);
  EXPECT_TRUE(Contains(unknown.err, "--no-such-option")) << unknown.err;

  const CommandOutcome no_plugin = RunCommand({"--config", "x.xml", "--out", "o"});
  EXPECT_EQ(no_plugin.status, 2);
  EXPECT_TRUE(Contains(no_plugin.err, "--plugin is required")) << no_plugin.err;

  const CommandOutcome mixed = RunCommand({"--plugin", "random", "--config", "x.xml", "--out", "o", "--live",
                                    "127.0.0.1:1", "--world", "quadruped"});
  EXPECT_EQ(mixed.status, 2);
  EXPECT_TRUE(Contains(mixed.err, "--world cannot be combined with --live")) << mixed.err;

  const CommandOutcome size = RunCommand({"--plugin", "random", "--config", "x.xml", "--out", "o",
                                   "--video-size", "big"});
  EXPECT_EQ(size.status, 2);
  EXPECT_TRUE(Contains(size.err, "expected WIDTHxHEIGHT")) << size.err;

  const CommandOutcome missing = RunCommand({"--plugin", "random", "--config", "/nonexistent/c.xml",
                                      "--out", "o"});
  EXPECT_EQ(missing.status, 2) << missing.err;
  EXPECT_TRUE(Contains(missing.err, "/nonexistent/c.xml")) << missing.err;
}

TEST(OptimizeRunTest, AShortRunAgainstAYamordWritesItsResults) {
  ::yamor::testing::YamordProcess daemon(
      YAMORD_PATH, {"--listen", "127.0.0.1:0", "--log-level", "warn", "--workers", "2"});
  const int port = daemon.WaitForPort();
  ASSERT_GT(port, 0) << "yamord did not start";
  const fs::path dir = fs::temp_directory_path() / ("optimize_run_" + std::to_string(getpid()));
  fs::remove_all(dir);
  const CommandOutcome run = RunCommand(
      {"--plugin", "random", "--config", kSource + "/configs/optimize/quadruped-2.xml", "--world",
       "quadruped", "--hosts", "127.0.0.1:" + std::to_string(port), "--warmup", "1", "--duration",
       "1", "--set", "max_evaluations=3", "--out", dir.string(), "--no-plot", "--no-video",
       "--quiet", "--log-level", "warn"});
  EXPECT_EQ(run.status, 0) << run.out << run.err;
  EXPECT_TRUE(Contains(run.out, "after 3 evaluations")) << run.out;
  EXPECT_TRUE(Contains(run.out, "best velocity")) << run.out;
  EXPECT_TRUE(fs::exists(dir / "evaluations.csv"));
  EXPECT_TRUE(fs::exists(dir / "best.xml"));
  if (!::testing::Test::HasFailure()) fs::remove_all(dir);
}

}  // namespace
}  // namespace yamor::optimize
