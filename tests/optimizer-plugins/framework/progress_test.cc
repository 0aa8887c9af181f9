// yamor-optimize's progress helpers: the remaining-time estimate, finding
// the plot script in an installed layout, and running programs without a
// shell.
#include "optimizer-plugins/framework/progress.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

namespace yamor::optimizer {
namespace {

namespace fs = std::filesystem;

// A fresh empty folder under the test's temporary directory.
fs::path FreshDir(const std::string& name) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("progress_test_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

TEST(ProgressLine, RemainingTimeIsLabelledAnEstimate) {
  // 100 of 300 in 50 s: about 100 s more at the same rate.
  EXPECT_EQ(RemainingEstimate(100, 300, 50.0), "about 1m40s left");
  EXPECT_EQ(RemainingEstimate(0, 300, 5.0), "") << "no rate yet";
  EXPECT_EQ(RemainingEstimate(300, 300, 50.0), "") << "budget spent";
  EXPECT_EQ(RemainingEstimate(10, 300, 0.0), "");
  EXPECT_EQ(FormatDuration(7322), "2h2m");
  EXPECT_EQ(FormatDuration(-1), "?");
}

TEST(PlotScript, TheInstalledLayoutNextToTheExecutableComesBeforeTheSourceTree) {
  const fs::path prefix = FreshDir("prefix");
  fs::create_directories(prefix / "bin");
  fs::create_directories(prefix / "share/yamor/plot");
  std::ofstream(prefix / "share/yamor/plot/plot_progress.py") << "# installed\n";
  const fs::path source = FreshDir("source");
  fs::create_directories(source / "tools/plot");
  std::ofstream(source / "tools/plot/plot_progress.py") << "# source\n";

  ::unsetenv("YAMOR_PLOT_DIR");
  const std::string exe = (prefix / "bin/yamor-optimize").string();
  EXPECT_EQ(fs::path(FindScript("plot_progress.py", PlotScriptDirs(exe, source.string()))),
            (prefix / "share/yamor/plot/plot_progress.py").lexically_normal());
  // A moved binary without an installed script falls back to the source tree.
  const fs::path elsewhere = FreshDir("elsewhere");
  EXPECT_EQ(fs::path(FindScript("plot_progress.py",
                                PlotScriptDirs((elsewhere / "yamor-optimize").string(),
                                               source.string()))),
            source / "tools/plot/plot_progress.py");
  EXPECT_EQ(FindScript("plot_progress.py", PlotScriptDirs((elsewhere / "x").string(), "")), "");
}

TEST(RunProgram, ArgumentsReachTheProgramAsIsWithoutAShell) {
  const fs::path dir = FreshDir("argv");
  // Names a shell would split or run: a quote, a space, a ';' command and '$'.
  const fs::path from = dir / "it's a file; touch pwned $(id)";
  const fs::path to = dir / "copy 'of' it";
  std::ofstream(from) << "content";
  std::string error;
  ASSERT_EQ(RunProgram({"cp", from.string(), to.string()}, &error), 0) << error;
  std::ifstream copied(to);
  std::string text;
  copied >> text;
  EXPECT_EQ(text, "content");
  EXPECT_FALSE(fs::exists("pwned"));
  EXPECT_FALSE(fs::exists(dir / "pwned"));
  EXPECT_EQ(RunProgram({"false"}), 1) << "the exit status is returned";
}

TEST(RunProgram, AMissingProgramFailsSoftly) {
  std::string error;
  EXPECT_EQ(RunProgram({"yamor-no-such-python3"}, &error), -1);
  EXPECT_NE(error.find("yamor-no-such-python3"), std::string::npos) << error;
  const fs::path dir = FreshDir("nopython");
  EXPECT_FALSE(PlotProgress(dir.string(), "t", (dir / "plot_progress.py").string(),
                            "yamor-no-such-python3"));
  EXPECT_FALSE(PlotProgress(dir.string(), "t", "", "python3")) << "no script";
  EXPECT_FALSE(fs::exists(dir / "progress.png"));
}

}  // namespace
}  // namespace yamor::optimizer
