// The positioning filter chain of Freescale's application note AN3397
// ("Implementing Positioning Algorithms Using Accelerometers"), as thesis 4.3.2
// applies it: rest calibration, the noise filter (each sample the mean of 64
// readings), the ±3-count window, trapezoidal integration to velocity and
// position, and the movement-end velocity reset.
#pragma once

#include <array>
#include <cstdint>
#include <optional>

#include <Eigen/Core>

namespace yamor::physics {

/// Settings of the filter chain (defaults: AN3397 and thesis 4.3.2).
/// Thread-safety: plain value.
struct An3397Options {
  int calibration_readings = 1024;  ///< Raw readings averaged at rest for the offset.
  int average_count = 64;           ///< Raw readings per sample (the noise filter).
  double window = 3;                ///< |sample| ≤ window counts reads as 0 (window filter).
  int movement_end_count = 25;      ///< Consecutive zero samples that reset the velocity.
  double sample_period = 0.01;      ///< Time between two samples (of averaged readings), s.
  double count_size = 0.0395;       ///< m/s² per count.
  bool window_filter = true;        ///< Apply the window (off: noise filter only).
  bool movement_end = true;         ///< Apply the movement-end reset (off: noise filter only).
};

/// Throws yamor::Error(kInvalidArgument) naming the first bad field.
void ValidateAn3397Options(const An3397Options& options);

/// The window filter: `counts` when |counts| > window, else 0.
double WindowFilter(double counts, double window);

/// One trapezoid step: integral + (previous + current)·dt/2.
double TrapezoidStep(double integral, double previous, double current, double dt);

/// One output sample of the chain, SI units, sensor frame.
/// Thread-safety: plain value.
struct DeadReckoningSample {
  Eigen::Vector3d acceleration = Eigen::Vector3d::Zero();  ///< After the filters, m/s².
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();      ///< Integrated, m/s.
  Eigen::Vector3d position = Eigen::Vector3d::Zero();      ///< Integrated twice, m.
};

/// The integrating end of the chain, fed calibrated samples in counts
/// (offset removed, already averaged): window, trapezoid to velocity and
/// position, then the movement end (after `movement_end_count` consecutive
/// zero samples on an axis that axis's velocity is set to 0; the position of
/// that step was already integrated with the velocity before the reset).
/// Thread-safety: not thread-safe (mutable integration state).
class DeadReckoning {
 public:
  /// Starts at rest at the origin. Throws kInvalidArgument for bad options.
  explicit DeadReckoning(An3397Options options = An3397Options());
  /// Integrates one calibrated sample (counts per axis).
  DeadReckoningSample Add(const Eigen::Vector3d& counts);
  /// Consecutive zero samples per axis so far.
  const std::array<int, 3>& zero_run() const { return zero_run_; }

 private:
  const An3397Options options_;
  Eigen::Vector3d acceleration_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d velocity_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d position_ = Eigen::Vector3d::Zero();
  std::array<int, 3> zero_run_{};
};

/// The whole chain on raw ADC readings: the first calibration_readings
/// readings give the offset (the module must rest; gravity is in it), then
/// every average_count readings make one sample, offset removed, integrated
/// by DeadReckoning.
/// Thread-safety: not thread-safe (mutable state).
class An3397Filter {
 public:
  /// A chain waiting for its calibration. Throws kInvalidArgument for bad options.
  explicit An3397Filter(An3397Options options = An3397Options());
  /// Feeds one raw reading; returns a sample when one completes.
  std::optional<DeadReckoningSample> Add(const std::array<int, 3>& counts);
  /// True once the offset is known.
  bool calibrated() const { return calibration_count_ >= options_.calibration_readings; }
  /// The rest offset, counts (valid once calibrated()).
  const Eigen::Vector3d& offset() const { return offset_; }

 private:
  const An3397Options options_;
  int calibration_count_ = 0;
  Eigen::Vector3d calibration_sum_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d offset_ = Eigen::Vector3d::Zero();
  int average_fill_ = 0;
  Eigen::Vector3d average_sum_ = Eigen::Vector3d::Zero();
  DeadReckoning integrator_;
};

}  // namespace yamor::physics
