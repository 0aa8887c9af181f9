#include "physics/driven_module.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <utility>

#include "common/format.h"
#include "common/status.h"
#include "physics/module.h"

namespace yamor::physics {
namespace {

constexpr double kPi = std::numbers::pi;

// A scalar function of time with its first two derivatives.
struct Jet {
  double v = 0, d = 0, dd = 0;
};

Jet operator+(Jet a, Jet b) { return {a.v + b.v, a.d + b.d, a.dd + b.dd}; }
Jet operator-(Jet a, Jet b) { return {a.v - b.v, a.d - b.d, a.dd - b.dd}; }
Jet operator*(double k, Jet a) { return {k * a.v, k * a.d, k * a.dd}; }

// f∘g, given f and its derivatives at g.v (in f's variable).
Jet Compose(Jet f, Jet g) { return {f.v, f.d * g.d, f.dd * g.d * g.d + f.d * g.dd}; }

// Minimum-jerk ramp 0 → 1 over x ∈ [0, 1], constant outside.
Jet MinJerk(double x) {
  if (x <= 0) return {0, 0, 0};
  if (x >= 1) return {1, 0, 0};
  const double x2 = x * x, x3 = x2 * x;
  return {x3 * (10 - 15 * x + 6 * x2), 30 * x2 * (1 - 2 * x + x2), 60 * x - 180 * x2 + 120 * x3};
}

// The minimum-jerk progress of a motion from t0 lasting `length`.
Jet Warp(double t, double t0, double length) {
  return Compose(MinJerk((t - t0) / length), Jet{(t - t0) / length, 1 / length, 0});
}

// sin(k·s) and sin²(k·s) of a jet s.
Jet Sin(double k, Jet s) {
  return Compose({std::sin(k * s.v), k * std::cos(k * s.v), -k * k * std::sin(k * s.v)}, s);
}
Jet Sin2(double k, Jet s) {  // (1 − cos 2ks) / 2
  const double c = 2 * k;
  return Compose({(1 - std::cos(c * s.v)) / 2, c * std::sin(c * s.v) / 2,
                  c * c * std::cos(c * s.v) / 2}, s);
}

struct Motion {
  std::array<Jet, 3> displacement;  // of the body centre from the start, per axis
  Jet angle;                        // rotation about a fixed world axis
};

// A path from a motion in time: start upright resting on the ground (or at
// `start`), displacement added, rotated by angle about `axis`.
MotionPath Build(std::string name, double duration, Eigen::Vector3d start, Eigen::Vector3d axis,
                 std::function<Motion(double)> motion) {
  return MotionPath(std::move(name), duration, [start, axis, motion = std::move(motion)](double t) {
    const Motion m = motion(t);
    PathPoint p;
    for (int i = 0; i < 3; ++i) {
      p.position[i] = start[i] + m.displacement[static_cast<size_t>(i)].v;
      p.velocity[i] = m.displacement[static_cast<size_t>(i)].d;
      p.acceleration[i] = m.displacement[static_cast<size_t>(i)].dd;
    }
    p.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(m.angle.v, axis));
    p.angular_velocity = m.angle.d * axis;
    p.angular_acceleration = m.angle.dd * axis;
    return p;
  });
}

void RequirePositive(double value, const char* what) {
  if (!(std::isfinite(value) && value > 0)) {
    throw Error(StatusCode::kInvalidArgument,
                std::string(what) + " must be finite and > 0, got " + FormatDouble(value));
  }
}
void RequireNonNegative(double value, const char* what) {
  if (!(std::isfinite(value) && value >= 0)) {
    throw Error(StatusCode::kInvalidArgument,
                std::string(what) + " must be finite and >= 0, got " + FormatDouble(value));
  }
}

Eigen::Vector3d RestingStart() { return {0, 0, RestingHeight()}; }

// Corners of the module's bounding box (body, and handle straight at 0°), body frame.
std::array<Eigen::Vector3d, 8> BoundingCorners() {
  const double x0 = -module::kBodyLength / 2, x1 = module::kPivotX + module::kHandleReach;
  const double y = 0.030, z = module::kBodyHeight / 2;
  std::array<Eigen::Vector3d, 8> corners;
  for (int i = 0; i < 8; ++i) {
    corners[static_cast<size_t>(i)] =
        Eigen::Vector3d((i & 1) ? x1 : x0, (i & 2) ? y : -y, (i & 4) ? z : -z);
  }
  return corners;
}

}  // namespace

MotionPath::MotionPath(std::string name, double duration, Function function)
    : name_(std::move(name)), duration_(duration), function_(std::move(function)) {
  if (!(std::isfinite(duration) && duration > 0)) {
    throw Error(StatusCode::kInvalidArgument,
                "path '" + name_ + "': duration must be finite and > 0, got " +
                    FormatDouble(duration));
  }
  if (!function_) {
    throw Error(StatusCode::kInvalidArgument, "path '" + name_ + "' has no function");
  }
}

PathPoint MotionPath::At(double t) const {
  const double clamped = std::clamp(std::isfinite(t) ? t : 0.0, 0.0, duration_);
  PathPoint p = function_(clamped);
  if (t < 0 || t > duration_) {  // resting at the end points
    p.velocity.setZero();
    p.acceleration.setZero();
    p.angular_velocity.setZero();
    p.angular_acceleration.setZero();
  }
  return p;
}

double RestingHeight() { return module::kBodyHeight / 2; }

MotionPath SineMove(double amplitude, double length, double move_time, double rest) {
  RequireNonNegative(amplitude, "sine amplitude");
  RequireNonNegative(length, "sine length");
  RequirePositive(move_time, "sine move_time");
  RequireNonNegative(rest, "sine rest");
  return Build("sine", 2 * rest + move_time, RestingStart(), Eigen::Vector3d::UnitZ(),
               [=](double t) {
                 const Jet s = Warp(t, rest, move_time);
                 return Motion{{length * s, amplitude * Sin(2 * kPi, s), Jet{}}, Jet{}};
               });
}

MotionPath CircleMove(double radius, double move_time, double rest) {
  RequireNonNegative(radius, "circle radius");
  RequirePositive(move_time, "circle move_time");
  RequireNonNegative(rest, "circle rest");
  return Build("circle", 2 * rest + move_time, RestingStart(), Eigen::Vector3d::UnitZ(),
               [=](double t) {
                 const Jet s = Warp(t, rest, move_time);
                 // φ = π/2 − 2πs about the centre (0, −r): from the top, clockwise.
                 const Jet phi = Jet{kPi / 2, 0, 0} - 2 * kPi * s;
                 const Jet x = Compose({std::cos(phi.v), -std::sin(phi.v), -std::cos(phi.v)}, phi);
                 const Jet y = Compose({std::sin(phi.v), std::cos(phi.v), -std::sin(phi.v)}, phi);
                 return Motion{{radius * x, radius * y - Jet{radius, 0, 0}, Jet{}}, Jet{}};
               });
}

MotionPath GoAndReturnMove(double distance, double leg_time, double pause, double rest) {
  RequireNonNegative(distance, "go-and-return distance");
  RequirePositive(leg_time, "go-and-return leg_time");
  RequireNonNegative(pause, "go-and-return pause");
  RequireNonNegative(rest, "go-and-return rest");
  return Build("go-and-return", 2 * rest + 2 * leg_time + pause, RestingStart(),
               Eigen::Vector3d::UnitZ(), [=](double t) {
                 const Jet x = distance * (Warp(t, rest, leg_time) -
                                           Warp(t, rest + leg_time + pause, leg_time));
                 return Motion{{x, Jet{}, Jet{}}, Jet{}};
               });
}

MotionPath RandomAirMove(std::uint64_t seed, double max_height, double max_tilt,
                         double move_time, double rest) {
  RequirePositive(max_height, "random-move max_height");
  RequireNonNegative(max_tilt, "random-move max_tilt");
  RequirePositive(move_time, "random-move move_time");
  RequireNonNegative(rest, "random-move rest");
  std::mt19937_64 random(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  // Horizontal: Σ a_k sin(kπs), |a_k| ≤ 4 cm / k. Height: h(b1 sin²(πs) +
  // b2 sin²(2πs)) with b1 + b2 ≤ 1. Tilt: θmax(c1 sin²(πs) + c2 sin²(2πs)),
  // |c1| + |c2| ≤ 1 and small c2, so the tilt grows no faster than the lift
  // near the ground.
  std::array<std::array<double, 3>, 2> a{};
  for (auto& axis : a) {
    for (size_t k = 0; k < axis.size(); ++k) axis[k] = (2 * unit(random) - 1) * 0.04 / double(k + 1);
  }
  const double b1 = 0.6 + 0.2 * unit(random);
  const double b2 = (1 - b1) * unit(random);
  const double sign = unit(random) < 0.5 ? -1.0 : 1.0;
  const double c1 = sign * (0.7 + 0.1 * unit(random));
  const double c2 = (2 * unit(random) - 1) * 0.2;
  const double azimuth = 2 * kPi * unit(random);
  const Eigen::Vector3d axis(std::cos(azimuth), std::sin(azimuth), 0);
  return Build("random", 2 * rest + move_time, RestingStart(), axis, [=](double t) {
    const Jet s = Warp(t, rest, move_time);
    Motion m;
    for (size_t i = 0; i < 2; ++i) {
      for (size_t k = 0; k < 3; ++k) m.displacement[i] = m.displacement[i] + a[i][k] * Sin(double(k + 1) * kPi, s);
    }
    m.displacement[2] = max_height * (b1 * Sin2(kPi, s) + b2 * Sin2(2 * kPi, s));
    m.angle = max_tilt * (c1 * Sin2(kPi, s) + c2 * Sin2(2 * kPi, s));
    return m;
  });
}

MotionPath DropMove(double height, double contact_time, double rest, double settle) {
  RequireNonNegative(height, "drop height");
  RequirePositive(contact_time, "drop contact_time");
  RequireNonNegative(rest, "drop rest");
  RequireNonNegative(settle, "drop settle");
  constexpr double g = 9.81;  // the path's own fall; the sensor uses the options' gravity
  const double fall = std::sqrt(2 * height / g);
  const double speed = g * fall;
  const double peak = kPi * speed / (2 * contact_time);  // half-sine deceleration
  const double ground = RestingHeight();
  const double sink = speed * contact_time / 2;
  const Eigen::Vector3d start(0, 0, ground + height);
  return Build("drop", rest + fall + contact_time + settle, start, Eigen::Vector3d::UnitZ(),
               [=](double t) {
                 Jet z;
                 if (t <= rest) {
                   z = {0, 0, 0};
                 } else if (t <= rest + fall) {
                   const double u = t - rest;
                   z = {-g * u * u / 2, -g * u, -g};
                 } else if (t <= rest + fall + contact_time) {
                   const double u = t - rest - fall, w = kPi / contact_time;
                   const double k = peak / w;
                   z = {-height - speed * u + k * (u - std::sin(w * u) / w),
                        -speed + k * (1 - std::cos(w * u)), peak * std::sin(w * u)};
                 } else {
                   z = {-height - sink, 0, 0};
                 }
                 return Motion{{Jet{}, Jet{}, z}, Jet{}};
               });
}

MotionPath FlipMove(double lift, double move_time, double rest) {
  RequirePositive(lift, "flip lift");
  RequirePositive(move_time, "flip move_time");
  RequireNonNegative(rest, "flip rest");
  return Build("flip", 2 * rest + move_time, RestingStart(), Eigen::Vector3d::UnitX(),
               [=](double t) {
                 const Jet s = Warp(t, rest, move_time);
                 // Turn during the middle half of the move, while lifted.
                 const Jet turn = Warp(t, rest + move_time / 4, move_time / 2);
                 return Motion{{Jet{}, Jet{}, lift * Sin2(kPi, s)}, kPi * turn};
               });
}

DrivenModule::DrivenModule(MotionPath path, DrivenModuleOptions options)
    : path_(std::move(path)),
      options_(std::move(options)),
      board_(options_.accelerometer, options_.seed, options_.module_id) {
  RequirePositive(options_.sample_rate, "sample_rate");
  RequireNonNegative(options_.gravity, "gravity");
  RequirePositive(options_.max_acceleration, "max_acceleration");
  RequireNonNegative(options_.ground_tolerance, "ground_tolerance");
  const double samples = std::floor(path_.duration() * options_.sample_rate) + 1;
  if (samples > 1e8) {
    throw Error(StatusCode::kOutOfRange, "path '" + path_.name() + "' of " +
                                             FormatDouble(path_.duration()) + " s at " +
                                             FormatDouble(options_.sample_rate) +
                                             " Hz has more than 1e8 samples");
  }
  sample_count_ = static_cast<std::uint64_t>(samples);
  const auto corners = BoundingCorners();
  for (std::uint64_t i = 0; i < sample_count_; ++i) {
    const DrivenSample s = Kinematics(i);
    const std::string where = "path '" + path_.name() + "' at t = " + FormatDouble(s.time) + " s";
    const PathPoint& p = s.state;
    if (!p.position.allFinite() || !p.velocity.allFinite() || !p.acceleration.allFinite() ||
        !p.orientation.coeffs().allFinite() || !p.angular_velocity.allFinite() ||
        !p.angular_acceleration.allFinite()) {
      throw Error(StatusCode::kInvalidArgument, where + ": non-finite state");
    }
    double lowest = std::numeric_limits<double>::infinity();
    for (const auto& c : corners) lowest = std::min(lowest, (p.orientation * c + p.position).z());
    if (lowest < -options_.ground_tolerance) {
      throw Error(StatusCode::kOutOfRange,
                  where + " leaves free space: lowest point z = " + FormatDouble(lowest) +
                      " m (ground tolerance " + FormatDouble(options_.ground_tolerance) + " m)");
    }
    const double a = s.sensor_acceleration.norm();
    if (a > options_.max_acceleration) {
      throw Error(StatusCode::kOutOfRange,
                  where + " asks an impossible acceleration: |a| = " + FormatDouble(a) +
                      " m/s² > max_acceleration " + FormatDouble(options_.max_acceleration));
    }
  }
}

DrivenSample DrivenModule::Kinematics(std::uint64_t index) const {
  DrivenSample s;
  s.index = index;
  s.time = static_cast<double>(index) / options_.sample_rate;
  s.state = path_.At(s.time);
  const PathPoint& p = s.state;
  const Eigen::Matrix3d rotation = p.orientation.normalized().toRotationMatrix();
  const Eigen::Vector3d r = rotation * module::kSensorPosition;
  const Eigen::Vector3d& w = p.angular_velocity;
  s.sensor_position = p.position + r;
  s.sensor_velocity = p.velocity + w.cross(r);
  s.sensor_acceleration =
      p.acceleration + p.angular_acceleration.cross(r) + w.cross(w.cross(r));
  const Eigen::Vector3d gravity(0, 0, -options_.gravity);
  s.specific_force = rotation.transpose() * (s.sensor_acceleration - gravity);
  return s;
}

bool DrivenModule::Done() const { return next_ >= sample_count_; }

DrivenSample DrivenModule::Next() {
  if (Done()) {
    throw Error(StatusCode::kOutOfRange, "path '" + path_.name() + "' ended after " +
                                             std::to_string(sample_count_) + " samples");
  }
  DrivenSample s = Kinematics(next_++);
  s.reading = board_.Read(s.specific_force, s.index);
  return s;
}

std::vector<DrivenSample> DrivenModule::Run() {
  std::vector<DrivenSample> out;
  out.reserve(static_cast<size_t>(sample_count_ - next_));
  while (!Done()) out.push_back(Next());
  return out;
}

}  // namespace yamor::physics
