#include "physics/an3397.h"

#include <cmath>
#include <string>

#include "common/format.h"
#include "common/status.h"

namespace yamor::physics {

void ValidateAn3397Options(const An3397Options& o) {
  auto bad = [](const std::string& what) {
    throw Error(StatusCode::kInvalidArgument, "AN3397 options: " + what);
  };
  if (o.calibration_readings < 1) {
    bad("calibration_readings must be >= 1, got " + std::to_string(o.calibration_readings));
  }
  if (o.average_count < 1) bad("average_count must be >= 1, got " + std::to_string(o.average_count));
  if (!(std::isfinite(o.window) && o.window >= 0)) {
    bad("window must be finite and >= 0, got " + FormatDouble(o.window));
  }
  if (o.movement_end_count < 1) {
    bad("movement_end_count must be >= 1, got " + std::to_string(o.movement_end_count));
  }
  if (!(std::isfinite(o.sample_period) && o.sample_period > 0)) {
    bad("sample_period must be finite and > 0, got " + FormatDouble(o.sample_period));
  }
  if (!(std::isfinite(o.count_size) && o.count_size > 0)) {
    bad("count_size must be finite and > 0, got " + FormatDouble(o.count_size));
  }
}

double WindowFilter(double counts, double window) {
  return std::abs(counts) <= window ? 0.0 : counts;
}

double TrapezoidStep(double integral, double previous, double current, double dt) {
  return integral + (previous + current) * dt / 2;
}

DeadReckoning::DeadReckoning(An3397Options options)
    : options_((ValidateAn3397Options(options), options)) {}

DeadReckoningSample DeadReckoning::Add(const Eigen::Vector3d& counts) {
  const double dt = options_.sample_period;
  DeadReckoningSample out;
  for (int axis = 0; axis < 3; ++axis) {
    const double c = options_.window_filter ? WindowFilter(counts[axis], options_.window)
                                            : counts[axis];
    const double a = c * options_.count_size;
    const double v = TrapezoidStep(velocity_[axis], acceleration_[axis], a, dt);
    position_[axis] = TrapezoidStep(position_[axis], velocity_[axis], v, dt);
    acceleration_[axis] = a;
    velocity_[axis] = v;
    int& run = zero_run_[static_cast<size_t>(axis)];
    run = c == 0 ? run + 1 : 0;
    if (options_.movement_end && run >= options_.movement_end_count) velocity_[axis] = 0;
  }
  out.acceleration = acceleration_;
  out.velocity = velocity_;
  out.position = position_;
  return out;
}

An3397Filter::An3397Filter(An3397Options options)
    : options_((ValidateAn3397Options(options), options)), integrator_(options_) {}

std::optional<DeadReckoningSample> An3397Filter::Add(const std::array<int, 3>& counts) {
  const Eigen::Vector3d c(counts[0], counts[1], counts[2]);
  if (!calibrated()) {
    calibration_sum_ += c;
    if (++calibration_count_ == options_.calibration_readings) {
      offset_ = calibration_sum_ / options_.calibration_readings;
    }
    return std::nullopt;
  }
  average_sum_ += c;
  if (++average_fill_ < options_.average_count) return std::nullopt;
  const Eigen::Vector3d mean = average_sum_ / options_.average_count;
  average_sum_.setZero();
  average_fill_ = 0;
  return integrator_.Add(mean - offset_);
}

}  // namespace yamor::physics
