// host_bench: what yamord costs over bare gRPC, in one run (issue 4).
//
// Starts, in this process, yamord-equivalent servers (HostServer over a
// RobotDriver with the default quadruped simulation open and connected, as
// `yamord` with no settings) and a bare gRPC echo service built with the same
// ServerBuilder settings, all on 127.0.0.1:0, and measures over real TCP
// loopback channels:
//   1. unary latency p50/p99 of GetModuleAmplitude, SetModuleAmplitude and
//      Echo (one sequential client, N calls per repetition, medians over the
//      repetitions), and Get/Set p50 relative to Echo's (target Get ≤ 1.5×);
//   2. Evaluate throughput (evaluations/s) of short quadruped evaluations on
//      a daemon with 1 worker and one with 2 (target 2 workers ≥ 1.8×).
// Prints a table, with /proc/loadavg and the CPU other processes used, since
// the host is shared. Not a Google Benchmark program: `--benchmark_*` flags
// (from tools/bench/run.sh) are accepted and ignored.
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <functional>
#include <iostream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/grpcpp.h>
#include <grpcpp/health_check_service_interface.h>
#include <grpcpp/resource_quota.h>

#include "common/log.h"
#include "common/status.h"
#include "host/builtin_robots.h"
#include "host/driver.h"
#include "host/evaluator.h"
#include "host/service.h"
#include "host/worker_pool.h"
#include "host/worlds.h"
#include "host_bench_echo.grpc.pb.h"
#include "optimizer-plugins/framework/host_rpc.h"
#include "yamor/v1/host.grpc.pb.h"

namespace yamor::bench {
namespace {

namespace v1 = yamor::v1;
using Clock = std::chrono::steady_clock;

/// What to run (flags).
struct BenchOptions {
  int calls = 2000;          ///< Timed calls per RPC per repetition.
  int warmup_calls = 200;    ///< Untimed calls per RPC before the first repetition.
  int latency_reps = 5;      ///< Latency repetitions.
  int evaluations = 8;       ///< Evaluate calls per throughput repetition.
  int eval_reps = 5;         ///< Throughput repetitions (per worker count).
  double eval_warmup = 1.0;  ///< Evaluate warm-up [s simulated].
  double eval_duration = 2.0;  ///< Evaluate measured span [s simulated].
  int module = 0;            ///< Module whose amplitude is read and written.
};

/// The bare baseline: returns its request.
/// Thread-safety: stateless.
class EchoService final : public Echo::Service {
 public:
  grpc::Status Echo(grpc::ServerContext*, const EchoMessage* request,
                    EchoMessage* response) override {
    *response = *request;
    return grpc::Status::OK;
  }
};

/// The echo service on 127.0.0.1:0, built like HostServer builds yamord's
/// server (health, reflection, the same thread quota) so the two differ only
/// in the service behind them.
/// Thread-safety: as grpc::Server.
class EchoServer {
 public:
  explicit EchoServer(unsigned max_concurrent_calls) {
    grpc::EnableDefaultHealthCheckService(true);
    grpc::reflection::InitProtoReflectionServerBuilderPlugin();
    grpc::ServerBuilder builder;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port_);
    builder.RegisterService(&service_);
    grpc::ResourceQuota quota("host_bench_echo");
    quota.SetMaxThreads(static_cast<int>(max_concurrent_calls) + 16);
    builder.SetResourceQuota(quota);
    server_ = builder.BuildAndStart();
    if (!server_ || port_ == 0) throw std::runtime_error("echo server: cannot listen");
  }
  ~EchoServer() {
    server_->Shutdown(std::chrono::system_clock::now());
    server_->Wait();
  }
  EchoServer(const EchoServer&) = delete;
  EchoServer& operator=(const EchoServer&) = delete;

  /// The bound port.
  int port() const { return port_; }

 private:
  EchoService service_;
  std::unique_ptr<grpc::Server> server_;
  int port_ = 0;
};

/// An in-process yamord: the default world (the quadruped) open with its
/// built-in configuration, `workers` Evaluate workers, served on 127.0.0.1:0,
/// and connected over the API (ConnectRobot) like a client's session.
/// Thread-safety: as HostServer.
class Daemon {
 public:
  explicit Daemon(unsigned workers) : pool_(workers) {
    host::ResolvedWorld world =
        host::ResolveWorld(host::WorldRequest{}, host::kDefaultWorld, /*allow_files=*/false);
    if (!world.config) throw std::runtime_error("the default world has no built-in configuration");
    auto morphology = std::make_shared<const physics::Morphology>(world.morphology);
    driver_ = std::make_unique<host::RobotDriver>(host::DriverOptions{}, *world.config);
    driver_->OpenSimulation(host::SimulationSpec{.morphology = std::move(world.morphology),
                                                 .world_name = world.name});
    server_ = std::make_unique<host::HostServer>(
        *driver_, pool_,
        host::ServerOptions{.listen = "127.0.0.1:0",
                            .service = {.default_world = world.name,
                                        .default_morphology = morphology}});
    stub_ = v1::Host::NewStub(yamor::client::MakeChannel("127.0.0.1:" + std::to_string(server_->port())));
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
    v1::ConnectRobotResponse connected;
    Check(stub_->ConnectRobot(&context, v1::ConnectRobotRequest(), &connected), "ConnectRobot");
  }
  ~Daemon() {
    server_->Shutdown(std::chrono::seconds(2));
    pool_.Shutdown();
  }
  Daemon(const Daemon&) = delete;
  Daemon& operator=(const Daemon&) = delete;

  /// The bound port.
  int port() const { return server_->port(); }
  /// The worker count.
  unsigned workers() const { return pool_.size(); }
  /// The service's in-flight cap (for the echo server's quota).
  static unsigned MaxConcurrentCalls() { return host::ServiceOptions{}.max_concurrent_calls; }

  /// Throws with the RPC's name unless `status` is OK.
  static void Check(const grpc::Status& status, const std::string& what) {
    if (!status.ok()) {
      throw std::runtime_error(what + " failed: " + std::to_string(status.error_code()) + " " +
                               status.error_message());
    }
  }

 private:
  host::WorkerPool pool_;
  std::unique_ptr<host::RobotDriver> driver_;
  std::unique_ptr<host::HostServer> server_;
  std::unique_ptr<v1::Host::Stub> stub_;
};

std::shared_ptr<grpc::Channel> Connect(int port) {
  // The project's channel with default arguments for every server (the
  // echo too), as a plain client uses.
  auto channel = yamor::client::MakeChannel("127.0.0.1:" + std::to_string(port));
  if (!channel->WaitForConnected(std::chrono::system_clock::now() + std::chrono::seconds(10))) {
    throw std::runtime_error("cannot connect to 127.0.0.1:" + std::to_string(port));
  }
  return channel;
}

// Every call gets a deadline, as the project's clients set one.
void SetDeadline(grpc::ClientContext& context, int seconds) {
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(seconds));
}

/// Nearest-rank percentile (q in (0, 1]) of unsorted samples.
double Percentile(std::vector<double> samples, double q) {
  if (samples.empty()) return NAN;
  std::sort(samples.begin(), samples.end());
  const auto rank = static_cast<std::size_t>(std::ceil(q * static_cast<double>(samples.size())));
  return samples[std::max<std::size_t>(rank, 1) - 1];
}

double Median(std::vector<double> values) {
  if (values.empty()) return NAN;
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

std::string LoadAverage() {
  std::ifstream in("/proc/loadavg");
  std::string line;
  std::getline(in, line);
  return line.empty() ? "unavailable" : line;
}

/// CPU time of the whole machine (busy) and of this process, to tell how much
/// the other processes of a shared host took during a span.
struct CpuSample {
  double machine_busy = 0.0;  ///< [s] summed over cores (/proc/stat).
  double process = 0.0;       ///< [s] this process, user + system.
  Clock::time_point wall = Clock::now();

  static CpuSample Now() {
    CpuSample s;
    std::ifstream in("/proc/stat");
    std::string cpu;
    in >> cpu;
    std::vector<double> ticks;
    double t = 0;
    while (ticks.size() < 8 && in >> t) ticks.push_back(t);
    if (cpu == "cpu" && ticks.size() >= 5) {
      double total = 0;
      for (double v : ticks) total += v;
      s.machine_busy = (total - ticks[3] - ticks[4]) / static_cast<double>(sysconf(_SC_CLK_TCK));
    }
    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);
    auto seconds = [](const timeval& tv) { return tv.tv_sec + tv.tv_usec * 1e-6; };
    s.process = seconds(usage.ru_utime) + seconds(usage.ru_stime);
    s.wall = Clock::now();
    return s;
  }
};

/// CPU use over a span, in cores.
struct CpuUse {
  double process = 0.0;  ///< This process.
  double others = 0.0;   ///< Every other process on the machine.
};

CpuUse Between(const CpuSample& a, const CpuSample& b) {
  const double wall = std::chrono::duration<double>(b.wall - a.wall).count();
  if (wall <= 0) return {};
  const double process = (b.process - a.process) / wall;
  const double busy = (b.machine_busy - a.machine_busy) / wall;
  return {.process = process, .others = std::max(0.0, busy - process)};
}

// ---- Latency ----------------------------------------------------------------

/// One RPC under test: a callable doing one complete unary call.
struct LatencyCase {
  std::string name;
  std::function<grpc::Status()> call;
  std::vector<double> p50;  // [µs] one per repetition
  std::vector<double> p99;  // [µs]
  CpuUse cpu;               // over the last repetition
};

void TimeCalls(LatencyCase& c, int calls) {
  std::vector<double> micros;
  micros.reserve(static_cast<std::size_t>(calls));
  for (int i = 0; i < calls; ++i) {
    const auto start = Clock::now();
    const grpc::Status status = c.call();
    micros.push_back(std::chrono::duration<double, std::micro>(Clock::now() - start).count());
    Daemon::Check(status, c.name);
  }
  c.p50.push_back(Percentile(micros, 0.50));
  c.p99.push_back(Percentile(micros, 0.99));
}

std::vector<LatencyCase> MeasureLatency(const BenchOptions& options, int host_port,
                                        int echo_port, CpuUse* cpu) {
  auto host_channel = Connect(host_port);
  auto echo_channel = Connect(echo_port);
  auto host = v1::Host::NewStub(host_channel);
  auto echo = Echo::NewStub(echo_channel);

  v1::ModuleRequest get;
  get.set_module_id(static_cast<uint32_t>(options.module));
  // Alternate two in-range values so every Set changes the configuration.
  const double set_values[2] = {0.5, 0.6};
  auto set_count = std::make_shared<uint64_t>(0);
  // The echo carries a double's worth of bytes, as a Get's reply does.
  EchoMessage message;
  message.set_payload(std::string(sizeof(double), '\x2a'));

  std::vector<LatencyCase> cases;
  cases.push_back({.name = "Echo (baseline)", .call = [&echo, message] {
                     grpc::ClientContext context;
                     SetDeadline(context, 10);
                     EchoMessage reply;
                     return echo->Echo(&context, message, &reply);
                   }});
  cases.push_back({.name = "GetModuleAmplitude", .call = [&host, get] {
                     grpc::ClientContext context;
                     SetDeadline(context, 10);
                     v1::ValueResponse reply;
                     return host->GetModuleAmplitude(&context, get, &reply);
                   }});
  cases.push_back({.name = "SetModuleAmplitude", .call = [&host, &options, set_values, set_count] {
                     v1::SetModuleValueRequest set;
                     set.set_module_id(static_cast<uint32_t>(options.module));
                     set.set_value(set_values[(*set_count)++ % 2]);
                     grpc::ClientContext context;
                     SetDeadline(context, 10);
                     google::protobuf::Empty reply;
                     return host->SetModuleAmplitude(&context, set, &reply);
                   }});

  for (LatencyCase& c : cases) {
    for (int i = 0; i < options.warmup_calls; ++i) Daemon::Check(c.call(), c.name + " (warm-up)");
  }
  const CpuSample start = CpuSample::Now();
  for (int rep = 0; rep < options.latency_reps; ++rep) {
    // Rotate the order so no RPC always runs first (or after the same one).
    for (std::size_t k = 0; k < cases.size(); ++k) {
      TimeCalls(cases[(k + static_cast<std::size_t>(rep)) % cases.size()], options.calls);
    }
  }
  *cpu = Between(start, CpuSample::Now());
  return cases;
}

// ---- Evaluate throughput -------------------------------------------------------

/// Throughput figures of one worker count.
struct ThroughputCase {
  unsigned workers = 0;
  int clients = 0;                    // concurrent Evaluate calls in flight
  std::vector<double> rates;          // evaluations/s, one per repetition
  std::vector<double> eval_wall_ms;   // server-side wall time per evaluation
  std::vector<double> cpu_ms;         // this process's CPU time per evaluation
  std::vector<double> process_cores;  // this process's CPU use, per repetition
  std::vector<double> other_cores;    // other processes' CPU use, per repetition
  int diverged = 0;
};

// One repetition: `count` evaluations with seeds first_seed.., `clients`
// calls in flight at a time.
void RunEvaluations(const BenchOptions& options, v1::Host::Stub& stub, uint64_t first_seed,
                    ThroughputCase& result) {
  std::atomic<int> next{0};
  std::atomic<int> diverged{0};
  std::vector<std::vector<double>> walls(static_cast<std::size_t>(result.clients));
  std::vector<std::string> errors(static_cast<std::size_t>(result.clients));
  const CpuSample start = CpuSample::Now();
  std::vector<std::thread> threads;
  for (int t = 0; t < result.clients; ++t) {
    threads.emplace_back([&, t] {
      for (int i = next++; i < options.evaluations; i = next++) {
        v1::EvaluateRequest request;
        request.set_warmup(options.eval_warmup);
        request.set_duration(options.eval_duration);
        request.set_seed(first_seed + static_cast<uint64_t>(i));
        grpc::ClientContext context;
        SetDeadline(context, 600);
        v1::EvaluateResponse response;
        const grpc::Status status = stub.Evaluate(&context, request, &response);
        if (!status.ok()) {
          errors[static_cast<std::size_t>(t)] = "Evaluate failed: " +
                                                std::to_string(status.error_code()) + " " +
                                                status.error_message();
          return;
        }
        if (response.diverged()) ++diverged;
        walls[static_cast<std::size_t>(t)].push_back(1e3 * response.wall_seconds());
      }
    });
  }
  for (std::thread& t : threads) t.join();
  const CpuSample end = CpuSample::Now();
  for (const std::string& e : errors) {
    if (!e.empty()) throw std::runtime_error(e);
  }
  const double wall = std::chrono::duration<double>(end.wall - start.wall).count();
  result.rates.push_back(options.evaluations / wall);
  std::vector<double> all;
  for (const auto& w : walls) all.insert(all.end(), w.begin(), w.end());
  result.eval_wall_ms.push_back(Median(all));
  const CpuUse cpu = Between(start, end);
  result.cpu_ms.push_back(1e3 * (end.process - start.process) / options.evaluations);
  result.process_cores.push_back(cpu.process);
  result.other_cores.push_back(cpu.others);
  result.diverged += diverged;
}

std::vector<ThroughputCase> MeasureThroughput(const BenchOptions& options) {
  std::vector<std::unique_ptr<Daemon>> daemons;
  std::vector<std::unique_ptr<v1::Host::Stub>> stubs;
  std::vector<ThroughputCase> cases;
  for (unsigned workers : {1u, 2u}) {
    daemons.push_back(std::make_unique<Daemon>(workers));
    stubs.push_back(v1::Host::NewStub(Connect(daemons.back()->port())));
    // Twice the workers in flight, so a worker never waits for a client.
    cases.push_back({.workers = workers, .clients = static_cast<int>(2 * workers)});
  }
  // Warm-up: one untimed repetition per daemon (page faults, allocator, gRPC).
  for (std::size_t k = 0; k < cases.size(); ++k) {
    ThroughputCase scratch = cases[k];
    RunEvaluations(options, *stubs[k], 1'000'000, scratch);
  }
  // Alternate the worker counts (and which goes first) so a change of the
  // host's load hits both alike; every repetition evaluates the same seeds
  // for both, distinct within the repetition and across repetitions.
  for (int rep = 0; rep < options.eval_reps; ++rep) {
    for (std::size_t j = 0; j < cases.size(); ++j) {
      const std::size_t k = (j + static_cast<std::size_t>(rep)) % cases.size();
      RunEvaluations(options, *stubs[k],
                     1 + static_cast<uint64_t>(rep) * static_cast<uint64_t>(options.evaluations),
                     cases[k]);
    }
  }
  return cases;
}

// ---- Report ---------------------------------------------------------------------

std::string Fixed(double value, int decimals) {
  char text[64];
  std::snprintf(text, sizeof text, "%.*f", decimals, value);
  return text;
}

std::string Verdict(bool met) { return met ? "met" : "MISSED"; }

int Run(int argc, char** argv) {
  CLI::App app{"host_bench: yamord latency and Evaluate throughput vs a bare gRPC echo", "host_bench"};
  BenchOptions options;
  app.add_option("--calls", options.calls, "Timed calls per RPC per repetition")
      ->check(CLI::PositiveNumber);
  app.add_option("--warmup-calls", options.warmup_calls, "Untimed calls per RPC first")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--latency-reps", options.latency_reps, "Latency repetitions")
      ->check(CLI::PositiveNumber);
  app.add_option("--evaluations", options.evaluations, "Evaluate calls per repetition")
      ->check(CLI::PositiveNumber);
  app.add_option("--eval-reps", options.eval_reps, "Throughput repetitions per worker count")
      ->check(CLI::PositiveNumber);
  app.add_option("--eval-warmup", options.eval_warmup, "Evaluate warm-up [s simulated]")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--eval-duration", options.eval_duration, "Evaluate span [s simulated]")
      ->check(CLI::PositiveNumber);
  bool skip_latency = false;
  bool skip_throughput = false;
  app.add_flag("--skip-latency", skip_latency, "Only the Evaluate throughput");
  app.add_flag("--skip-throughput", skip_throughput, "Only the latencies");
  // tools/bench/run.sh passes Google Benchmark flags to every program.
  app.allow_extras();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  for (const std::string& extra : app.remaining()) {
    if (extra.rfind("--benchmark_", 0) != 0) {
      std::cerr << "host_bench: unknown argument " << extra << " (see --help)\n";
      return 2;
    }
  }
  SetLogLevel("warn");

  const unsigned cores = std::thread::hardware_concurrency();
  std::cout << "host_bench: yamord (in-process HostServer, default quadruped open and connected)"
               " vs a bare gRPC echo, unary calls over TCP 127.0.0.1, one process\n"
            << "cores: " << cores << "\n"
            << "loadavg before: " << LoadAverage() << "\n";

  bool all_met = true;
  if (!skip_latency) {
    Daemon daemon(0);  // yamord's default: one worker per core
    EchoServer echo(Daemon::MaxConcurrentCalls());
    CpuUse cpu;
    std::vector<LatencyCase> cases = MeasureLatency(options, daemon.port(), echo.port(), &cpu);
    const double echo_p50 = Median(cases[0].p50);
    const double echo_p99 = Median(cases[0].p99);
    std::cout << "\nUnary latency: one sequential client, " << options.calls << " calls x "
              << options.latency_reps << " repetitions per RPC (after " << options.warmup_calls
              << " warm-up calls); median over repetitions of each repetition's p50/p99\n";
    std::printf("%-20s %9s %9s %12s %12s  %s\n", "rpc", "p50 us", "p99 us", "p50 vs echo",
                "p99 vs echo", "p50 range over reps us");
    for (const LatencyCase& c : cases) {
      const double p50 = Median(c.p50);
      const double p99 = Median(c.p99);
      const auto [lo, hi] = std::minmax_element(c.p50.begin(), c.p50.end());
      std::printf("%-20s %9.1f %9.1f %11.2fx %11.2fx  %.1f..%.1f\n", c.name.c_str(), p50, p99,
                  p50 / echo_p50, p99 / echo_p99, *lo, *hi);
    }
    const double get_ratio = Median(cases[1].p50) / echo_p50;
    const double set_ratio = Median(cases[2].p50) / echo_p50;
    all_met = all_met && get_ratio <= 1.5;
    std::cout << "Get p50 / Echo p50 = " << Fixed(get_ratio, 2) << "x (target <= 1.5x: "
              << Verdict(get_ratio <= 1.5) << "); Set p50 / Echo p50 = " << Fixed(set_ratio, 2)
              << "x\n"
              << "CPU during the latency runs: this process " << Fixed(cpu.process, 2)
              << " cores, other processes " << Fixed(cpu.others, 2) << " cores\n";
  }

  if (!skip_throughput) {
    std::vector<ThroughputCase> cases = MeasureThroughput(options);
    std::cout << "\nEvaluate throughput: default quadruped, warm-up " << options.eval_warmup
              << " s + " << options.eval_duration << " s simulated, " << options.evaluations
              << " evaluations (distinct seeds) per repetition, " << options.eval_reps
              << " repetitions per worker count (alternated); medians. wall ms/eval: the"
                 " server's time per evaluation; CPU ms/eval: this process's CPU time over the"
                 " repetition / evaluations; cores: CPU-s per wall-s (others' = the rest of"
                 " the machine, /proc/stat)\n";
    std::printf("%-8s %8s %10s %14s %12s %14s %14s %9s\n", "workers", "clients", "evals/s",
                "wall ms/eval", "CPU ms/eval", "process cores", "others' cores", "diverged");
    for (const ThroughputCase& c : cases) {
      std::printf("%-8u %8d %10.2f %14.1f %12.1f %14.2f %14.2f %9d\n", c.workers, c.clients,
                  Median(c.rates), Median(c.eval_wall_ms), Median(c.cpu_ms),
                  Median(c.process_cores), Median(c.other_cores), c.diverged);
    }
    // Ratio per repetition (each pair ran back to back), then the median.
    std::vector<double> ratios;
    for (std::size_t r = 0; r < cases[0].rates.size(); ++r) {
      ratios.push_back(cases[1].rates[r] / cases[0].rates[r]);
    }
    const double ratio = Median(cases[1].rates) / Median(cases[0].rates);
    all_met = all_met && ratio >= 1.8;
    std::cout << "2 workers / 1 worker evaluations/s = " << Fixed(ratio, 2)
              << "x (target >= 1.8x: " << Verdict(ratio >= 1.8) << "); per-repetition ratios:";
    for (double r : ratios) std::cout << " " << Fixed(r, 2);
    std::cout << "\n";
  }
  std::cout << "\nloadavg after: " << LoadAverage() << "\n"
            << "targets: " << (all_met ? "all met" : "NOT all met") << std::endl;
  // Missed targets are a measurement, not a failure of the program.
  return 0;
}

}  // namespace
}  // namespace yamor::bench

int main(int argc, char** argv) {
  try {
    return yamor::bench::Run(argc, argv);
  } catch (const yamor::Error& e) {
    std::cerr << "host_bench: " << yamor::StatusCodeName(e.code()) << ": " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "host_bench: " << e.what() << "\n";
    return 1;
  }
}
