// yamor-camapp's camera (issue 15 §2): a pinhole camera above the ground
// looking straight down, with Brown–Conrady lens distortion, Gaussian pixel
// noise, integer pixels and dropouts, every random draw from one seed; the
// frame clock that decides when a simulation is filmed; and the calibration
// file (docs/camapp.md) that matches the camera exactly.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <chrono>
#include <cstdint>
#include <random>
#include <string>

#include "host/camera_model.h"

namespace yamor::camapp {

/// The camera and its imperfections. Plain value; defaults are the thesis's
/// camera (2.7 m above the ground, 640×480, about 3.3 mm per pixel).
struct CameraOptions {
  int width = 640;               ///< Image width [px].
  int height = 480;              ///< Image height [px].
  double camera_height = 2.7;    ///< Height of the lens above the ground [m].
  double camera_x = 0.0;         ///< Ground point below the lens, x [m].
  double camera_y = 0.0;         ///< Ground point below the lens, y [m].
  double focal = 800.0;          ///< Focal length [px] (fx = fy).
  double cx = 319.5;             ///< Principal point, column [px].
  double cy = 239.5;             ///< Principal point, row [px].
  double k1 = -0.25;             ///< Brown–Conrady radial r² (barrel: < 0).
  double k2 = 0.08;              ///< Radial r⁴.
  double k3 = 0.0;               ///< Radial r⁶.
  double p1 = 0.0005;            ///< Tangential p1.
  double p2 = -0.0003;           ///< Tangential p2.
  double noise = 0.1;            ///< Standard deviation of the pixel noise, per axis [px].
  bool integer_pixels = true;    ///< Round to whole pixels as CamApp does; else 3 decimals.
  double dropout = 0.0;          ///< Probability that a frame misses the LED, in [0, 1).
  /// Direction the LED faces in the central module's frame (non-zero; normalised).
  Eigen::Vector3d led_axis = Eigen::Vector3d::UnitZ();
  /// Half-angle of the LED's emission cone around `led_axis` [deg], in
  /// (0, 180]: the camera sees the LED only when the lens lies inside it (a
  /// robot on its back or side hides it).
  double led_cone = 80.0;
  std::uint64_t seed = 0;        ///< Seed of the noise and the dropouts.
};

/// Why a frame has or has not the LED.
enum class FrameState {
  kSeen,     ///< The LED is in the frame.
  kOutside,  ///< The LED is outside the image (or above the camera).
  kDropout,  ///< A random miss.
  kHidden,   ///< The LED faces away from the lens (outside its emission cone).
};

/// The text of a FrameState ("seen", "outside", "dropout", "hidden").
const char* FrameStateName(FrameState state);

/// One captured frame.
struct CameraFrame {
  FrameState state = FrameState::kOutside;  ///< Seen, outside, or dropped.
  Eigen::Vector2d pixel{0, 0};   ///< Reported pixel (noise, rounding) when seen.
  Eigen::Vector2d exact{0, 0};   ///< Distorted pixel before noise and rounding.
};

/// The emulated camera. Thread-safety: not thread-safe (one capturing
/// thread); the const methods are pure.
class CameraEmulator {
 public:
  /// Validates `options` (the lens through host::LensModel, heights,
  /// noise >= 0, dropout in [0, 1), LED cone in (0, 180]); INVALID_ARGUMENT
  /// naming the bad value.
  explicit CameraEmulator(const CameraOptions& options);

  /// The options.
  const CameraOptions& options() const noexcept { return options_; }
  /// The lens (intrinsics and distortion).
  const host::LensModel& lens() const noexcept { return lens_; }

  /// Ideal (undistorted) pinhole pixel of the world point `p` [m]; false
  /// when `p` is not below the lens.
  bool ProjectIdeal(const Eigen::Vector3d& p, Eigen::Vector2d* ideal) const;

  /// Distorted pixel of `p` before noise; false when it is not in the image
  /// (outside, above the lens, or beyond where the lens folds).
  bool ProjectExact(const Eigen::Vector3d& p, Eigen::Vector2d* pixel) const;

  /// Points the LED along `axis` in the central module's frame
  /// (INVALID_ARGUMENT for a zero or non-finite axis).
  void SetLedAxis(const Eigen::Vector3d& axis);

  /// True when the lens lies inside the emission cone of an LED at `led`
  /// [m] on a central module turned by `orientation` (the LED faces
  /// `led_axis` of the module).
  bool LedFacesLens(const Eigen::Vector3d& led, const Eigen::Quaterniond& orientation) const;

  /// Films the LED at world position `led` [m] on a central module turned
  /// by `orientation`: draws the frame's noise and dropout (always the same
  /// draws per frame, so a seed replays exactly). Outside the image wins
  /// over hidden, hidden over a dropout.
  CameraFrame Capture(const Eigen::Vector3d& led,
                      const Eigen::Quaterniond& orientation = Eigen::Quaterniond::Identity());

  /// The pixel field of a sample line ("321", "321.500") for `frame`, or "-".
  std::string PixelText(double value) const;

  /// A calibration file (docs/camapp.md) for this camera with the LED at
  /// `led_height` [m]: the lens exactly, and a grid of reference points
  /// (noise-free, sub-pixel) over the image; a tracker loading it recovers
  /// metres on the ground.
  std::string CalibrationText(double led_height) const;

 private:
  CameraOptions options_;
  host::LensModel lens_;
  std::mt19937_64 random_;
};

/// When the camera films a simulation it reads by polling (docs/camapp.md,
/// "yamor-camapp"): the camera's clock is the simulation's; frame k belongs
/// to simulation time [k/fps, (k+1)/fps). A poll captures a frame when it
/// is the first, when the simulation clock went back (a reset), when it
/// falls in a later frame slot than the last capture (slots passed over
/// count as frames dropped), or when 1/fps of wall time passed since the
/// last capture (a camera keeps filming a simulation that does not advance).
/// Thread-safety: not thread-safe.
class FrameClock {
 public:
  /// A decision for one poll.
  struct Decision {
    bool capture = false;        ///< Capture a frame now.
    std::uint32_t skipped = 0;   ///< Frame slots passed over since the last capture.
    bool restarted = false;      ///< The simulation clock went back.
  };

  /// A clock at `fps` frames per second (> 0, at most 1000).
  explicit FrameClock(double fps);

  /// Decides for a poll that saw simulation time `sim_time` at wall time `now`.
  Decision Poll(double sim_time, std::chrono::steady_clock::time_point now);

 private:
  double fps_;
  bool started_ = false;
  double last_time_ = 0.0;
  std::int64_t last_slot_ = 0;
  std::chrono::steady_clock::time_point last_capture_;
};

}  // namespace yamor::camapp
