// yamord: the YaMoR host daemon. Drives one robot (the simulated quadruped
// unless told otherwise) and serves the yamor.v1.Host gRPC API, plus
// grpc.health.v1 and server reflection.
//
//   yamord                                  # quadruped on 127.0.0.1:2224
//   yamord --listen 127.0.0.1:0 --world snake
//   yamord --settings /etc/yamor/yamord.toml --print-config
//   yamord --backend serial --device /dev/rfcomm0          # a real robot
//   yamord --backend serial --device tcp://simhost:2223    # yamor-bridge --tcp
//   yamord --record session.rec             # every SNP frame both ways, timed
//                                           # (docs/snp.md "Recorded sessions";
//                                           # replay: yamor-bridge --replay)
//
// SIGTERM / SIGINT: stop accepting calls, cancel long Sleeps and Evaluates,
// drain in-flight calls (up to --drain-seconds), exit 0.
#include <pthread.h>
#include <signal.h>

#include <charconv>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>

#include "common/log.h"
#include "common/status.h"
#include "cpg/config_xml.h"
#include "host/builtin_robots.h"
#include "host/driver.h"
#include "host/evaluator.h"
#include "host/id_map.h"
#include "host/led_tracker.h"
#include "host/serial_backend.h"
#include "host/recording_backend.h"
#include "host/service.h"
#include "host/settings.h"
#include "host/worker_pool.h"
#include "host/worlds.h"
#include "physics/render/raster_threads.h"

namespace {

using namespace yamor;
using namespace yamor::host;

int Run(int argc, char** argv, const sigset_t& signals) {
  CLI::App app{"yamord: the YaMoR host daemon (gRPC API yamor.v1.Host)", "yamord"};
  Settings flags;
  std::string settings_file;
  int master_id = 0;
  bool print_config = false;
  double drain_seconds = 5.0;
  app.add_option("--settings", settings_file, "TOML settings file (flags override it)");
  auto* listen = app.add_option("--listen", flags.listen, "gRPC address ADDR:PORT (port 0: pick one)");
  app.footer(
      "Serial backend: --backend serial --device PATH|tcp://HOST:PORT attaches a real robot's\n"
      "master node (serial port, /dev/rfcomm0) or yamor-bridge (its pty, or --tcp) instead of\n"
      "opening a world. A device that cannot be opened at start is an error: yamord prints\n"
      "why and exits with status 2. A link lost later makes robot calls fail with\n"
      "UNAVAILABLE; the next call reopens it.\n"
      "Rendering (RenderFrame, RecordFrames, filmed Evaluate): Mesa's llvmpipe rasterises on\n"
      "the calling thread (yamord sets LP_NUM_THREADS=0 unless it is set; LP_NUM_THREADS=N\n"
      "gives each renderer N rasteriser threads). YAMOR_RENDER_BACKEND=osmesa|egl|none\n"
      "chooses the GL library.");
  auto* backend = app.add_option("--backend", flags.backend,
                                 "Robot backend: sim (in-process simulation) or serial (--device)");
  auto* device = app.add_option("--device", flags.device,
                                "Serial backend: device path (/dev/ttyUSB0, /dev/rfcomm0, "
                                "/dev/pts/N) or tcp://HOST:PORT");
  auto* baud = app.add_option("--baud", flags.baud, "Serial line rate [bit/s] (default 115200)");
  auto* data_bits = app.add_option("--data-bits", flags.data_bits, "Serial data bits, 5..8");
  auto* parity = app.add_option("--parity", flags.parity, "Serial parity: none, odd, even");
  auto* stop_bits = app.add_option("--stop-bits", flags.stop_bits, "Serial stop bits, 1 or 2");
  auto* flow = app.add_option("--flow-control", flags.flow_control,
                              "Serial flow control: none, software, hardware");
  auto* hello_timeout = app.add_option("--hello-timeout", flags.hello_timeout,
                                       "Wait for yamor-bridge's answer to the hello [s]; "
                                       "silence means a real robot");
  auto* reply_timeout = app.add_option("--reply-timeout", flags.reply_timeout,
                                       "Wait for a reply on a serial link [s]");
  auto* world = app.add_option("--world", flags.world,
                               "Built-in world name or morphology file (default quadruped)");
  auto* config = app.add_option("--config", flags.config,
                                "Robot configuration file (default: the world's built-in one)");
  auto* workers = app.add_option("--workers", flags.workers, "Evaluate workers (0 = core count)");
  auto* id_map = app.add_option("--id-map", flags.id_map, "Real:simulation ids, e.g. 0:10,1:11");
  auto* master = app.add_option("--master", master_id, "Master node id (0..254)")
                     ->check(CLI::Range(0, 254));
  auto* led = app.add_option("--led-tracker", flags.led_tracker,
                             "LED tracker (CamApp, docs/camapp.md) HOST:PORT: a real robot's position");
  auto* calibration = app.add_option("--tracker-calibration", flags.tracker_calibration,
                                     "Camera calibration file of the LED tracker");
  auto* max_age = app.add_option("--tracker-max-age", flags.tracker_max_age,
                                 "Oldest tracker sample RobotPosition accepts [s]");
  auto* position_source = app.add_option(
      "--position-source", flags.position_source,
      "RobotPosition from: auto (the simulation's own, the tracker on a real robot) or tracker "
      "(the LED tracker on a simulation too: what the camera would see)");
  auto* level = app.add_option("--log-level", flags.log_level,
                               "trace, debug, info, warn, error, critical, off");
  auto* calls = app.add_option("--max-concurrent-calls", flags.max_concurrent_calls,
                               "Calls served at once; more get RESOURCE_EXHAUSTED");
  auto* link_timeout = app.add_option("--link-timeout", flags.link_timeout,
                                      "ConnectRobot per-link timeout [s]");
  auto* link_retries = app.add_option("--link-retries", flags.link_retries,
                                      "ConnectRobot retries of a link that timed out or failed");
  auto* free_run = app.add_option("--free-run", flags.free_run,
                                  "Free-run real-time factor at start (0 = off)");
  auto* seed = app.add_option("--seed", flags.seed, "Seed of the world opened at start");
  auto* record = app.add_option("--record", flags.record,
                                "Record every SNP frame both ways to FILE (docs/snp.md, "
                                "\"Recorded sessions\"; replay with yamor-bridge --replay)");
  app.add_option("--drain-seconds", drain_seconds, "Grace period for in-flight calls on SIGTERM");
  app.add_flag("--print-config", print_config, "Print the effective settings as TOML and exit");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }

  Settings settings = settings_file.empty() ? Settings() : LoadSettingsFile(settings_file);
  if (listen->count()) settings.listen = flags.listen;
  if (backend->count()) settings.backend = flags.backend;
  if (device->count()) settings.device = flags.device;
  if (baud->count()) settings.baud = flags.baud;
  if (data_bits->count()) settings.data_bits = flags.data_bits;
  if (parity->count()) settings.parity = flags.parity;
  if (stop_bits->count()) settings.stop_bits = flags.stop_bits;
  if (flow->count()) settings.flow_control = flags.flow_control;
  if (hello_timeout->count()) settings.hello_timeout = flags.hello_timeout;
  if (reply_timeout->count()) settings.reply_timeout = flags.reply_timeout;
  if (world->count()) settings.world = flags.world;
  if (config->count()) settings.config = flags.config;
  if (workers->count()) settings.workers = flags.workers;
  if (id_map->count()) settings.id_map = flags.id_map;
  if (master->count()) settings.master = master_id;
  if (led->count()) settings.led_tracker = flags.led_tracker;
  if (calibration->count()) settings.tracker_calibration = flags.tracker_calibration;
  if (max_age->count()) settings.tracker_max_age = flags.tracker_max_age;
  if (position_source->count()) settings.position_source = flags.position_source;
  if (level->count()) settings.log_level = flags.log_level;
  if (calls->count()) settings.max_concurrent_calls = flags.max_concurrent_calls;
  if (link_timeout->count()) settings.link_timeout = flags.link_timeout;
  if (link_retries->count()) settings.link_retries = flags.link_retries;
  if (free_run->count()) settings.free_run = flags.free_run;
  if (seed->count()) settings.seed = flags.seed;
  if (record->count()) settings.record = flags.record;
  ValidateSettings(settings);
  if (print_config) {
    std::cout << SettingsToToml(settings);
    return 0;
  }
  SetLogLevel(settings.log_level);

  // The world and configuration opened at start.
  ResolvedWorld resolved = ResolveWorld(WorldRequest{.world = settings.world}, kDefaultWorld,
                                        /*allow_files=*/true);
  std::optional<cpg::RobotConfig> robot_config = std::move(resolved.config);
  if (!settings.config.empty()) robot_config = cpg::LoadConfigFile(settings.config);
  if (!robot_config) {
    throw Error(StatusCode::kInvalidArgument, "world " + resolved.name +
                                                  " has no built-in configuration: give --config");
  }
  DriverOptions driver_options{.id_map = ParseIdMap(settings.id_map),
                               .master = settings.master,
                               .link_timeout = settings.link_timeout,
                               .link_retries = settings.link_retries,
                               .reply_timeout = settings.reply_timeout};
  std::shared_ptr<LedTracker> tracker;
  if (!settings.led_tracker.empty()) {
    // The real robot's position (thesis 5.1.2): pixels from CamApp, corrected
    // and mapped to metres with the calibration (docs/camapp.md).
    if (settings.tracker_calibration.empty()) {
      throw Error(StatusCode::kInvalidArgument,
                  "--led-tracker " + settings.led_tracker +
                      " needs --tracker-calibration FILE (the camera model, docs/camapp.md)");
    }
    LedTrackerOptions tracker_options;
    const auto colon = settings.led_tracker.rfind(':');
    int port = 0;
    if (colon != std::string::npos) {
      const std::string digits = settings.led_tracker.substr(colon + 1);
      const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), port);
      if (ec != std::errc() || end != digits.data() + digits.size()) port = 0;
    }
    if (colon == std::string::npos || colon == 0 || port < 1 || port > 65535) {
      throw Error(StatusCode::kInvalidArgument,
                  "--led-tracker '" + settings.led_tracker + "' is not HOST:PORT");
    }
    tracker_options.host = settings.led_tracker.substr(0, colon);
    tracker_options.port = port;
    tracker = std::make_shared<LedTracker>(LoadCameraModel(settings.tracker_calibration),
                                           tracker_options);
    driver_options.tracker = MakeLedPositionTracker(
        tracker, std::chrono::duration<double>(settings.tracker_max_age));
    driver_options.position_from_tracker = settings.position_source == "tracker";
    Log().info("LED tracker {} with calibration {}{}", tracker->name(),
               settings.tracker_calibration,
               driver_options.position_from_tracker ? " (the position source on a simulation too)"
                                                    : "");
  }
  if (!settings.record.empty()) {
    // One file for the daemon's life; each backend the driver opens (the
    // world at start, every OpenSimulation) starts a session in it.
    auto writer = std::make_shared<snp::RecordingWriter>(
        settings.record, snp::RecordAttributes{{"backend", settings.backend},
                                               {"program", "yamord " YAMOR_VERSION}});
    driver_options.backend_wrapper = [writer](std::unique_ptr<Backend> inner,
                                              const snp::RecordAttributes& attributes)
        -> std::unique_ptr<Backend> {
      return std::make_unique<RecordingBackend>(std::move(inner), writer, attributes);
    };
    Log().info("recording every SNP frame to {}", settings.record);
  }
  RobotDriver driver(driver_options, *robot_config);
  // The world stays the default of the stateless Evaluate workers either way.
  auto default_morphology = std::make_shared<const physics::Morphology>(resolved.morphology);
  std::string serving = resolved.name;
  if (settings.backend == "serial") {
    // Throws UNAVAILABLE naming the device when it cannot be opened: exit 2.
    auto serial = std::make_unique<SerialBackend>(SerialOptionsOf(settings));
    serving = serial->Name() + " " + settings.device +
              (serial->IsSimulation() ? " (yamor-bridge)" : " (real robot)");
    driver.AttachBackend(std::move(serial), settings.device);
  } else {
    driver.OpenSimulation(SimulationSpec{.morphology = std::move(resolved.morphology),
                                         .world_name = resolved.name,
                                         .config = std::nullopt,
                                         .seed = settings.seed});
  }

  WorkerPool pool(settings.workers);
  ServerOptions server_options{
      .listen = settings.listen,
      .service = ServiceOptions{.max_concurrent_calls = settings.max_concurrent_calls,
                                .default_world = resolved.name,
                                .default_morphology = default_morphology}};
  HostServer server(driver, pool, server_options);
  const std::string host = settings.listen.substr(0, settings.listen.rfind(':'));
  std::cout << "yamord: listening on " << host << ":" << server.port() << std::endl;
  Log().info("yamord {} serving {} on {}:{} ({} evaluate workers)", YAMOR_VERSION, serving,
             host, server.port(), pool.size());
  if (settings.free_run > 0.0) driver.SetFreeRun(settings.free_run);

  int signal_number = 0;
  sigwait(&signals, &signal_number);
  Log().info("received {}: draining calls (up to {} s)", strsignal(signal_number), drain_seconds);
  server.Shutdown(std::chrono::milliseconds(static_cast<int64_t>(drain_seconds * 1000)));
  pool.Shutdown();
  Log().info("yamord stopped");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  // Before any thread starts: llvmpipe rasterises frames on the rendering
  // thread unless the user set LP_NUM_THREADS (raster_threads.h says why).
  yamor::render::DefaultToOneRasterThread();
  // Block the stop signals in every thread (gRPC's included, so block before
  // any starts); main waits for them with sigwait.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  try {
    return Run(argc, argv, signals);
  } catch (const yamor::Error& e) {
    std::cerr << "yamord: " << yamor::StatusCodeName(e.code()) << ": " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "yamord: " << e.what() << "\n";
    return 1;
  }
}
