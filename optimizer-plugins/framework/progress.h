// What yamor-optimize shows while and after it runs: the remaining-time
// estimate of the progress line, and progress.png drawn by
// tools/plot/plot_progress.py, found in the installed layout or the source
// tree and run without a shell.
#pragma once

#include <string>
#include <vector>

namespace yamor::optimizer {

/// "42s", "3m5s", "1h2m"; "?" for a negative or non-finite number of seconds.
std::string FormatDuration(double seconds);

/// The progress line's remaining-time part, "about 1m10s left", from the
/// average rate so far; "" when nothing is done yet or the budget is spent.
/// An estimate, not a bound: the rate changes (a sequential phase at the end
/// of a run is slower than the parallel batches before it).
std::string RemainingEstimate(long long done, long long budget, double elapsed_seconds);

/// Folders searched for the plot scripts, in order: $YAMOR_PLOT_DIR when set,
/// the installed layout next to `executable` (BIN/../share/yamor/plot), and
/// `source_dir`/tools/plot (a build tree's binary).
std::vector<std::string> PlotScriptDirs(const std::string& executable, const std::string& source_dir);

/// The path of the first `dirs`/`name` that is a regular file; "" when none is.
std::string FindScript(const std::string& name, const std::vector<std::string>& dirs);

/// The Python interpreter for the plot scripts: $YAMOR_PYTHON when set, the
/// source tree's `.venv/bin/python` when it exists, else "python3" (from PATH).
std::string FindPython(const std::string& source_dir);

/// Runs `argv` (argv[0] searched in PATH when it has no '/') with
/// posix_spawnp — no shell, every argument passed as is — with stdin, stdout
/// and stderr on /dev/null, and waits for it. Returns its exit status (128 +
/// signal number when killed), or -1 when it cannot be started (`error`, when
/// not null, says why, naming argv[0]). Never throws.
int RunProgram(const std::vector<std::string>& argv, std::string* error = nullptr);

/// Draws `out_dir`/progress.png from `out_dir`/evaluations.csv with `python`
/// running `script`. Fails softly: returns false and logs a warning naming
/// what is missing (no script, no Python, matplotlib missing) instead of
/// throwing.
bool PlotProgress(const std::string& out_dir, const std::string& title, const std::string& script,
                  const std::string& python);

}  // namespace yamor::optimizer
