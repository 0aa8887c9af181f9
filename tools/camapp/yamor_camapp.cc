// yamor-camapp: the ceiling camera emulator (issue 15 §2, docs/camapp.md).
// Films the central module of the robot a yamord simulates — read with the
// SimulatedPosition RPC, so it works for the in-process simulation and for a
// yamor-bridge behind `yamord --backend serial` alike — and serves the frames
// over the CamApp protocol to LED trackers (yamord --led-tracker, yamorctl track).
//
//   yamor-camapp                                   # yamord on 127.0.0.1:2224, serve :2225
//   yamor-camapp --listen 127.0.0.1:0 --write-calibration camera.txt --truth truth.csv
//   yamor-camapp --noise 0.3 --dropout 0.05 --latency 0.08 --seed 7
//   yamor-camapp --calibration-only --write-calibration camera.txt --led-height 0.03
//   yamor-camapp --frames pictures --frames-every 5   # the camera's picture, 5 fps
//
// stdout: "yamor-camapp: listening on ADDR:PORT" once serving, then
// "yamor-camapp: calibration FILE" once the calibration file is written.
// SIGTERM / SIGINT: exit 0. Exit status 2: a bad flag or a port in use.
#include <pthread.h>
#include <signal.h>

#include <atomic>
#include <cmath>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>

#include "common/log.h"
#include "common/status.h"
#include "optimizer-plugins/framework/host_rpc.h"
#include "tools/camapp/camapp_server.h"
#include "tools/camapp/camera_picture.h"
#include "tools/camapp/emulator.h"
#include "yamor/v1/host.grpc.pb.h"

namespace {

using namespace yamor;
using namespace yamor::camapp;
using Clock = std::chrono::steady_clock;

// Splits HOST:PORT (the port may be 0); INVALID_ARGUMENT otherwise.
std::pair<std::string, int> HostPort(const std::string& text, const char* flag) {
  const auto colon = text.rfind(':');
  int port = -1;
  if (colon != std::string::npos && colon > 0) {
    try {
      size_t used = 0;
      port = std::stoi(text.substr(colon + 1), &used);
      if (used != text.size() - colon - 1) port = -1;
    } catch (const std::exception&) {
      port = -1;
    }
  }
  if (port < 0 || port > 65535) {
    throw Error(StatusCode::kInvalidArgument, std::string(flag) + " '" + text + "' is not HOST:PORT");
  }
  return {text.substr(0, colon), port};
}

void WriteCalibration(const CameraEmulator& camera, double led_height, const std::string& path) {
  const std::string text = camera.CalibrationText(led_height);
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
  out.close();
  if (!out) throw Error(StatusCode::kInvalidArgument, "cannot write the calibration file " + path);
  Log().info("camapp: calibration for an LED {} m high written to {}", led_height, path);
  std::cout << "yamor-camapp: calibration " << path << std::endl;
}

int Run(int argc, char** argv, const sigset_t& signals) {
  CLI::App app{"yamor-camapp: the ceiling camera emulator (CamApp protocol, docs/camapp.md)",
               "yamor-camapp"};
  EmulatorOptions options;
  CameraOptions& camera = options.camera;
  std::string yamord = "127.0.0.1:2224";
  std::string listen = "127.0.0.1:2225";
  std::string calibration_file, truth_file, frames_folder, log_level = "info";
  int frames_every = 1;
  std::string led_axis = "auto";
  std::optional<double> led_height;
  bool calibration_only = false;
  bool subpixel = false;
  std::vector<double> radial{camera.k1, camera.k2, camera.k3};
  std::vector<double> tangential{camera.p1, camera.p2};
  std::vector<double> principal{camera.cx, camera.cy};
  std::vector<int> image{camera.width, camera.height};
  app.add_option("--yamord", yamord, "The yamord whose simulation is filmed (SimulatedPosition)")
      ->capture_default_str();
  app.add_option("--listen", listen, "Serve the CamApp protocol on ADDR:PORT (port 0: pick one)")
      ->capture_default_str();
  app.add_option("--fps", options.fps, "Frames per second of simulation time")->capture_default_str();
  app.add_option("--latency", options.latency, "Capture to sending [wall s]")->capture_default_str();
  app.add_option("--noise", camera.noise, "Gaussian pixel noise, standard deviation per axis [px]")
      ->capture_default_str();
  app.add_option("--dropout", camera.dropout, "Probability that a frame misses the LED, [0, 1)")
      ->capture_default_str();
  app.add_flag("--subpixel", subpixel, "Send pixels with 3 decimals instead of CamApp's integers");
  app.add_option("--led-axis", led_axis,
                 "Axis of the central module the LED faces: x, -x, y, -y, z, -z, or auto (the "
                 "one pointing up in the first pose filmed)")
      ->check(CLI::IsMember({"auto", "x", "-x", "y", "-y", "z", "-z"}))
      ->capture_default_str();
  app.add_option("--led-cone", camera.led_cone,
                 "Half-angle of the LED's emission cone around the central module's +z [deg]; "
                 "a robot turned further away from the lens hides it")
      ->capture_default_str();
  app.add_option("--seed", camera.seed, "Seed of the noise and the dropouts")->capture_default_str();
  app.add_option("--height", camera.camera_height, "Lens above the ground [m]")->capture_default_str();
  app.add_option("--camera-x", camera.camera_x, "Ground point below the lens, x [m]")->capture_default_str();
  app.add_option("--camera-y", camera.camera_y, "Ground point below the lens, y [m]")->capture_default_str();
  app.add_option("--image", image, "Image width and height [px]")->expected(2)->capture_default_str();
  app.add_option("--focal", camera.focal, "Focal length [px]")->capture_default_str();
  app.add_option("--principal", principal, "Principal point cx cy [px]")->expected(2)->capture_default_str();
  app.add_option("--radial", radial, "Brown-Conrady k1 k2 k3 (barrel: k1 < 0)")
      ->expected(3)
      ->capture_default_str();
  app.add_option("--tangential", tangential, "Brown-Conrady p1 p2")->expected(2)->capture_default_str();
  app.add_option("--poll-interval", options.poll_interval, "Wall seconds between pose polls")
      ->capture_default_str();
  app.add_option("--first-seq", options.first_seq, "Sequence number of the first frame");
  app.add_option("--write-calibration", calibration_file,
                 "Write the calibration file matching this camera (docs/camapp.md)");
  app.add_option("--led-height", led_height,
                 "LED height the calibration is for [m] (default: the robot's first polled height)");
  app.add_flag("--calibration-only", calibration_only,
               "Write --write-calibration (needs --led-height) and exit without serving");
  app.add_option("--truth", truth_file,
                 "Write every frame's true position and what was sent as CSV");
  app.add_option("--frames", frames_folder,
                 "Write the camera's picture of the frames (frame-SEQ.png, frames.csv) into this folder");
  app.add_option("--frames-every", frames_every, "With --frames: a picture of every N-th frame")
      ->capture_default_str();
  app.add_option("--log-level", log_level, "trace, debug, info, warn, error, critical, off");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  SetLogLevel(log_level);
  camera.width = image[0];
  camera.height = image[1];
  camera.cx = principal[0];
  camera.cy = principal[1];
  camera.k1 = radial[0];
  camera.k2 = radial[1];
  camera.k3 = radial[2];
  camera.p1 = tangential[0];
  camera.p2 = tangential[1];
  camera.integer_pixels = !subpixel;
  options.led_axis_from_first_pose = led_axis == "auto";
  if (led_axis != "auto") {
    camera.led_axis = Eigen::Vector3d::Zero();
    camera.led_axis[led_axis.back() - 'x'] = led_axis.front() == '-' ? -1.0 : 1.0;
  }

  if (calibration_only) {
    if (calibration_file.empty() || !led_height) {
      throw Error(StatusCode::kInvalidArgument,
                  "--calibration-only needs --write-calibration FILE and --led-height M");
    }
    WriteCalibration(CameraEmulator(camera), *led_height, calibration_file);
    return 0;
  }

  const auto [address, port] = HostPort(listen, "--listen");
  HostPort(yamord, "--yamord");
  std::unique_ptr<std::ofstream> truth;
  if (!truth_file.empty()) {
    truth = std::make_unique<std::ofstream>(truth_file, std::ios::binary | std::ios::trunc);
    if (!*truth) throw Error(StatusCode::kInvalidArgument, "cannot write the truth file " + truth_file);
  }
  CamAppServer server(CamAppServerOptions{
      .address = address, .port = port, .width = camera.width, .height = camera.height});

  // A pose is wanted within a frame or two; a picture may take longer.
  client::HostClient host(yamord, 2.0);
  PoseSource source = [&host] {
    const v1::RobotPositionResponse r =
        host.Call(&v1::Host::Stub::SimulatedPosition, google::protobuf::Empty(), "SimulatedPosition");
    const auto& q = r.orientation();
    Eigen::Quaterniond orientation(q.w(), q.x(), q.y(), q.z());
    if (orientation.norm() < 1e-9) orientation = Eigen::Quaterniond::Identity();  // a peer without it
    return SimulatedPose{r.time(), {r.position().x(), r.position().y(), r.position().z()}, orientation};
  };
  Emulator emulator(options, server, std::move(source), truth.get());
  std::unique_ptr<PictureRecorder> pictures;
  if (!frames_folder.empty()) {
    PinholeRenderer render = [&host](const PinholeRequest& request) {
      v1::RenderFrameRequest ask;
      ask.mutable_camera()->set_kind(v1::CAMERA_TOP);
      ask.mutable_camera()->mutable_target()->set_x(request.target.x());
      ask.mutable_camera()->mutable_target()->set_y(request.target.y());
      ask.mutable_camera()->mutable_target()->set_z(request.target.z());
      ask.mutable_camera()->set_height(request.height);
      ask.mutable_camera()->set_fov(request.fov);
      ask.set_width(static_cast<uint32_t>(request.width));
      ask.set_height(static_cast<uint32_t>(request.height_px));
      ask.set_hide_labels(true);
      ask.set_hide_legend(true);
      const v1::RenderFrameResponse r =
          host.Call(&v1::Host::Stub::RenderFrame, ask, "RenderFrame", {.deadline = 10});
      return std::pair{std::vector<uint8_t>(r.png().begin(), r.png().end()), r.time()};
    };
    pictures = std::make_unique<PictureRecorder>(emulator.camera(), frames_folder, frames_every, std::move(render));
    emulator.SetFrameObserver([&pictures](const CapturedFrame& frame) { pictures->Offer(frame); });
    Log().info("camapp: pictures of every {}. frame into {}", frames_every, frames_folder);
  }
  if (!calibration_file.empty() && led_height) WriteCalibration(emulator.camera(), *led_height, calibration_file);
  std::cout << "yamor-camapp: listening on " << address << ":" << server.port() << std::endl;
  Log().info("camapp: filming yamord {} at {} Hz, serving on {}:{}", yamord, options.fps, address,
             server.port());

  std::atomic<bool> stop{false};
  std::thread signal_thread([&signals, &stop] {
    int signal_number = 0;
    sigwait(&signals, &signal_number);
    stop = true;
  });
  bool calibration_pending = !calibration_file.empty() && !led_height;
  try {
    emulator.Run([&] {
      if (calibration_pending && emulator.first_pose()) {
        calibration_pending = false;
        WriteCalibration(emulator.camera(), emulator.first_pose()->position.z(), calibration_file);
      }
      return stop.load();
    });
  } catch (...) {
    // Wake the signal thread so it can be joined, then report.
    pthread_kill(signal_thread.native_handle(), SIGTERM);
    signal_thread.join();
    throw;
  }
  signal_thread.join();
  if (pictures) {
    pictures->Drain();
    Log().info("camapp: {} pictures written, {} skipped while rendering, {} failed", pictures->written(),
               pictures->skipped(), pictures->failed());
  }
  Log().info("camapp: stopped after {} frames", emulator.frames());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  // Block the stop signals in every thread; one thread waits for them.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  try {
    return Run(argc, argv, signals);
  } catch (const yamor::Error& e) {
    std::cerr << "yamor-camapp: " << yamor::StatusCodeName(e.code()) << ": " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "yamor-camapp: " << e.what() << "\n";
    return 1;
  }
}
