#include "physics/render/camera.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <fmt/format.h>

#include "common/status.h"

namespace yamor::render {
namespace {

constexpr double kHalfPi = 1.5707963267948966;
constexpr double kMaxDistance = 1000.0;  // [m]
constexpr double kMaxFov = 3.1;          // [rad]

void CheckFinite(double value, const char* field) {
  if (!std::isfinite(value)) {
    throw Error(StatusCode::kInvalidArgument,
                fmt::format("camera {} is not finite: {}", field, value));
  }
}

void CheckFinite(const Eigen::Vector3d& v, const char* field) {
  for (int i = 0; i < 3; ++i) {
    if (!std::isfinite(v[i])) {
      throw Error(StatusCode::kInvalidArgument,
                  fmt::format("camera {}.{} is not finite: {}", field, "xyz"[i], v[i]));
    }
  }
}

void CheckRange(double value, double min_exclusive, double max, const char* field,
                const char* unit) {
  if (!(value > min_exclusive && value <= max)) {
    throw Error(StatusCode::kOutOfRange,
                fmt::format("camera {} {} {} is outside ({}, {}]", field, value, unit,
                            min_exclusive, max));
  }
}

double FovOf(const Camera& camera) {
  if (camera.fov != 0.0) return camera.fov;
  return camera.kind == CameraKind::kTop ? kCeilingCameraFov : kDefaultFov;
}

// A unit vector perpendicular to `up`: world x (or y) with its `up` part removed.
Eigen::Vector3d Horizontal(const Eigen::Vector3d& up) {
  Eigen::Vector3d x = Eigen::Vector3d::UnitX() - up.dot(Eigen::Vector3d::UnitX()) * up;
  if (x.norm() < 1e-6) x = Eigen::Vector3d::UnitY() - up.dot(Eigen::Vector3d::UnitY()) * up;
  return x.normalized();
}

Eigen::Matrix4d LookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
                       const Eigen::Vector3d& up) {
  const Eigen::Vector3d f = (target - eye).normalized();
  const Eigen::Vector3d s = f.cross(up).normalized();
  const Eigen::Vector3d u = s.cross(f);
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.block<1, 3>(0, 0) = s.transpose();
  m.block<1, 3>(1, 0) = u.transpose();
  m.block<1, 3>(2, 0) = -f.transpose();
  m(0, 3) = -s.dot(eye);
  m(1, 3) = -u.dot(eye);
  m(2, 3) = f.dot(eye);
  return m;
}

Eigen::Matrix4d Perspective(double fov, double aspect, double near, double far) {
  const double f = 1.0 / std::tan(fov / 2.0);
  Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
  m(0, 0) = f / aspect;
  m(1, 1) = f;
  m(2, 2) = (far + near) / (near - far);
  m(2, 3) = 2.0 * far * near / (near - far);
  m(3, 2) = -1.0;
  return m;
}

}  // namespace

void ValidateCamera(const Camera& camera) {
  switch (camera.kind) {
    case CameraKind::kFollow:
      CheckFinite(camera.distance, "distance");
      CheckFinite(camera.elevation, "elevation");
      CheckFinite(camera.azimuth, "azimuth");
      CheckRange(camera.distance, 0.0, kMaxDistance, "distance", "m");
      if (camera.elevation < -kHalfPi - 1e-12 || camera.elevation > kHalfPi + 1e-12) {
        throw Error(StatusCode::kOutOfRange,
                    fmt::format("camera elevation {} rad is outside [-pi/2, pi/2]",
                                camera.elevation));
      }
      break;
    case CameraKind::kFixed:
      CheckFinite(camera.eye, "eye");
      CheckFinite(camera.target, "target");
      if ((camera.eye - camera.target).norm() < 1e-9) {
        throw Error(StatusCode::kInvalidArgument,
                    fmt::format("camera eye ({}, {}, {}) equals its target: no view direction",
                                camera.eye.x(), camera.eye.y(), camera.eye.z()));
      }
      CheckRange((camera.eye - camera.target).norm(), 0.0, kMaxDistance * 10, "eye-target distance",
                 "m");
      break;
    case CameraKind::kTop:
      CheckFinite(camera.target, "target");
      CheckFinite(camera.height, "height");
      CheckRange(camera.height, 0.0, kMaxDistance, "height", "m");
      break;
    default:
      throw Error(StatusCode::kInvalidArgument,
                  fmt::format("camera kind {} is not follow, fixed or top",
                              static_cast<int>(camera.kind)));
  }
  CheckFinite(camera.fov, "fov");
  if (camera.fov != 0.0) CheckRange(camera.fov, 0.0, kMaxFov, "fov", "rad");
}

View ComputeView(const Camera& camera, const Scene& scene, int width, int height) {
  ValidateCamera(camera);
  YAMOR_CHECK(width > 0 && height > 0, "ComputeView needs a non-empty image");
  const Eigen::Vector3d up = scene.Up();
  View view;
  view.width = width;
  view.height = height;
  Eigen::Vector3d image_up = up;
  switch (camera.kind) {
    case CameraKind::kFollow: {
      const SceneModule* central = scene.Central();
      view.target = central ? central->body.position : Eigen::Vector3d::Zero();
      const Eigen::Vector3d e1 = Horizontal(up);
      const Eigen::Vector3d e2 = up.cross(e1);
      const Eigen::Vector3d horizontal =
          std::cos(camera.azimuth) * e1 + std::sin(camera.azimuth) * e2;
      view.eye = view.target + camera.distance * (std::cos(camera.elevation) * horizontal +
                                                  std::sin(camera.elevation) * up);
      // Straight above or below: the image's up is away from the azimuth.
      if (std::cos(camera.elevation) < 1e-9) image_up = -horizontal;
      break;
    }
    case CameraKind::kFixed:
      view.eye = camera.eye;
      view.target = camera.target;
      break;
    case CameraKind::kTop:
      view.target = Eigen::Vector3d(camera.target.x(), camera.target.y(), camera.target.z());
      view.eye = view.target + Eigen::Vector3d(0.0, 0.0, camera.height);
      image_up = Eigen::Vector3d::UnitY();
      break;
  }
  const Eigen::Vector3d direction = (view.target - view.eye).normalized();
  if (direction.cross(image_up).norm() < 1e-6) {
    // Looking along the vertical: +y up in the image (as the ceiling camera).
    image_up = std::fabs(direction.y()) < 0.9 ? Eigen::Vector3d::UnitY() : Eigen::Vector3d::UnitX();
  }
  const double distance = (view.target - view.eye).norm();
  const double near = std::clamp(0.02 * distance, 0.005, 10.0);
  const double far = distance + 400.0;
  view.view = LookAt(view.eye, view.target, image_up);
  view.projection = Perspective(FovOf(camera), static_cast<double>(width) / height, near, far);
  return view;
}

std::optional<Eigen::Vector2d> Project(const View& view, const Eigen::Vector3d& point) {
  const Eigen::Vector4d clip = view.projection * view.view * point.homogeneous();
  if (clip.w() <= 1e-12) return std::nullopt;
  const double x = clip.x() / clip.w();
  const double y = clip.y() / clip.w();
  return Eigen::Vector2d((x + 1.0) * 0.5 * view.width, (1.0 - y) * 0.5 * view.height);
}

}  // namespace yamor::render
