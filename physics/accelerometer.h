// The MMA7260Q accelerometer of the YaMoR sensor board as characterised in
// thesis chapter 4: 1.5 g range read by a 10-bit ADC, δ = 0.0395 m/s² per
// count, zero g at mid-scale, the measured noise band of Table 4.1, the ADC's
// missing codes (Figure B.2) and the offset shift after a shock (4.5.2).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace yamor::physics {

/// Figures of the accelerometer model (defaults from thesis chapter 4).
/// Thread-safety: plain value.
struct AccelerometerSpec {
  double count_size = 0.0395;  ///< δ: m/s² per ADC count (g·3.3 V / (0.8 V·1024)).
  int zero_count = 512;        ///< ADC count at zero acceleration (mid-scale).
  int max_count = 1023;        ///< Largest ADC count (10 bits).
  /// Per-axis noise band (x, y, z), m/s²: Table 4.1's N_min and N_max.
  Eigen::Vector3d noise_min{-0.269, -0.267, -0.249};
  Eigen::Vector3d noise_max{0.363, 0.246, 0.304};  ///< See noise_min.
  /// ADC differential non-linearity: absolute codes per axis (x, y, z) whose
  /// input range has zero width, so they never occur; an input that would
  /// round to one goes to the neighbouring code on its side (Figure B.2's
  /// holes near the centre of the X distribution; chosen, not measured).
  std::array<std::vector<int>, 3> missing_codes{{{513, 515}, {510}, {762}}};
  /// A shock: |true specific force| above this, m/s²; each one shifts the offsets.
  double impact_threshold = 30.0;
  /// Largest offset shift per shock and axis, m/s²; a shift's magnitude is
  /// drawn uniformly in [½, 1]× this with a random sign (seeded). Z is small
  /// enough for the ±3-count window to hide it, as in 4.5.2.
  Eigen::Vector3d impact_offset_shift{0.30, 0.30, 0.08};
};

/// Throws yamor::Error(kInvalidArgument) naming the first bad field of `spec`.
void ValidateAccelerometerSpec(const AccelerometerSpec& spec);

/// One accelerometer sample.
struct AccelerometerReading {
  std::array<int, 3> counts{};   ///< Raw ADC counts per axis, in [0, max_count].
  Eigen::Vector3d acceleration;  ///< (counts − zero_count)·δ, m/s², module frame.
};

/// Samples the sensor for a true specific force `specific_force` (acceleration
/// minus gravity, m/s², module frame) plus an offset error `offset` (m/s²):
/// adds noise drawn uniformly from the Table 4.1 band, quantises to δ through
/// the ADC (missing codes skipped) and clamps to the ADC range. The noise is a
/// pure function of (seed, module_id, sample_index, axis), so a replay gives
/// the same readings however often the sensor is polled.
AccelerometerReading SampleAccelerometer(const Eigen::Vector3d& specific_force, std::uint64_t seed,
                                         int module_id, std::uint64_t sample_index,
                                         const AccelerometerSpec& spec = AccelerometerSpec(),
                                         const Eigen::Vector3d& offset = Eigen::Vector3d::Zero());

/// The ADC code of an analog value `counts` (in count units, zero at 0 g
/// already added): rounded and clamped; an input in a run of missing codes
/// goes to the code below the run when under the run's midpoint, else above.
int QuantiseCount(double counts, int axis, const AccelerometerSpec& spec);

/// One sensor board with its history: the offset errors its shocks left
/// (4.5.2). Readings are SampleAccelerometer() plus the accumulated offset;
/// a shock is detected on the rising edge of |specific force| above
/// spec.impact_threshold and shifts the offset by a seeded draw.
/// Thread-safety: not thread-safe (mutable state); one thread at a time.
class AccelerometerBoard {
 public:
  /// A board with no offset error. Throws kInvalidArgument for a bad spec.
  AccelerometerBoard(AccelerometerSpec spec, std::uint64_t seed, int module_id);
  /// Reads the sensor for a true specific force at sample `sample_index`.
  AccelerometerReading Read(const Eigen::Vector3d& specific_force, std::uint64_t sample_index);
  /// The accumulated offset error, m/s², module frame.
  const Eigen::Vector3d& offset() const { return offset_; }
  /// Shocks seen so far.
  int impacts() const { return impacts_; }
  /// The model figures.
  const AccelerometerSpec& spec() const { return spec_; }

 private:
  const AccelerometerSpec spec_;
  const std::uint64_t seed_;
  const int module_id_;
  Eigen::Vector3d offset_ = Eigen::Vector3d::Zero();
  int impacts_ = 0;
  bool in_shock_ = false;
};

}  // namespace yamor::physics
