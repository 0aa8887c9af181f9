// Cameras of the renderer: following the central module, fixed, or looking
// straight down like the thesis's ceiling camera; and the view/projection
// they give for a scene (also used to project points to pixels in tests).
#pragma once

#include <optional>

#include <Eigen/Core>

#include "physics/render/scene.h"

namespace yamor::render {

/// How a camera is placed.
enum class CameraKind {
  /// Looks at the central module from `distance` metres, `elevation` above
  /// the (true) horizon, at azimuth `azimuth` (the direction from the module
  /// to the eye, measured from +x towards +y). Moves with the module.
  kFollow,
  /// Looks from `eye` at `target` (world frame).
  kFixed,
  /// Looks straight down from `height` metres above `target` (on the
  /// ground), image up = +y: the ceiling camera (thesis 4.2.1: 2.7 m, its
  /// 640x480 view covers about 3.3 x 2.5 m of floor).
  kTop,
};

/// Default vertical field of view of the follow and fixed cameras [rad] (45°).
inline constexpr double kDefaultFov = 0.7853981633974483;
/// Vertical field of view of the ceiling camera [rad]: 2·atan(240/520), a
/// 520-pixel focal length over 480 rows (docs/camapp.md).
inline constexpr double kCeilingCameraFov = 0.8650738;
/// Height of the ceiling camera above the floor [m].
inline constexpr double kCeilingCameraHeight = 2.7;

/// A camera. Thread-safety: plain value.
struct Camera {
  CameraKind kind = CameraKind::kFollow;  ///< Placement.
  double distance = 0.8;     ///< kFollow: eye to module [m], (0, 1000].
  double elevation = 0.45;   ///< kFollow: angle above the horizon [rad], [-π/2, π/2].
  double azimuth = -1.2;     ///< kFollow: module-to-eye direction [rad], any finite value.
  Eigen::Vector3d eye = Eigen::Vector3d(1.0, -1.0, 0.8);  ///< kFixed: eye [m].
  Eigen::Vector3d target = Eigen::Vector3d::Zero();      ///< kFixed: looked-at point; kTop: point below the camera [m].
  double height = kCeilingCameraHeight;  ///< kTop: height above the target [m], (0, 1000].
  /// Vertical field of view [rad], (0, 3.1]; 0 = kDefaultFov (kFollow,
  /// kFixed) or kCeilingCameraFov (kTop).
  double fov = 0.0;
};

/// The matrices a camera gives for one frame (column-major, OpenGL conventions).
struct View {
  Eigen::Matrix4d view = Eigen::Matrix4d::Identity();        ///< World -> eye.
  Eigen::Matrix4d projection = Eigen::Matrix4d::Identity();  ///< Eye -> clip.
  Eigen::Vector3d eye = Eigen::Vector3d::Zero();             ///< Eye position, world.
  Eigen::Vector3d target = Eigen::Vector3d::Zero();          ///< Looked-at point, world.
  int width = 0;   ///< Image width [px].
  int height = 0;  ///< Image height [px].
};

/// Throws yamor::Error: INVALID_ARGUMENT naming the field for a NaN or
/// infinite value or a fixed camera whose eye equals its target (no
/// direction); OUT_OF_RANGE for a distance, height or field of view outside
/// its range.
void ValidateCamera(const Camera& camera);

/// The view of `camera` on `scene` for a `width` x `height` image (validates
/// the camera). A follow camera on a scene without modules looks at the origin.
View ComputeView(const Camera& camera, const Scene& scene, int width, int height);

/// The pixel (x right, y down, pixel centres at +0.5) where `point` appears,
/// or nullopt when it is behind the eye.
std::optional<Eigen::Vector2d> Project(const View& view, const Eigen::Vector3d& point);

}  // namespace yamor::render
