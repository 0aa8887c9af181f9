// The MMA7260Q accelerometer of the YaMoR sensor board as characterised in
// thesis chapter 4: 1.5 g range read by a 10-bit ADC, δ = 0.0395 m/s² per
// count, zero g at mid-scale, and the measured noise band of Table 4.1.
#pragma once

#include <array>
#include <cstdint>

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
};

/// One accelerometer sample.
struct AccelerometerReading {
  std::array<int, 3> counts{};   ///< Raw ADC counts per axis, in [0, max_count].
  Eigen::Vector3d acceleration;  ///< (counts − zero_count)·δ, m/s², module frame.
};

/// Samples the sensor for a true specific force `specific_force` (acceleration
/// minus gravity, m/s², module frame): adds noise drawn uniformly from the
/// Table 4.1 band, quantises to δ and clamps to the ADC range. The noise is a
/// pure function of (seed, module_id, sample_index, axis), so a replay gives
/// the same readings however often the sensor is polled.
AccelerometerReading SampleAccelerometer(const Eigen::Vector3d& specific_force, std::uint64_t seed,
                                         int module_id, std::uint64_t sample_index,
                                         const AccelerometerSpec& spec = AccelerometerSpec());

}  // namespace yamor::physics
