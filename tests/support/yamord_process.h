// A yamord child process for end-to-end tests: started with fork/exec,
// stdout a pipe (for the "yamord: listening on HOST:PORT" line), stderr the
// test's; SIGKILLed and reaped when the object dies.
//
// Thread safety: one thread at a time.
#pragma once

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace yamor::testing {

/// A running yamord (or any program printing yamord's "listening on" line).
class YamordProcess {
 public:
  /// Runs `path` with `args` (argv[0] excluded).
  YamordProcess(const std::string& path, std::vector<std::string> args) {
    args.insert(args.begin(), path);
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    int fds[2];
    if (pipe(fds) != 0) throw std::runtime_error("pipe failed");
    pid_ = fork();
    if (pid_ == 0) {
      dup2(fds[1], STDOUT_FILENO);
      close(fds[0]);
      close(fds[1]);
      execv(path.c_str(), argv.data());
      _exit(127);
    }
    close(fds[1]);
    out_ = fds[0];
  }
  ~YamordProcess() {
    Kill();
    if (out_ >= 0) close(out_);
  }
  YamordProcess(const YamordProcess&) = delete;
  YamordProcess& operator=(const YamordProcess&) = delete;

  /// Everything printed to stdout until it closed it or `timeout` passed.
  std::string ReadAll(std::chrono::seconds timeout = std::chrono::seconds(30)) {
    std::string text;
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
      pollfd p{out_, POLLIN, 0};
      if (poll(&p, 1, 100) <= 0) continue;
      char buffer[4096];
      const ssize_t n = read(out_, buffer, sizeof buffer);
      if (n <= 0) break;
      text.append(buffer, static_cast<std::size_t>(n));
    }
    return text;
  }

  /// The next stdout line (without its newline); what came so far when the
  /// stream ends (then `*ended` is set) or `timeout` passes.
  std::string ReadLine(std::chrono::seconds timeout = std::chrono::seconds(30),
                       bool* ended = nullptr) {
    std::string line;
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
      pollfd p{out_, POLLIN, 0};
      if (poll(&p, 1, 100) <= 0) continue;
      char c = 0;
      if (read(out_, &c, 1) != 1) {
        if (ended != nullptr) *ended = true;
        break;
      }
      if (c == '\n') return line;
      line.push_back(c);
    }
    return line;
  }

  /// Waits for "yamord: listening on 127.0.0.1:PORT"; the port, 0 on failure.
  int WaitForPort(std::chrono::seconds timeout = std::chrono::seconds(30)) {
    const std::string prefix = "yamord: listening on 127.0.0.1:";
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
      const auto left = std::chrono::duration_cast<std::chrono::seconds>(
          deadline - std::chrono::steady_clock::now());
      bool ended = false;
      const std::string line = ReadLine(left + std::chrono::seconds(1), &ended);
      if (line.rfind(prefix, 0) == 0) return std::stoi(line.substr(prefix.size()));
      if (ended) return 0;
    }
    return 0;
  }

  /// The exit status after at most `timeout`; -1 if it did not exit (a hang
  /// guard, not a performance check), -2 if a signal killed it.
  int WaitForExit(std::chrono::seconds timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        return WIFEXITED(status) ? WEXITSTATUS(status) : -2;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return -1;
  }

  /// The child's process id (-1 once reaped).
  pid_t pid() const { return pid_; }

  /// Sends `signal`.
  void Signal(int signal) {
    if (pid_ > 0) kill(pid_, signal);
  }

  /// SIGKILLs and reaps it (no-op once gone).
  void Kill() {
    if (pid_ <= 0) return;
    kill(pid_, SIGKILL);
    waitpid(pid_, nullptr, 0);
    pid_ = -1;
  }

 private:
  pid_t pid_ = -1;
  int out_ = -1;
};

}  // namespace yamor::testing
