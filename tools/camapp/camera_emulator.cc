#include "tools/camapp/camera_emulator.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "common/format.h"
#include "common/status.h"

namespace yamor::camapp {
namespace {

host::LensParameters LensOf(const CameraOptions& o) {
  host::LensParameters p;
  p.width = o.width;
  p.height = o.height;
  p.fx = p.fy = o.focal;
  p.cx = o.cx;
  p.cy = o.cy;
  p.k1 = o.k1;
  p.k2 = o.k2;
  p.k3 = o.k3;
  p.p1 = o.p1;
  p.p2 = o.p2;
  return p;
}

void CheckAxis(const Eigen::Vector3d& axis) {
  if (!axis.allFinite() || axis.norm() < 1e-9) {
    throw Error(StatusCode::kInvalidArgument,
                fmt::format("camera: the LED axis ({}, {}, {}) must be finite and non-zero",
                            FormatDouble(axis.x()), FormatDouble(axis.y()), FormatDouble(axis.z())));
  }
}

const CameraOptions& Validated(const CameraOptions& o) {
  auto bad = [](const std::string& what, double value) {
    return Error(StatusCode::kInvalidArgument, "camera: " + what + ", got " + FormatDouble(value));
  };
  if (!(o.camera_height > 0.0 && o.camera_height <= 100.0)) {
    throw bad("height above the ground must be in (0, 100] m", o.camera_height);
  }
  if (!std::isfinite(o.camera_x)) throw bad("camera x must be finite", o.camera_x);
  if (!std::isfinite(o.camera_y)) throw bad("camera y must be finite", o.camera_y);
  if (!(o.noise >= 0.0 && o.noise <= 100.0)) throw bad("noise must be in [0, 100] px", o.noise);
  if (!(o.dropout >= 0.0 && o.dropout < 1.0)) throw bad("dropout must be in [0, 1)", o.dropout);
  if (!(o.led_cone > 0.0 && o.led_cone <= 180.0)) throw bad("LED cone must be in (0, 180] deg", o.led_cone);
  CheckAxis(o.led_axis);
  return o;
}

}  // namespace

const char* FrameStateName(FrameState state) {
  switch (state) {
    case FrameState::kSeen: return "seen";
    case FrameState::kOutside: return "outside";
    case FrameState::kDropout: return "dropout";
    case FrameState::kHidden: return "hidden";
  }
  return "?";
}

CameraEmulator::CameraEmulator(const CameraOptions& options)
    : options_(Validated(options)), lens_(LensOf(options)), random_(options.seed) {}

bool CameraEmulator::ProjectIdeal(const Eigen::Vector3d& p, Eigen::Vector2d* ideal) const {
  const double depth = options_.camera_height - p.z();
  if (!p.allFinite() || !(depth > 1e-6)) return false;
  // Image columns along +x, rows along -y: the picture is a map with +y up.
  *ideal = {options_.cx + options_.focal * (p.x() - options_.camera_x) / depth,
            options_.cy - options_.focal * (p.y() - options_.camera_y) / depth};
  return true;
}

bool CameraEmulator::ProjectExact(const Eigen::Vector3d& p, Eigen::Vector2d* pixel) const {
  Eigen::Vector2d ideal;
  if (!ProjectIdeal(p, &ideal)) return false;
  // Far outside the image the radial polynomial turns back and would bring
  // the point inside again: a pixel counts only if it inverts to itself.
  const double margin = 0.5 * (options_.width + options_.height);
  if (ideal.x() < -margin || ideal.x() > options_.width + margin || ideal.y() < -margin ||
      ideal.y() > options_.height + margin) {
    return false;
  }
  const Eigen::Vector2d raw = lens_.Distort(ideal);
  if (!(raw.x() >= 0 && raw.x() <= options_.width - 1 && raw.y() >= 0 &&
        raw.y() <= options_.height - 1)) {
    return false;
  }
  try {
    if ((lens_.Undistort(raw) - ideal).norm() > 1e-6) return false;
  } catch (const Error&) {
    return false;
  }
  *pixel = raw;
  return true;
}

void CameraEmulator::SetLedAxis(const Eigen::Vector3d& axis) {
  CheckAxis(axis);
  options_.led_axis = axis;
}

bool CameraEmulator::LedFacesLens(const Eigen::Vector3d& led,
                                  const Eigen::Quaterniond& orientation) const {
  const Eigen::Vector3d lens(options_.camera_x, options_.camera_y, options_.camera_height);
  const Eigen::Vector3d to_lens = lens - led;
  if (to_lens.norm() < 1e-12) return true;
  const Eigen::Vector3d facing = orientation.normalized() * options_.led_axis.normalized();
  const double cosine = std::clamp(facing.dot(to_lens.normalized()), -1.0, 1.0);
  return std::acos(cosine) <= options_.led_cone * M_PI / 180.0;
}

CameraFrame CameraEmulator::Capture(const Eigen::Vector3d& led, const Eigen::Quaterniond& orientation) {
  // The same three draws every frame, whatever happens to it.
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  const Eigen::Vector2d noise(gauss(random_) * options_.noise, gauss(random_) * options_.noise);
  const double miss = uniform(random_);
  CameraFrame frame;
  if (!ProjectExact(led, &frame.exact)) return frame;  // kOutside
  Eigen::Vector2d pixel = frame.exact + noise;
  if (options_.integer_pixels) {
    pixel = pixel.array().round();
  } else {
    pixel = (pixel.array() * 1000.0).round() / 1000.0;
  }
  if (!(pixel.x() >= 0 && pixel.x() <= options_.width - 1 && pixel.y() >= 0 &&
        pixel.y() <= options_.height - 1)) {
    return frame;  // the noise pushed it off the edge
  }
  frame.pixel = pixel;
  if (!LedFacesLens(led, orientation)) {
    frame.state = FrameState::kHidden;
  } else {
    frame.state = miss < options_.dropout ? FrameState::kDropout : FrameState::kSeen;
  }
  return frame;
}

std::string CameraEmulator::PixelText(double value) const {
  return options_.integer_pixels ? fmt::format("{}", static_cast<long long>(value))
                                 : fmt::format("{:.3f}", value);
}

std::string CameraEmulator::CalibrationText(double led_height) const {
  if (!std::isfinite(led_height) || !(led_height < options_.camera_height)) {
    throw Error(StatusCode::kInvalidArgument, "camera: the LED height " + FormatDouble(led_height) +
                                                  " m must be finite and below the camera");
  }
  const CameraOptions& o = options_;
  host::CameraCalibration calibration;
  calibration.lens = lens_.params();
  calibration.led_height = led_height;
  // A 5 x 5 grid over 80 % of the field seen at the LED's height.
  const double depth = o.camera_height - led_height;
  const double half_x = 0.8 * depth * std::min(o.cx, o.width - 1 - o.cx) / o.focal;
  const double half_y = 0.8 * depth * std::min(o.cy, o.height - 1 - o.cy) / o.focal;
  for (int j = -2; j <= 2; ++j) {
    for (int i = -2; i <= 2; ++i) {
      const Eigen::Vector3d ground(o.camera_x + half_x * i / 2.0, o.camera_y + half_y * j / 2.0,
                                   led_height);
      Eigen::Vector2d pixel;
      if (ProjectExact(ground, &pixel)) calibration.points.push_back({pixel, ground.head<2>(), 0});
    }
  }
  if (calibration.points.size() < 4) {
    throw Error(StatusCode::kInvalidArgument, "camera: fewer than 4 reference points in the image");
  }
  return host::FormatCameraCalibration(
      calibration, "yamor-camapp's camera: " + FormatDouble(o.camera_height) + " m above (" +
                       FormatDouble(o.camera_x) + ", " + FormatDouble(o.camera_y) +
                       ") looking down\nreference points: the LED's exact pixels (no noise)");
}

FrameClock::FrameClock(double fps) : fps_(fps) {
  if (!(fps > 0.0 && fps <= 1000.0)) {
    throw Error(StatusCode::kInvalidArgument, "camera: frame rate must be in (0, 1000] Hz, got " +
                                                  FormatDouble(fps));
  }
}

FrameClock::Decision FrameClock::Poll(double sim_time, std::chrono::steady_clock::time_point now) {
  // A time exactly on a frame boundary belongs to the new frame despite rounding.
  const auto slot = static_cast<std::int64_t>(std::floor(sim_time * fps_ + 1e-6));
  Decision d;
  if (!started_ || sim_time < last_time_) {
    d.capture = true;
    d.restarted = started_;
  } else if (slot > last_slot_) {
    d.capture = true;
    d.skipped = static_cast<std::uint32_t>(std::min<std::int64_t>(slot - last_slot_ - 1, 1 << 30));
  } else if (std::chrono::duration<double>(now - last_capture_).count() >= 1.0 / fps_) {
    d.capture = true;
  }
  if (d.capture) {
    started_ = true;
    last_time_ = sim_time;
    last_slot_ = slot;
    last_capture_ = now;
  }
  return d;
}

}  // namespace yamor::camapp
