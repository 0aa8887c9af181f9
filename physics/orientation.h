// What the accelerometers are good for (thesis 4.5.3): the orientation of a
// module at rest from the gravity direction, impacts and "is it moving",
// from the specific force the accelerometer reads (m/s², module frame).
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace yamor::physics {

/// Settings of the orientation estimator.
/// Thread-safety: plain value.
struct OrientationOptions {
  int window = 100;  ///< Low-pass: mean over this many samples (e.g. one CPG period).
  double gravity = 9.81;     ///< Expected |g|, m/s².
  double max_motion = 2.0;   ///< The mean is trusted while ||mean| − g| ≤ this, m/s².
  double upside_down_enter = 2.0943951023931957;  ///< Tilt that makes it upside down, rad (120°).
  double upside_down_leave = 1.0471975511965976;  ///< Tilt that makes it upright again, rad (60°).
  Eigen::Vector3d up_axis = Eigen::Vector3d::UnitZ();  ///< Module axis that points up when upright.
};

/// Throws yamor::Error(kInvalidArgument) naming the first bad field.
void ValidateOrientationOptions(const OrientationOptions& options);

/// The orientation as the estimator sees it.
/// Thread-safety: plain value.
struct OrientationEstimate {
  bool valid = false;  ///< Window full and its mean looks like gravity alone.
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();  ///< World up in the module frame (unit).
  double tilt = 0;           ///< Angle between up and up_axis, rad, in [0, π].
  bool upside_down = false;  ///< Hysteresis on tilt; keeps its last value while invalid.
};

/// Low-passes the specific force over a window and reads the gravity
/// direction from it: at rest the accelerometer measures −g, i.e. world up.
/// Thread-safety: not thread-safe (mutable window).
class OrientationEstimator {
 public:
  /// An empty window. Throws kInvalidArgument for bad options.
  explicit OrientationEstimator(OrientationOptions options = OrientationOptions());
  /// Adds one sample (m/s², module frame; non-finite samples are skipped) and
  /// returns the updated estimate.
  const OrientationEstimate& Add(const Eigen::Vector3d& specific_force);
  /// The current estimate.
  const OrientationEstimate& estimate() const { return estimate_; }

 private:
  const OrientationOptions options_;
  std::vector<Eigen::Vector3d> ring_;
  size_t next_ = 0;
  Eigen::Vector3d sum_ = Eigen::Vector3d::Zero();
  OrientationEstimate estimate_;
};

/// Settings of the motion monitor.
/// Thread-safety: plain value.
struct MotionMonitorOptions {
  double gravity = 9.81;        ///< Expected |g|, m/s².
  double impact_threshold = 8;  ///< An impact: |f| − g above this, m/s².
  int refractory = 50;          ///< Samples after an impact during which no new one counts.
  int block = 64;               ///< Samples averaged into one block mean (the noise filter).
  int moving_blocks = 16;       ///< Block means over which the change is taken.
  double moving_threshold = 0.3;  ///< Moving: an axis's block means span more than this, m/s².
};

/// Throws yamor::Error(kInvalidArgument) naming the first bad field.
void ValidateMotionMonitorOptions(const MotionMonitorOptions& options);

/// Impact detection on |specific force| of single readings (independent of
/// the orientation and of offset shifts) and "is this module moving": some
/// axis's block means (noise filtered) changed by more than the threshold over
/// the last moving_blocks blocks. It sees changes of acceleration (starting,
/// stopping, shaking, a gait, a fall); a constant velocity is invisible to it.
/// Thread-safety: not thread-safe (mutable state).
class MotionMonitor {
 public:
  /// A monitor that saw nothing yet. Throws kInvalidArgument for bad options.
  explicit MotionMonitor(MotionMonitorOptions options = MotionMonitorOptions());
  /// Adds one sample (m/s², module frame); returns true when it is a new impact.
  bool Add(const Eigen::Vector3d& specific_force);
  /// Impacts so far.
  int impacts() const { return impacts_; }
  /// Sample indices (0-based, in Add() order) of the impacts.
  const std::vector<std::uint64_t>& impact_samples() const { return impact_samples_; }
  /// True while an axis's block means over the last moving_blocks blocks
  /// span more than moving_threshold (false until that many blocks exist).
  bool moving() const { return moving_; }

 private:
  const MotionMonitorOptions options_;
  Eigen::Vector3d block_sum_ = Eigen::Vector3d::Zero();
  int block_fill_ = 0;
  std::vector<Eigen::Vector3d> blocks_;
  size_t next_ = 0;
  std::uint64_t count_ = 0;
  std::uint64_t quiet_until_ = 0;
  int impacts_ = 0;
  std::vector<std::uint64_t> impact_samples_;
  bool moving_ = false;
};

}  // namespace yamor::physics
