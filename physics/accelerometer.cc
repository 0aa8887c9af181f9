#include "physics/accelerometer.h"

#include <algorithm>
#include <cmath>

namespace yamor::physics {
namespace {

// SplitMix64 finaliser: a well-mixed 64-bit hash.
std::uint64_t Mix(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

double Uniform01(std::uint64_t seed, int module_id, std::uint64_t sample, int axis) {
  std::uint64_t h = Mix(seed);
  h = Mix(h ^ static_cast<std::uint64_t>(static_cast<std::uint32_t>(module_id)));
  h = Mix(h ^ sample);
  h = Mix(h ^ static_cast<std::uint64_t>(axis));
  return static_cast<double>(h >> 11) * 0x1.0p-53;
}

}  // namespace

AccelerometerReading SampleAccelerometer(const Eigen::Vector3d& specific_force, std::uint64_t seed,
                                         int module_id, std::uint64_t sample_index,
                                         const AccelerometerSpec& spec) {
  AccelerometerReading reading;
  for (int axis = 0; axis < 3; ++axis) {
    const double u = Uniform01(seed, module_id, sample_index, axis);
    const double noise = spec.noise_min[axis] + u * (spec.noise_max[axis] - spec.noise_min[axis]);
    const double value = specific_force[axis] + noise;
    const double count = std::isfinite(value)
                             ? std::round(value / spec.count_size) + spec.zero_count
                             : static_cast<double>(spec.zero_count);
    const int clamped = static_cast<int>(std::clamp(count, 0.0, double(spec.max_count)));
    reading.counts[static_cast<size_t>(axis)] = clamped;
    reading.acceleration[axis] = (clamped - spec.zero_count) * spec.count_size;
  }
  return reading;
}

}  // namespace yamor::physics
