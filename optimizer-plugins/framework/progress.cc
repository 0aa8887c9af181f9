#include "optimizer-plugins/framework/progress.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <sstream>

#include "common/log.h"

extern char** environ;

namespace yamor::optimizer {
namespace {

namespace fs = std::filesystem;

}  // namespace

std::string FormatDuration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "?";
  const long s = std::lround(seconds);
  std::ostringstream out;
  if (s >= 3600) {
    out << s / 3600 << "h" << (s % 3600) / 60 << "m";
  } else if (s >= 60) {
    out << s / 60 << "m" << s % 60 << "s";
  } else {
    out << s << "s";
  }
  return out.str();
}

std::string RemainingEstimate(long long done, long long budget, double elapsed_seconds) {
  if (done <= 0 || budget <= done || !(elapsed_seconds > 0)) return "";
  const double rate = static_cast<double>(done) / elapsed_seconds;
  return "about " + FormatDuration(static_cast<double>(budget - done) / rate) + " left";
}

std::vector<std::string> PlotScriptDirs(const std::string& executable,
                                        const std::string& source_dir) {
  std::vector<std::string> dirs;
  if (const char* env = std::getenv("YAMOR_PLOT_DIR"); env != nullptr && *env) dirs.push_back(env);
  if (!executable.empty()) {
    dirs.push_back((fs::path(executable).parent_path() / ".." / "share" / "yamor" / "plot")
                       .lexically_normal()
                       .string());
  }
  if (!source_dir.empty()) dirs.push_back((fs::path(source_dir) / "tools" / "plot").string());
  return dirs;
}

std::string FindScript(const std::string& name, const std::vector<std::string>& dirs) {
  for (const std::string& dir : dirs) {
    const fs::path candidate = fs::path(dir) / name;
    std::error_code ec;
    if (fs::is_regular_file(candidate, ec)) return candidate.string();
  }
  return "";
}

std::string FindPython(const std::string& source_dir) {
  if (const char* env = std::getenv("YAMOR_PYTHON"); env != nullptr && *env) return env;
  if (!source_dir.empty()) {
    const fs::path venv = fs::path(source_dir) / ".venv" / "bin" / "python";
    std::error_code ec;
    if (fs::exists(venv, ec)) return venv.string();
  }
  return "python3";
}

int RunProgram(const std::vector<std::string>& argv, std::string* error) {
  const auto fail = [&](const std::string& why) {
    if (error != nullptr) *error = why;
    return -1;
  };
  if (argv.empty() || argv.front().empty()) return fail("no program to run");
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);

  posix_spawn_file_actions_t actions;
  if (posix_spawn_file_actions_init(&actions) != 0) return fail("posix_spawn_file_actions_init failed");
  for (int fd : {STDIN_FILENO, STDOUT_FILENO, STDERR_FILENO}) {
    posix_spawn_file_actions_addopen(&actions, fd, "/dev/null", fd == STDIN_FILENO ? O_RDONLY : O_WRONLY,
                                     0);
  }
  pid_t pid = 0;
  const int spawned = posix_spawnp(&pid, args[0], &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) return fail("cannot run '" + argv.front() + "': " + std::strerror(spawned));

  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) return fail("waitpid for '" + argv.front() + "': " + std::strerror(errno));
  }
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return fail("'" + argv.front() + "' ended in an unknown way");
}

bool PlotProgress(const std::string& out_dir, const std::string& title, const std::string& script,
                  const std::string& python) {
  if (script.empty()) {
    Log().warn("progress.png not drawn: plot_progress.py not found (set YAMOR_PLOT_DIR)");
    return false;
  }
  std::string error;
  const int status = RunProgram({python, script, (fs::path(out_dir) / "evaluations.csv").string(),
                                 (fs::path(out_dir) / "progress.png").string(), "--title", title},
                                &error);
  if (status < 0) {
    Log().warn("progress.png not drawn: {} (is Python installed? set YAMOR_PYTHON)", error);
    return false;
  }
  if (status != 0) {
    Log().warn("progress.png not drawn: '{}' exited with {} (is matplotlib installed? `make deps`)",
               python, status);
    return false;
  }
  return true;
}

}  // namespace yamor::optimizer
