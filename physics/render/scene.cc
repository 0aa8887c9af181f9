#include "physics/render/scene.h"

#include <cmath>
#include <string>

#include <fmt/format.h>

#include "common/status.h"

namespace yamor::render {
namespace {

constexpr double kMaxCoordinate = 1e4;  // [m]
constexpr double kHalfPi = 1.5707963267948966;

void CheckVector(const Eigen::Vector3d& v, const std::string& field) {
  for (int i = 0; i < 3; ++i) {
    if (!std::isfinite(v[i])) {
      throw Error(StatusCode::kInvalidArgument,
                  fmt::format("scene {}[{}] is not finite: {}", field, i, v[i]));
    }
    if (std::fabs(v[i]) > kMaxCoordinate) {
      throw Error(StatusCode::kOutOfRange, fmt::format("scene {}[{}] = {} m is beyond ±{} m",
                                                       field, i, v[i], kMaxCoordinate));
    }
  }
}

void CheckSize(const Eigen::Vector3d& size, const std::string& field) {
  CheckVector(size, field);
  for (int i = 0; i < 3; ++i) {
    if (!(size[i] > 0.0)) {
      throw Error(StatusCode::kInvalidArgument,
                  fmt::format("scene {}[{}] = {} is not > 0", field, i, size[i]));
    }
  }
}

void CheckPose(const Pose& pose, const std::string& field) {
  CheckVector(pose.position, field + ".position");
  const Eigen::Vector4d q = pose.orientation.coeffs();
  if (!q.allFinite()) {
    throw Error(StatusCode::kInvalidArgument,
                fmt::format("scene {}.orientation is not finite", field));
  }
  if (std::fabs(q.norm() - 1.0) > 1e-3) {
    throw Error(StatusCode::kInvalidArgument,
                fmt::format("scene {}.orientation has norm {}, not 1", field, q.norm()));
  }
}

}  // namespace

const SceneModule* Scene::Central() const {
  for (const SceneModule& m : modules) {
    if (m.central) return &m;
  }
  return nullptr;
}

Eigen::Vector3d Scene::Up() const {
  return Eigen::Vector3d(-std::sin(slope) * std::cos(slope_direction),
                         -std::sin(slope) * std::sin(slope_direction), std::cos(slope));
}

Color ModuleColor(int id) {
  // Twelve hues far apart, medium lightness, so lit faces stay readable and
  // the next id in a chain always has a clearly different colour.
  static constexpr Color kPalette[] = {
      {0.90f, 0.33f, 0.20f}, {0.20f, 0.55f, 0.90f}, {0.95f, 0.75f, 0.15f},
      {0.35f, 0.75f, 0.30f}, {0.70f, 0.35f, 0.85f}, {0.10f, 0.75f, 0.75f},
      {0.95f, 0.50f, 0.70f}, {0.55f, 0.45f, 0.25f}, {0.60f, 0.85f, 0.25f},
      {0.30f, 0.30f, 0.75f}, {0.95f, 0.60f, 0.35f}, {0.45f, 0.60f, 0.55f},
  };
  constexpr int kCount = static_cast<int>(std::size(kPalette));
  return kPalette[((id % kCount) + kCount) % kCount];
}

void ValidateScene(const Scene& scene) {
  if (!std::isfinite(scene.time)) {
    throw Error(StatusCode::kInvalidArgument,
                fmt::format("scene time is not finite: {}", scene.time));
  }
  if (!std::isfinite(scene.slope) || !std::isfinite(scene.slope_direction)) {
    throw Error(StatusCode::kInvalidArgument, "scene slope or slope direction is not finite");
  }
  if (scene.slope < 0.0 || scene.slope >= kHalfPi) {
    throw Error(StatusCode::kOutOfRange,
                fmt::format("scene slope {} rad is outside [0, pi/2)", scene.slope));
  }
  if (scene.shape.empty()) {
    throw Error(StatusCode::kInvalidArgument, "scene has no module shape (no shape boxes)");
  }
  for (std::size_t i = 0; i < scene.shape.size(); ++i) {
    CheckVector(scene.shape[i].center, fmt::format("shape[{}].center", i));
    CheckSize(scene.shape[i].size, fmt::format("shape[{}].size", i));
  }
  CheckVector(scene.led, "led");
  for (std::size_t i = 0; i < scene.modules.size(); ++i) {
    CheckPose(scene.modules[i].body, fmt::format("module {} body", scene.modules[i].id));
    CheckPose(scene.modules[i].handle, fmt::format("module {} handle", scene.modules[i].id));
  }
  for (std::size_t i = 0; i < scene.boxes.size(); ++i) {
    CheckPose(scene.boxes[i].pose, fmt::format("boxes[{}]", i));
    CheckSize(scene.boxes[i].size, fmt::format("boxes[{}].size", i));
  }
}

}  // namespace yamor::render
