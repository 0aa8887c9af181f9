#include "physics/orientation.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "common/format.h"
#include "common/status.h"

namespace yamor::physics {
namespace {

[[noreturn]] void Bad(const char* what, const std::string& detail) {
  throw Error(StatusCode::kInvalidArgument, std::string(what) + ": " + detail);
}

void Positive(const char* owner, const char* name, double value) {
  if (!(std::isfinite(value) && value > 0)) {
    Bad(owner, std::string(name) + " must be finite and > 0, got " + FormatDouble(value));
  }
}

}  // namespace

void ValidateOrientationOptions(const OrientationOptions& o) {
  constexpr const char* kOwner = "orientation options";
  if (o.window < 1) Bad(kOwner, "window must be >= 1, got " + std::to_string(o.window));
  Positive(kOwner, "gravity", o.gravity);
  Positive(kOwner, "max_motion", o.max_motion);
  if (!(std::isfinite(o.upside_down_enter) && std::isfinite(o.upside_down_leave) &&
        0 <= o.upside_down_leave && o.upside_down_leave <= o.upside_down_enter &&
        o.upside_down_enter <= M_PI)) {
    Bad(kOwner, "need 0 <= upside_down_leave <= upside_down_enter <= pi, got " +
                    FormatDouble(o.upside_down_leave) + " and " +
                    FormatDouble(o.upside_down_enter));
  }
  if (!o.up_axis.allFinite() || o.up_axis.norm() < 1e-9) Bad(kOwner, "up_axis must be non-zero");
}

OrientationEstimator::OrientationEstimator(OrientationOptions options)
    : options_((ValidateOrientationOptions(options), options)) {
  ring_.reserve(static_cast<size_t>(options_.window));
}

const OrientationEstimate& OrientationEstimator::Add(const Eigen::Vector3d& f) {
  if (!f.allFinite()) return estimate_;
  if (ring_.size() < static_cast<size_t>(options_.window)) {
    ring_.push_back(f);
  } else {
    sum_ -= ring_[next_];
    ring_[next_] = f;
    next_ = (next_ + 1) % ring_.size();
  }
  sum_ += f;
  if (ring_.size() < static_cast<size_t>(options_.window)) {
    estimate_.valid = false;
    return estimate_;
  }
  const Eigen::Vector3d mean = sum_ / double(options_.window);
  const double norm = mean.norm();
  estimate_.valid = std::abs(norm - options_.gravity) <= options_.max_motion && norm > 0;
  if (!estimate_.valid) return estimate_;
  estimate_.up = mean / norm;
  const double c = std::clamp(estimate_.up.dot(options_.up_axis.normalized()), -1.0, 1.0);
  estimate_.tilt = std::acos(c);
  if (estimate_.tilt > options_.upside_down_enter) estimate_.upside_down = true;
  if (estimate_.tilt < options_.upside_down_leave) estimate_.upside_down = false;
  return estimate_;
}

void ValidateMotionMonitorOptions(const MotionMonitorOptions& o) {
  constexpr const char* kOwner = "motion monitor options";
  Positive(kOwner, "gravity", o.gravity);
  Positive(kOwner, "impact_threshold", o.impact_threshold);
  Positive(kOwner, "moving_threshold", o.moving_threshold);
  if (o.refractory < 0) Bad(kOwner, "refractory must be >= 0, got " + std::to_string(o.refractory));
  if (o.block < 1) Bad(kOwner, "block must be >= 1, got " + std::to_string(o.block));
  if (o.moving_blocks < 2) {
    Bad(kOwner, "moving_blocks must be >= 2, got " + std::to_string(o.moving_blocks));
  }
}

MotionMonitor::MotionMonitor(MotionMonitorOptions options)
    : options_((ValidateMotionMonitorOptions(options), options)) {
  blocks_.reserve(static_cast<size_t>(options_.moving_blocks));
}

bool MotionMonitor::Add(const Eigen::Vector3d& f) {
  if (!f.allFinite()) return false;
  const double magnitude = f.norm();
  const std::uint64_t index = count_++;
  block_sum_ += f;
  if (++block_fill_ == options_.block) {
    const Eigen::Vector3d mean = block_sum_ / double(options_.block);
    block_sum_.setZero();
    block_fill_ = 0;
    if (blocks_.size() < static_cast<size_t>(options_.moving_blocks)) {
      blocks_.push_back(mean);
    } else {
      blocks_[next_] = mean;
      next_ = (next_ + 1) % blocks_.size();
    }
    if (blocks_.size() == static_cast<size_t>(options_.moving_blocks)) {
      Eigen::Vector3d low = blocks_.front(), high = blocks_.front();
      for (const Eigen::Vector3d& b : blocks_) {
        low = low.cwiseMin(b);
        high = high.cwiseMax(b);
      }
      moving_ = (high - low).maxCoeff() > options_.moving_threshold;
    }
  }
  if (magnitude - options_.gravity > options_.impact_threshold && index >= quiet_until_) {
    ++impacts_;
    impact_samples_.push_back(index);
    quiet_until_ = index + 1 + static_cast<std::uint64_t>(options_.refractory);
    return true;
  }
  return false;
}

}  // namespace yamor::physics
