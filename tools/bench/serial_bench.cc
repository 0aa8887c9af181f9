// serial_bench: the cost of the one SNP path over a real link (issue 11).
// The same RobotDriver drives the quadruped in-process and through a
// SerialBackend to a yamor-bridge transport (BridgeServer + BridgeTransport,
// in this process on its own thread) on a pty — paced at 115200 baud as a
// real line, or unpaced — and on loopback TCP. Prints medians over --runs
// runs and ratios against the in-process backend measured in the same run:
//   * a Set + Flush round trip (one SetOscillator, its Ack);
//   * a Get round trip (ReadServoAngle, its ServoAngle);
//   * paced throughput: morphology readback (large MorphologyChunk replies)
//     in bytes per second as a fraction of the line rate (baud / 10);
//   * the thesis session (connect, control on, flush, 20 s of virtual time,
//     position) in wall time.
// A plain program (tools/bench/run.sh's plain_programs).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>

#include "bridge/bridge_server.h"
#include "bridge/bridge_transport.h"
#include "common/log.h"
#include "host/driver.h"
#include "host/serial_backend.h"
#include "host/worlds.h"

namespace {

using namespace yamor;
using namespace yamor::host;
using Clock = std::chrono::steady_clock;

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

double SecondsSince(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

ResolvedWorld Quadruped() {
  return ResolveWorld(WorldRequest{.world = "quadruped"}, "quadruped", false);
}

// One way to reach the robot: a driver over the in-process backend, or over
// a SerialBackend to a bridge transport served on a thread of its own.
class Link {
 public:
  enum class Kind { kInProcess, kPtyPaced, kPtyUnpaced, kTcp };

  Link(Kind kind, int baud) {
    ResolvedWorld world = Quadruped();
    driver_ = std::make_unique<RobotDriver>(DriverOptions{}, *world.config);
    if (kind == Kind::kInProcess) {
      driver_->OpenSimulation(SimulationSpec{.morphology = std::move(world.morphology),
                                             .world_name = "quadruped"});
      return;
    }
    server_ = std::make_unique<bridge::BridgeServer>(std::move(world.morphology));
    bridge::TransportOptions options;
    options.kind = kind == Kind::kTcp ? bridge::TransportOptions::Kind::kTcp
                                      : bridge::TransportOptions::Kind::kPty;
    options.tcp_port = 0;
    options.pace = kind == Kind::kPtyPaced;
    options.baud = baud;
    transport_ = std::make_unique<bridge::BridgeTransport>(*server_, options);
    serve_ = std::thread([this] { transport_->Run(/*stop_on_signals=*/false); });
    SerialOptions serial;
    serial.device = kind == Kind::kTcp ? "tcp://127.0.0.1:" + std::to_string(transport_->Port())
                                       : transport_->SlavePath();
    serial.baud = baud;
    auto backend = std::make_unique<SerialBackend>(serial);
    serial_ = backend.get();
    driver_->AttachBackend(std::move(backend), serial.device);
  }
  ~Link() {
    driver_.reset();
    if (transport_) {
      transport_->Stop();
      serve_.join();
    }
  }
  RobotDriver& driver() { return *driver_; }
  // Bytes received by the host so far (0 in-process: no line).
  uint64_t BytesIn() const { return serial_ ? serial_->stats().bytes_in : 0; }

 private:
  std::unique_ptr<bridge::BridgeServer> server_;
  std::unique_ptr<bridge::BridgeTransport> transport_;
  std::thread serve_;
  SerialBackend* serial_ = nullptr;  // owned by the driver
  std::unique_ptr<RobotDriver> driver_;
};

const char* Name(Link::Kind kind) {
  switch (kind) {
    case Link::Kind::kInProcess: return "in-process";
    case Link::Kind::kPtyPaced: return "pty, paced";
    case Link::Kind::kPtyUnpaced: return "pty, unpaced";
    case Link::Kind::kTcp: return "tcp";
  }
  return "?";
}

// Seconds per Set + Flush round trip.
double SetFlush(RobotDriver& driver, int calls) {
  const Clock::time_point start = Clock::now();
  for (int i = 0; i < calls; ++i) {
    driver.SetModuleValue(1, ModuleField::kAmplitude, 0.3 + 0.001 * (i % 100));
    driver.Flush();
  }
  return SecondsSince(start) / calls;
}

// Seconds per servo-angle read.
double Get(RobotDriver& driver, int calls) {
  const Clock::time_point start = Clock::now();
  for (int i = 0; i < calls; ++i) driver.GetServoAngles({1});
  return SecondsSince(start) / calls;
}

// Wall seconds of the thesis session on a fresh robot.
double ThesisSession(RobotDriver& driver) {
  const Clock::time_point start = Clock::now();
  driver.ConnectRobot(0.0, false, nullptr);
  driver.SendControlMessage(ControlMessage{.uart = snp::Tristate::kOn,
                                           .cpg = snp::Tristate::kOn,
                                           .motors = snp::Tristate::kOn,
                                           .all = true});
  for (int hip = 0; hip < 4; ++hip) driver.SetModuleValue(hip, ModuleField::kSpeed, 0.35);
  driver.Flush();
  driver.Sleep(20.0, false, nullptr);
  driver.RobotPosition();
  return SecondsSince(start);
}

int Run(int argc, char** argv) {
  CLI::App app{"serial_bench: the SNP path over a pty and TCP against in-process"};
  int runs = 5;
  int calls = 200;
  int baud = 115200;
  app.add_option("--runs", runs, "Runs per figure (medians)")->check(CLI::Range(1, 100));
  app.add_option("--calls", calls, "Round trips per run")->check(CLI::Range(1, 100000));
  app.add_option("--baud", baud, "Line rate of the paced pty [bit/s]");
  CLI11_PARSE(app, argc, argv);
  SetLogLevel("warn");

  const std::vector<Link::Kind> kinds = {Link::Kind::kInProcess, Link::Kind::kPtyPaced,
                                         Link::Kind::kPtyUnpaced, Link::Kind::kTcp};
  std::vector<std::vector<double>> set_flush(kinds.size()), get(kinds.size()),
      session(kinds.size());
  std::vector<double> throughput;
  for (int run = 0; run < runs; ++run) {
    for (std::size_t k = 0; k < kinds.size(); ++k) {
      {
        Link link(kinds[k], baud);
        link.driver().ConnectRobot(0.0, false, nullptr);
        set_flush[k].push_back(SetFlush(link.driver(), calls));
        get[k].push_back(Get(link.driver(), calls));
        if (kinds[k] == Link::Kind::kPtyPaced) {
          const uint64_t before = link.BytesIn();
          const Clock::time_point start = Clock::now();
          for (int i = 0; i < 3; ++i) link.driver().GetMorphology();
          const double seconds = SecondsSince(start);
          throughput.push_back(static_cast<double>(link.BytesIn() - before) / seconds /
                               (baud / 10.0));
        }
      }
      if (kinds[k] == Link::Kind::kPtyPaced) continue;  // a paced 20-s session is line-bound
      Link fresh(kinds[k], baud);
      session[k].push_back(ThesisSession(fresh.driver()));
    }
  }

  std::printf("serial_bench: quadruped, %d runs x %d round trips, paced pty at %d baud "
              "(medians; ratio = / in-process of the same run)\n",
              runs, calls, baud);
  std::printf("%-14s %14s %8s %14s %8s %16s %8s\n", "link", "set+flush [ms]", "ratio",
              "get [ms]", "ratio", "20-s session [s]", "ratio");
  for (std::size_t k = 0; k < kinds.size(); ++k) {
    const double sf = Median(set_flush[k]) * 1e3, g = Median(get[k]) * 1e3;
    const double sf0 = Median(set_flush[0]) * 1e3, g0 = Median(get[0]) * 1e3;
    if (session[k].empty()) {
      std::printf("%-14s %14.3f %8.1f %14.3f %8.1f %16s %8s\n", Name(kinds[k]), sf, sf / sf0, g,
                  g / g0, "-", "-");
    } else {
      const double s = Median(session[k]), s0 = Median(session[0]);
      std::printf("%-14s %14.3f %8.1f %14.3f %8.1f %16.3f %8.2f\n", Name(kinds[k]), sf, sf / sf0,
                  g, g / g0, s, s / s0);
    }
  }
  std::printf("paced throughput (morphology readback): %.1f %% of the line rate (%d B/s)\n",
              100.0 * Median(throughput), baud / 10);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return Run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "serial_bench: %s\n", e.what());
    return 1;
  }
}
