#include "physics/accelerometer.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "common/format.h"
#include "common/status.h"

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

// A stream of draws independent of the noise (different axis numbers).
constexpr int kShockStream = 16;

bool IsMissing(int code, int axis, const AccelerometerSpec& spec) {
  const auto& codes = spec.missing_codes[static_cast<size_t>(axis)];
  return std::find(codes.begin(), codes.end(), code) != codes.end();
}

[[noreturn]] void Bad(const std::string& what) {
  throw Error(StatusCode::kInvalidArgument, "accelerometer spec: " + what);
}

}  // namespace

void ValidateAccelerometerSpec(const AccelerometerSpec& spec) {
  if (!(std::isfinite(spec.count_size) && spec.count_size > 0)) {
    Bad("count_size must be finite and > 0, got " + FormatDouble(spec.count_size));
  }
  if (spec.max_count < 2) Bad("max_count must be >= 2, got " + std::to_string(spec.max_count));
  if (spec.zero_count < 0 || spec.zero_count > spec.max_count) {
    Bad("zero_count " + std::to_string(spec.zero_count) + " outside [0, max_count]");
  }
  for (int axis = 0; axis < 3; ++axis) {
    const std::string name = std::string(1, "xyz"[axis]);
    if (!(std::isfinite(spec.noise_min[axis]) && std::isfinite(spec.noise_max[axis]) &&
          spec.noise_min[axis] <= spec.noise_max[axis])) {
      Bad("noise band " + name + " [" + FormatDouble(spec.noise_min[axis]) + ", " +
          FormatDouble(spec.noise_max[axis]) + "] is not a finite interval");
    }
    if (!(std::isfinite(spec.impact_offset_shift[axis]) && spec.impact_offset_shift[axis] >= 0)) {
      Bad("impact_offset_shift." + name + " must be finite and >= 0, got " +
          FormatDouble(spec.impact_offset_shift[axis]));
    }
    for (int code : spec.missing_codes[static_cast<size_t>(axis)]) {
      // The end codes stay: an input beyond the range must land somewhere.
      if (code <= 0 || code >= spec.max_count) {
        Bad("missing code " + std::to_string(code) + " on " + name + " outside (0, max_count)");
      }
    }
  }
  if (!(std::isfinite(spec.impact_threshold) && spec.impact_threshold > 0)) {
    Bad("impact_threshold must be finite and > 0, got " + FormatDouble(spec.impact_threshold));
  }
}

int QuantiseCount(double counts, int axis, const AccelerometerSpec& spec) {
  if (!std::isfinite(counts)) return spec.zero_count;
  const double clamped = std::clamp(std::round(counts), 0.0, double(spec.max_count));
  int code = static_cast<int>(clamped);
  if (!IsMissing(code, axis, spec)) return code;
  // A run of missing codes lo..hi gives its input range to its neighbours:
  // below its midpoint to lo − 1, from it on to hi + 1 (one code: its halves).
  int lo = code, hi = code;
  while (lo > 0 && IsMissing(lo - 1, axis, spec)) --lo;
  while (hi < spec.max_count && IsMissing(hi + 1, axis, spec)) ++hi;
  return counts < (lo + hi) / 2.0 ? lo - 1 : hi + 1;
}

AccelerometerReading SampleAccelerometer(const Eigen::Vector3d& specific_force, std::uint64_t seed,
                                         int module_id, std::uint64_t sample_index,
                                         const AccelerometerSpec& spec,
                                         const Eigen::Vector3d& offset) {
  AccelerometerReading reading;
  for (int axis = 0; axis < 3; ++axis) {
    const double u = Uniform01(seed, module_id, sample_index, axis);
    const double noise = spec.noise_min[axis] + u * (spec.noise_max[axis] - spec.noise_min[axis]);
    const double value = specific_force[axis] + offset[axis] + noise;
    const int code = QuantiseCount(value / spec.count_size + spec.zero_count, axis, spec);
    reading.counts[static_cast<size_t>(axis)] = code;
    reading.acceleration[axis] = (code - spec.zero_count) * spec.count_size;
  }
  return reading;
}

AccelerometerBoard::AccelerometerBoard(AccelerometerSpec spec, std::uint64_t seed, int module_id)
    : spec_((ValidateAccelerometerSpec(spec), std::move(spec))), seed_(seed), module_id_(module_id) {}

AccelerometerReading AccelerometerBoard::Read(const Eigen::Vector3d& specific_force,
                                              std::uint64_t sample_index) {
  const bool shock = specific_force.norm() > spec_.impact_threshold;
  if (shock && !in_shock_) {
    for (int axis = 0; axis < 3; ++axis) {
      const double u = Uniform01(seed_, module_id_, static_cast<std::uint64_t>(impacts_),
                                 kShockStream + axis);
      // u in [0, 1): the lower half gives a negative shift, the upper a positive one.
      const double magnitude = 0.5 + std::abs(2 * u - 1) * 0.5;
      offset_[axis] += (u < 0.5 ? -1.0 : 1.0) * magnitude * spec_.impact_offset_shift[axis];
    }
    ++impacts_;
  }
  in_shock_ = shock;
  return SampleAccelerometer(specific_force, seed_, module_id_, sample_index, spec_, offset_);
}

}  // namespace yamor::physics
