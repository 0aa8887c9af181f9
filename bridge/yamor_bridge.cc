// yamor-bridge: one emulated YaMoR robot served over a pseudo-terminal or TCP,
// speaking SNP exactly as the real robot's master module does on its serial
// line (the successor of the thesis's Webots Bridge, 5.4).
//
//   yamor-bridge --pty --link /tmp/yamor0       # prints "yamor-bridge: pty /dev/pts/N"
//   yamor-bridge --tcp 2223                     # prints "yamor-bridge: tcp 127.0.0.1:2223"
//   yamor-bridge --tcp 0.0.0.0:2223 --world snake --pace --baud 115200
//   yamor-bridge --pty --real-time 1            # the world free-runs at wall-clock speed
//   yamor-bridge --replay session.rec [--world quadruped] [--csv gap.csv]
//
// --replay FILE replays a recording of `yamord --record` (docs/snp.md,
// "Recorded sessions") into a fresh simulation and prints, per second of
// simulated time, the simulated central-module position next to the recorded
// position samples, then the mean and max difference; it serves nothing.
//
// SIGTERM / SIGINT: exit 0. Bad flags: exit 2.
#include <signal.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <set>
#include <string>

#include <CLI/CLI.hpp>

#include "bridge/bridge_server.h"
#include "bridge/bridge_transport.h"
#include "bridge/replay.h"
#include "common/log.h"
#include "common/status.h"
#include "physics/morphology.h"

namespace {

using namespace yamor;
using namespace yamor::bridge;

constexpr int kUsageExitCode = 2;

// A world name: a morphology file path as given, else <worlds_dir>/<name>.xml.
// (yamord resolves names from copies compiled into host/; the bridge reads
// the same configs/worlds files.)
physics::Morphology LoadWorld(const std::string& world, const std::filesystem::path& worlds_dir) {
  if (world.find('/') != std::string::npos || std::filesystem::is_regular_file(world)) {
    return physics::Morphology::LoadFile(world);
  }
  const std::filesystem::path file = worlds_dir / (world + ".xml");
  if (std::filesystem::is_regular_file(file)) return physics::Morphology::LoadFile(file);
  std::set<std::string> names;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(worlds_dir, ec)) {
    if (entry.path().extension() == ".xml") names.insert(entry.path().stem().string());
  }
  std::string known;
  for (const std::string& name : names) known += (known.empty() ? "" : ", ") + name;
  throw Error(StatusCode::kNotFound,
              "unknown world '" + world + "' (not a file, no " + file.string() + ")" +
                  (known.empty() ? "" : "; worlds in " + worlds_dir.string() + ": " + known));
}

int Run(int argc, char** argv) {
  CLI::App app{"yamor-bridge: an emulated YaMoR robot speaking SNP over a pty or TCP",
               "yamor-bridge"};
  std::string world = "quadruped";
  std::string worlds_dir = YAMOR_WORLDS_DIR;
  std::string tcp;
  std::string log_level = "info";
  TransportOptions transport_options;
  RobotOptions robot_options;
  uint64_t seed = 0;
  int master = 0;
  double time_step = robot_options.world.time_step;

  bool pty = false;
  auto* pty_flag = app.add_flag("--pty", pty, "Serve on a new pseudo-terminal (the default)");
  auto* tcp_option =
      app.add_option("--tcp", tcp, "Serve on TCP [HOST:]PORT (default 127.0.0.1:2223; port 0: pick one)")
          ->expected(0, 1);
  app.add_option("--link", transport_options.link,
                 "Pty: make this symlink to the slave device (replaces a stale symlink)")
      ->excludes(tcp_option);
  pty_flag->excludes(tcp_option);
  auto* world_option =
      app.add_option("--world", world, "World name (in --worlds-dir) or morphology file");
  app.add_option("--morphology", world, "Morphology XML file")->excludes(world_option);
  app.add_option("--worlds-dir", worlds_dir, "Where world names are looked up");
  app.add_flag("--pace", transport_options.pace,
               "Pace outgoing bytes at --baud as 8N1 (baud/10 bytes per second)");
  app.add_option("--baud", transport_options.baud, "Line rate for --pace [bit/s]")
      ->check(CLI::Range(50, 4000000));
  app.add_option("--real-time", transport_options.real_time_factor,
                 "Free-run the world at this real-time factor (default: only Step advances time)")
      ->check(CLI::Range(0.0, 100.0));
  app.add_option("--seed", seed, "Seed of the world and of the oscillators' initial phases");
  auto* master_option =
      app.add_option("--master", master, "Master node (default: the central module)")
          ->check(CLI::Range(0, 254));
  app.add_option("--time-step", time_step, "Physics step [s]")->check(CLI::Range(1e-5, 0.1));
  app.add_option("--log-level", log_level, "trace, debug, info, warn, error, critical, off");
  std::string replay_file;
  std::string csv_file;
  double row_period = 1.0;
  auto* replay_option = app.add_option(
      "--replay", replay_file,
      "Replay a yamord --record FILE into a simulation and compare positions (serves nothing)");
  replay_option->excludes(tcp_option)->excludes(pty_flag);
  app.add_option("--csv", csv_file, "With --replay: write the table as CSV to FILE ('-': stdout)")
      ->needs(replay_option);
  app.add_option("--row-period", row_period,
                 "With --replay: simulated seconds between table rows")
      ->needs(replay_option)
      ->check(CLI::Range(1e-3, 3600.0));
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return kUsageExitCode;
  }
  try {
    if (tcp_option->count()) {
      transport_options.kind = TransportOptions::Kind::kTcp;
      ParseTcpEndpoint(tcp, transport_options);
    }
    SetLogLevel(log_level);
  } catch (const Error& e) {
    std::cerr << "yamor-bridge: " << e.what() << "\nRun with --help for more information.\n";
    return kUsageExitCode;
  }

  if (replay_option->count()) {
    // Flags given override what the recording says; the rest comes from it.
    const snp::Recording recording = snp::LoadRecordingFile(replay_file);
    ReplayOptions replay_options;
    replay_options.load_world = [&worlds_dir](const std::string& name) {
      return LoadWorld(name, worlds_dir);
    };
    if (world_option->count() || app.count("--morphology")) replay_options.world = world;
    if (app.count("--seed")) replay_options.seed = seed;
    if (app.count("--time-step")) replay_options.time_step = time_step;
    if (master_option->count()) replay_options.master = master;
    replay_options.row_period = row_period;
    const ReplayResult result = Replay(recording, replay_options);
    if (csv_file == "-") {
      std::cout << FormatReplayCsv(result);
    } else {
      if (!csv_file.empty()) {
        std::ofstream csv(csv_file);
        csv << FormatReplayCsv(result);
        if (!csv.flush()) throw Error(StatusCode::kNotFound, "cannot write " + csv_file);
      }
      std::cout << FormatReplayReport(result);
    }
    if (recording.torn_lines > 0) {
      std::cerr << "yamor-bridge: " << replay_file << ": skipped a torn last line\n";
    }
    return 0;
  }

  robot_options.world.seed = seed;
  robot_options.phase_seed = seed;
  robot_options.world.time_step = time_step;
  if (master_option->count()) robot_options.master = master;
  physics::Morphology morphology = LoadWorld(world, worlds_dir);
  const std::string source = morphology.source();
  BridgeServer server(std::move(morphology), robot_options);
  BridgeTransport transport(server, transport_options);
  std::cout << "yamor-bridge: " << transport.Endpoint() << std::endl;
  Log().info("yamor-bridge serving {} on {} ({}, {})", source, transport.Endpoint(),
             transport_options.pace
                 ? "paced at " + std::to_string(transport_options.baud) + " baud"
                 : std::string("unpaced"),
             transport_options.real_time_factor > 0.0
                 ? "free-running at " + std::to_string(transport_options.real_time_factor) +
                       "x real time"
                 : std::string("stepped by the host"));
  const int stopped_by = transport.Run(/*stop_on_signals=*/true);
  const BridgeStats stats = server.stats();
  Log().info(
      "yamor-bridge stopped ({}): {} bytes in, {} frames, {} bytes skipped, {} bytes out, "
      "t = {} s",
      stopped_by ? strsignal(stopped_by) : "stopped", stats.decoder.bytes_fed,
      stats.decoder.frames, stats.decoder.skipped_bytes, stats.bytes_out, server.Time());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return Run(argc, argv);
  } catch (const yamor::Error& e) {
    std::cerr << "yamor-bridge: " << yamor::StatusCodeName(e.code()) << ": " << e.what() << "\n";
    return kUsageExitCode;
  } catch (const std::exception& e) {
    std::cerr << "yamor-bridge: " << e.what() << "\n";
    return 1;
  }
}
