// yamor-camapp's loop (issue 15 §2): poll the simulated robot's pose, let the
// frame clock decide, film the LED, and publish the sample line after the
// camera's latency; optionally log the truth of every frame as CSV.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <chrono>
#include <cstdint>
#include <functional>
#include <optional>
#include <ostream>
#include <string>

#include "tools/camapp/camapp_server.h"
#include "tools/camapp/camera_emulator.h"

namespace yamor::camapp {

/// The simulation's pose of the central module (the LED) at a time.
struct SimulatedPose {
  double time = 0.0;                        ///< Simulation time [s].
  Eigen::Vector3d position{0.0, 0.0, 0.0};  ///< World position [m].
  /// Orientation of the central module (the LED faces its +z).
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();
};

/// One frame the emulator captured and published, for a FrameObserver.
struct CapturedFrame {
  std::uint32_t seq = 0;         ///< Sequence number sent.
  std::uint64_t time_us = 0;     ///< Camera timestamp sent [µs of simulation time].
  SimulatedPose pose;            ///< The pose filmed.
  CameraFrame frame;             ///< What the camera made of it.
};

/// Called after each captured frame (on the polling thread; must not block long).
using FrameObserver = std::function<void(const CapturedFrame&)>;

/// Reads the simulation's pose; throws yamor::Error when it cannot.
using PoseSource = std::function<SimulatedPose()>;

/// The emulator's settings.
struct EmulatorOptions {
  CameraOptions camera;             ///< The camera.
  double fps = 25.0;                ///< Frames per second of simulation time.
  double latency = 0.04;            ///< Wall seconds from capture to sending [s], in [0, 10].
  double poll_interval = 0.005;     ///< Wall seconds between polls of the pose [s], in (0, 1].
  std::uint32_t first_seq = 0;      ///< Sequence number of the first frame.
  /// Point the LED along the central module's axis that is nearest to up in
  /// the first pose polled (robots start standing as built); false: keep
  /// camera.led_axis.
  bool led_axis_from_first_pose = true;
};

/// The truth log's CSV header (one row per frame, see Emulator).
inline constexpr char kTruthHeader[] = "seq,camera_time_us,sim_time,x,y,z,state,pixel_x,pixel_y";

/// Films a simulated robot and serves the frames.
/// Thread-safety: not thread-safe; one thread runs PollOnce or Run.
class Emulator {
 public:
  /// `server` and `truth` (may be null) must outlive the emulator. Writes the
  /// truth header when `truth` is given. INVALID_ARGUMENT for bad options.
  Emulator(EmulatorOptions options, CamAppServer& server, PoseSource source, std::ostream* truth);

  /// One poll at wall time `now`: reads the pose (an error is logged once
  /// per distinct message and no frame is made), captures a frame if the
  /// frame clock says so, and publishes it. True when a frame was captured.
  bool PollOnce(std::chrono::steady_clock::time_point now);

  /// Calls `observer` after each captured frame (replaces any earlier one).
  void SetFrameObserver(FrameObserver observer) { observer_ = std::move(observer); }

  /// Polls every poll_interval until `stop` returns true.
  void Run(const std::function<bool()>& stop);

  /// The camera.
  const CameraEmulator& camera() const noexcept { return camera_; }
  /// Frames captured so far.
  std::uint64_t frames() const noexcept { return frames_; }
  /// The first pose read, if any poll succeeded yet.
  const std::optional<SimulatedPose>& first_pose() const noexcept { return first_pose_; }

 private:
  EmulatorOptions options_;
  CameraEmulator camera_;
  FrameClock clock_;
  CamAppServer& server_;
  PoseSource source_;
  std::ostream* truth_;
  std::uint32_t next_seq_;
  std::uint64_t frames_ = 0;
  std::optional<SimulatedPose> first_pose_;
  std::string last_error_;
  FrameObserver observer_;
};

}  // namespace yamor::camapp
