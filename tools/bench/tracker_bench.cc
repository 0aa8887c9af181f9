// LED tracking accuracy (issue 15 §4, docs/benchmarks.md "LED tracking"):
//
// 1. Position error against the distance from the point below the camera,
//    with and without the Brown–Conrady correction: yamor-camapp's default
//    camera (2.7 m, 640x480, focal 800 px, k1 -0.25), calibrated from its own
//    25 reference points; "uncorrected" is a homography fitted to the same
//    points' raw (distorted) pixels, what a tracker without the lens model
//    gets. Exact pixels and camera pixels (noise, whole pixels) of 200 000
//    random points at the LED's height.
// 2. The velocity error of a 12-s measurement (after the 8-s warm-up) of the
//    quadruped against the simulation's true velocity: one camera frame at
//    each end, as yamord --position-source tracker reports it, with the
//    camera above the start, 0.7 m and 1.0 m to the side (the walk in the
//    outer image). In-process (the same camera and correction code as yamor-camapp
//    and the tracker; the TCP path is tests/tools/camapp_e2e_test.cc).
//
// A plain program printing tables: tracker_bench [--seeds N] [--noise PX].
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include <CLI/CLI.hpp>

#include "common/log.h"
#include "host/camera_model.h"
#include "host/builtin_robots.h"
#include "host/driver.h"
#include "host/worlds.h"
#include "tools/camapp/camera_emulator.h"

namespace {

using namespace yamor;
using camapp::CameraEmulator;
using camapp::CameraOptions;

constexpr double kLedHeight = 0.0401;  // the quadruped's central module at rest

struct Stat {
  double sum = 0, max = 0;
  int n = 0;
  void Add(double v) {
    sum += v;
    max = std::max(max, v);
    ++n;
  }
  double Mean() const { return n ? sum / n : 0; }
};

// The camera's own calibration, and one without the lens model: the same
// reference pixels taken as undistorted.
std::pair<host::CameraModel, host::CameraModel> Models(const CameraEmulator& camera) {
  host::CameraCalibration calibration =
      host::ParseCameraCalibration(camera.CalibrationText(kLedHeight), "camapp");
  host::CameraCalibration plain = calibration;
  plain.lens.k1 = plain.lens.k2 = plain.lens.k3 = plain.lens.p1 = plain.lens.p2 = 0;
  return {host::CameraModel(calibration, "corrected"), host::CameraModel(plain, "uncorrected")};
}

void PositionErrorByDistance(double noise) {
  CameraOptions options;
  options.noise = noise;
  CameraEmulator camera(options);
  const auto [corrected, uncorrected] = Models(camera);
  constexpr double kRing = 0.1;
  std::vector<Stat> raw(20), exact(20), noisy(20);
  std::vector<double> radius_px(20, 0);
  // Random points (a regular grid would alias with the pixel lattice).
  std::mt19937_64 random(1);
  std::uniform_real_distribution<double> ux(-1.5, 1.5), uy(-1.15, 1.15);
  for (int i = 0; i < 200000; ++i) {
    const double x = ux(random), y = uy(random);
    const Eigen::Vector3d led(x, y, kLedHeight);
    Eigen::Vector2d pixel;
    if (!camera.ProjectExact(led, &pixel)) continue;
    const camapp::CameraFrame frame = camera.Capture(led);
    const auto ring = static_cast<size_t>(std::hypot(x, y) / kRing);
    if (ring >= raw.size()) continue;
    const Eigen::Vector2d truth(x, y);
    raw[ring].Add((uncorrected.PixelToGround(pixel) - truth).norm());
    exact[ring].Add((corrected.PixelToGround(pixel) - truth).norm());
    if (frame.state != camapp::FrameState::kOutside) noisy[ring].Add((corrected.PixelToGround(frame.pixel) - truth).norm());
    radius_px[ring] = std::max(radius_px[ring], (pixel - Eigen::Vector2d(options.cx, options.cy)).norm());
  }
  std::printf("Position error against the distance from the point below the camera (LED %.4f m high)\n",
              kLedHeight);
  std::printf("camera: 2.7 m, 640x480, focal 800 px, k1 -0.25 k2 0.08 p1 5e-4 p2 -3e-4; camera pixels: "
              "noise %.2f px, whole pixels\n\n",
              noise);
  std::printf("%-10s %8s %7s | %21s | %21s | %21s\n", "ring [m]", "max px", "points", "uncorrected mean/max",
              "corrected exact [um]", "corrected camera px");
  for (size_t i = 0; i < raw.size(); ++i) {
    if (raw[i].n == 0) continue;
    std::printf("%4.1f-%-5.1f %8.0f %7d | %8.2f / %8.2f mm | %8.1e / %8.1e um | %8.2f / %8.2f mm\n", i * kRing,
                (i + 1) * kRing, radius_px[i], raw[i].n, raw[i].Mean() * 1e3, raw[i].max * 1e3,
                exact[i].Mean() * 1e6, exact[i].max * 1e6, noisy[i].Mean() * 1e3, noisy[i].max * 1e3);
  }
  std::printf("\n");
}

// True and tracked velocity of one 12-s measurement of the quadruped.
void VelocityError(int seeds, double noise) {
  struct Placement {
    const char* name;
    double camera_x;
  };
  const Placement placements[] = {{"above the start", 0.0}, {"0.7 m to the side", -0.7},
                                  {"1.0 m to the side", -1.0}};
  constexpr int kPlacements = 3;
  struct Row {
    Stat velocity, corrected, uncorrected, relative;
  };
  Row rows[kPlacements];
  for (int seed = 0; seed < seeds; ++seed) {
    host::ResolvedWorld world =
        host::ResolveWorld(host::WorldRequest{.world = "quadruped"}, host::kDefaultWorld, false);
    host::RobotDriver driver({}, *world.config);
    driver.OpenSimulation(host::SimulationSpec{.morphology = std::move(world.morphology),
                                               .world_name = world.name,
                                               .config = std::nullopt,
                                               .seed = static_cast<uint64_t>(seed)});
    driver.ConnectRobot(0.0, false, nullptr);
    driver.SendControlMessage(
        host::ControlMessage{snp::Tristate::kOn, snp::Tristate::kOn, snp::Tristate::kOn, {}, true});
    driver.Sleep(8.0, false, nullptr);
    const host::RobotPose start = driver.RobotPosition();
    driver.Sleep(12.0, false, nullptr);
    const host::RobotPose end = driver.RobotPosition();
    const double duration = end.time - start.time;
    const Eigen::Vector3d a(start.position[0], start.position[1], start.position[2]);
    const Eigen::Vector3d b(end.position[0], end.position[1], end.position[2]);
    const double truth = (b - a).head<2>().norm() / duration;
    for (int p = 0; p < kPlacements; ++p) {
      CameraOptions options;
      options.noise = noise;
      options.camera_x = placements[p].camera_x;
      options.seed = static_cast<uint64_t>(seed);
      CameraEmulator camera(options);
      const auto [corrected, uncorrected] = Models(camera);
      const camapp::CameraFrame fa = camera.Capture(a), fb = camera.Capture(b);
      if (fa.state == camapp::FrameState::kOutside || fb.state == camapp::FrameState::kOutside) continue;
      const double tracked = (corrected.PixelToGround(fb.pixel) - corrected.PixelToGround(fa.pixel)).norm() / duration;
      const double plain =
          (uncorrected.PixelToGround(fb.pixel) - uncorrected.PixelToGround(fa.pixel)).norm() / duration;
      rows[p].velocity.Add(truth);
      rows[p].corrected.Add(std::abs(tracked - truth));
      rows[p].uncorrected.Add(std::abs(plain - truth));
      rows[p].relative.Add(std::abs(tracked - truth) / truth);
    }
  }
  std::printf("Velocity of a 12-s measurement (after 8 s) of the quadruped, one camera frame at each end\n");
  std::printf("(%d seeds; noise %.2f px, whole pixels; error = |tracked - true velocity|)\n\n", seeds, noise);
  std::printf("%-18s %5s %14s | %23s | %10s | %23s\n", "camera", "runs", "true [cm/s]", "corrected mean/max",
              "rel. mean", "uncorrected mean/max");
  for (int p = 0; p < kPlacements; ++p) {
    const Row& r = rows[p];
    std::printf("%-18s %5d %5.2f (%5.2f) | %8.3f / %8.3f mm/s | %9.2f%% | %8.3f / %8.3f mm/s\n",
                placements[p].name, r.velocity.n, r.velocity.Mean() * 100, r.velocity.max * 100,
                r.corrected.Mean() * 1e3, r.corrected.max * 1e3, r.relative.Mean() * 100,
                r.uncorrected.Mean() * 1e3, r.uncorrected.max * 1e3);
  }
  std::printf("(true: mean (max) over the runs)\n");
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"tracker_bench: LED tracking accuracy (position vs image radius, velocity error)"};
  int seeds = 10;
  double noise = 0.1;
  app.add_option("--seeds", seeds, "Quadruped runs (seeds 0..N-1) for the velocity error")->check(CLI::Range(1, 1000));
  app.add_option("--noise", noise, "Camera pixel noise [px]")->check(CLI::Range(0.0, 10.0));
  CLI11_PARSE(app, argc, argv);
  SetLogLevel("warn");
  PositionErrorByDistance(noise);
  VelocityError(seeds, noise);
  return 0;
}
