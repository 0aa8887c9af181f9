// What the renderer draws: a plain description of one instant of a world —
// every module's body and handle pose, the module's shape, the central
// module (its LED), the ground's slope and static boxes. Built from a
// physics::World by bridge::SceneOf, or carried over SNP as a scene snapshot
// (proto/snp/scene.h) and converted with FromSnapshot.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Geometry>

namespace yamor::render {

/// A rigid pose in the world frame (z up from the ground plane z = 0).
struct Pose {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();                ///< [m].
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  ///< Unit quaternion.
};

/// The part of a module a shape box belongs to.
enum class ShapePart { kBody, kHandle };

/// One box of the module's shape, axis-aligned in its part's frame.
struct ShapeBox {
  ShapePart part = ShapePart::kBody;                ///< Body or handle.
  Eigen::Vector3d center = Eigen::Vector3d::Zero(); ///< Centre in the part frame [m].
  Eigen::Vector3d size = Eigen::Vector3d::Zero();   ///< Full edge lengths [m].
};

/// One module in the world.
struct SceneModule {
  int id = 0;               ///< Id shown in labels and the legend (the robot's real id).
  Pose body;                ///< Body frame.
  Pose handle;              ///< Handle frame.
  bool central = false;     ///< The tracked module: carries the LED.
  bool loose = false;       ///< In the world but not part of the robot.
  bool defective = false;   ///< Marked defective (drawn greyed).
};

/// A static box of the terrain.
struct StaticBox {
  Pose pose;                                      ///< Centre and orientation.
  Eigen::Vector3d size = Eigen::Vector3d::Zero(); ///< Full edge lengths [m].
};

/// One instant of a world. Thread-safety: plain value.
struct Scene {
  double time = 0.0;             ///< Simulated time [s] (shown in the legend).
  double slope = 0.0;            ///< Ground tilt [rad] (gravity rotated by it).
  double slope_direction = 0.0;  ///< Downhill azimuth [rad].
  std::vector<ShapeBox> shape;   ///< The module's boxes (every module has the same shape).
  /// The LED's position in the central module's body frame [m].
  Eigen::Vector3d led = Eigen::Vector3d(0.0, 0.0, 0.028);
  std::vector<SceneModule> modules;  ///< Modules in the world (put-away ones left out).
  std::vector<StaticBox> boxes;      ///< Static boxes on the ground.

  /// The central module, or nullptr when there is none.
  const SceneModule* Central() const;
  /// The unit "up" vector of the world: against gravity, tilted by the slope.
  Eigen::Vector3d Up() const;
};

/// An RGB colour, components in [0, 1].
using Color = std::array<float, 3>;

/// The colour of module `id` (a fixed palette of twelve hues, by id), so a
/// module keeps its colour in every frame and neighbours in a chain differ.
Color ModuleColor(int id);

/// Throws yamor::Error: INVALID_ARGUMENT naming the field for a non-finite
/// value, a non-unit quaternion, a box size <= 0 or an empty shape;
/// OUT_OF_RANGE for a slope outside [0, π/2) or a coordinate beyond 10 km.
void ValidateScene(const Scene& scene);

}  // namespace yamor::render
