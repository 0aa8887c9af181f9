// pool_bench: what the optimizer's host pool costs and gains (issue 5).
//
// Starts real yamord processes (one Evaluate worker each) on 127.0.0.1:0
// and measures, per repetition, with full 20-s quadruped evaluations (8 s
// warm-up + 12 s, the thesis's timing):
//   1. direct: N sequential Evaluate RPCs from a plain stub to daemon A;
//   2. pool, 1 host: the same N candidates as one HostPool batch on A;
//   3. pool, 2 hosts: the same N candidates as one batch on A and B.
// Prints medians over the repetitions: evaluations/s of each, the two-host
// speed-up (target >= 1.8x) and the dispatch overhead per evaluation (target
// < 1% of one evaluation): the time per evaluation spent outside the daemon's
// own evaluation (its reported wall_seconds) through the pool minus the same
// through direct calls. The raw wall-time difference is printed too; it
// carries the evaluations' run-to-run noise (~1-2%). Every candidate differs (a phase
// lag sweep) so no cache could help. Not a Google Benchmark program:
// `--benchmark_*` flags (from tools/bench/run.sh) are accepted and ignored.
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <grpcpp/grpcpp.h>

#include "common/log.h"
#include "optimizer-plugins/framework/host_pool.h"
#include "optimizer-plugins/framework/host_rpc.h"
#include "yamor/v1/host.grpc.pb.h"

namespace yamor::bench {
namespace {

using Clock = std::chrono::steady_clock;
using optimizer::Candidate;

double Seconds(Clock::time_point since) {
  return std::chrono::duration<double>(Clock::now() - since).count();
}

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// A yamord child process on an ephemeral port.
class Daemon {
 public:
  explicit Daemon(const std::string& yamord) {
    int fds[2];
    if (pipe(fds) != 0) throw std::runtime_error("pipe failed");
    pid_ = fork();
    if (pid_ == 0) {
      dup2(fds[1], STDOUT_FILENO);
      close(fds[0]);
      close(fds[1]);
      execl(yamord.c_str(), yamord.c_str(), "--listen", "127.0.0.1:0", "--workers", "1",
            "--log-level", "warn", static_cast<char*>(nullptr));
      _exit(127);
    }
    close(fds[1]);
    std::string line;
    const auto deadline = Clock::now() + std::chrono::seconds(60);
    while (Clock::now() < deadline && port_ == 0) {
      pollfd p{fds[0], POLLIN, 0};
      if (poll(&p, 1, 100) <= 0) continue;
      char c = 0;
      if (read(fds[0], &c, 1) != 1) break;
      if (c != '\n') {
        line.push_back(c);
        continue;
      }
      const std::string prefix = "yamord: listening on 127.0.0.1:";
      if (line.rfind(prefix, 0) == 0) port_ = std::stoi(line.substr(prefix.size()));
      line.clear();
    }
    close(fds[0]);
    if (port_ == 0) throw std::runtime_error("yamord did not start: " + yamord);
  }
  ~Daemon() {
    kill(pid_, SIGTERM);
    waitpid(pid_, nullptr, 0);
  }
  int port() const { return port_; }

 private:
  pid_t pid_ = -1;
  int port_ = 0;
};

std::vector<Candidate> Candidates(int n, int repetition) {
  std::vector<Candidate> out;
  for (int i = 0; i < n; ++i) {
    const double lag = 0.3 + 0.05 * i + 0.001 * repetition;
    out.push_back(Candidate{{{"phase.0.1", lag}, {"phase.1.0", -lag}}});
  }
  return out;
}

}  // namespace
}  // namespace yamor::bench

int main(int argc, char** argv) {
  using namespace yamor::bench;
  namespace v1 = yamor::v1;
  CLI::App app{"pool_bench: host pool throughput and dispatch overhead (issue 5)"};
  int evaluations = 8, repetitions = 5;
  app.add_option("--evaluations", evaluations, "Evaluations per case per repetition")->capture_default_str();
  app.add_option("--repetitions", repetitions, "Repetitions (medians are reported)")->capture_default_str();
  app.allow_extras();  // --benchmark_* from run.sh
  CLI11_PARSE(app, argc, argv);
  yamor::SetLogLevel("warn");

  Daemon a(YAMORD_PATH), b(YAMORD_PATH);
  const yamor::optimizer::HostAddress host_a{"127.0.0.1", a.port()}, host_b{"127.0.0.1", b.port()};
  yamor::optimizer::EvaluationSettings settings;
  settings.world = "quadruped";
  settings.warmup = 8;
  settings.duration = 12;

  auto channel = yamor::client::MakeChannel(host_a.ToString());
  auto stub = v1::Host::NewStub(channel);
  std::vector<double> direct_rate, pool1_rate, pool2_rate, overhead_share, overhead_ms, eval_ms, raw_share;
  yamor::optimizer::HostPool pool1({host_a}, settings);
  yamor::optimizer::HostPool pool2({host_a, host_b}, settings);
  for (int r = 0; r < repetitions; ++r) {
    const std::vector<Candidate> batch = Candidates(evaluations, r);
    // 1. Direct calls.
    double in_daemon = 0.0;
    auto start = Clock::now();
    for (const Candidate& c : batch) {
      v1::EvaluateRequest request;
      request.set_world(settings.world);
      request.set_warmup(settings.warmup);
      request.set_duration(settings.duration);
      for (const auto& [name, value] : c.parameters) {
        auto* p = request.add_parameters();
        p->set_name(name);
        p->set_value(value);
      }
      grpc::ClientContext context;
      context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(600));
      v1::EvaluateResponse response;
      const grpc::Status status = stub->Evaluate(&context, request, &response);
      if (!status.ok()) {
        std::cerr << "pool_bench: Evaluate failed: " << status.error_message() << "\n";
        return 1;
      }
      in_daemon += response.wall_seconds();
    }
    const double direct = Seconds(start);
    // 2. The pool with one host, 3. with two.
    start = Clock::now();
    double in_daemon_pool = 0.0;
    for (const auto& e : pool1.EvaluateBatch(batch)) in_daemon_pool += e.wall_seconds;
    const double one = Seconds(start);
    start = Clock::now();
    pool2.EvaluateBatch(batch);
    const double two = Seconds(start);

    direct_rate.push_back(evaluations / direct);
    pool1_rate.push_back(evaluations / one);
    pool2_rate.push_back(evaluations / two);
    const double per_eval = direct / evaluations;
    eval_ms.push_back(1e3 * in_daemon / evaluations);
    // Time outside the daemon's evaluation, per evaluation, pool minus direct:
    // what the pool adds, free of the evaluations' own run-to-run noise.
    const double added = ((one - in_daemon_pool) - (direct - in_daemon)) / evaluations;
    overhead_ms.push_back(1e3 * added);
    overhead_share.push_back(added / per_eval);
    raw_share.push_back((one - direct) / direct);
    std::fprintf(stderr, "pool_bench: repetition %d/%d: direct %.3f, pool(1) %.3f, pool(2) %.3f eval/s\n",
                 r + 1, repetitions, evaluations / direct, evaluations / one, evaluations / two);
  }
  double load[3] = {0, 0, 0};
  if (std::ifstream in("/proc/loadavg"); in) in >> load[0] >> load[1] >> load[2];
  const double speedup = Median(pool2_rate) / Median(pool1_rate);
  const double share = Median(overhead_share);
  std::printf("pool_bench: host pool over real yamord (1 worker each), 20-s quadruped evaluations\n");
  std::printf("  %d evaluations per case, medians over %d repetitions; load average %.2f\n",
              evaluations, repetitions, load[0]);
  std::printf("  %-36s %10.3f eval/s\n", "direct Evaluate calls, 1 daemon", Median(direct_rate));
  std::printf("  %-36s %10.3f eval/s\n", "host pool, 1 daemon", Median(pool1_rate));
  std::printf("  %-36s %10.3f eval/s\n", "host pool, 2 daemons", Median(pool2_rate));
  std::printf("  %-36s %10.2fx   (target >= 1.8x) %s\n", "2 daemons vs 1", speedup,
              speedup >= 1.8 ? "met" : "MISSED");
  std::printf("  %-36s %10.2f ms of %.0f ms = %.2f%%   (target < 1%%) %s\n",
              "dispatch overhead per evaluation", Median(overhead_ms), Median(eval_ms), 100.0 * share,
              share < 0.01 ? "met" : "MISSED");
  std::printf("  %-36s %10.2f%%   (wall time pool vs direct, evaluation noise included)\n",
              "  raw difference", 100.0 * Median(raw_share));
  return 0;
}
