// Module positioning (thesis 5.4.2) done directly with rotation matrices built
// from connector frames: the placed module's connector normal is opposite the
// fixed one's, the norths are at the connection angle, and the faces are kept
// a small gap apart.
#pragma once

#include <Eigen/Geometry>

#include "physics/module.h"

namespace yamor::physics {

/// A connector expressed in the world (or any common) frame.
/// Thread-safety: plain value.
struct WorldConnector {
  Eigen::Vector3d position;  ///< Centre of the mating face.
  Eigen::Vector3d normal;    ///< Unit outward normal.
  Eigen::Vector3d north;     ///< Unit north vector.
};

/// Frame of `connector` given the pose of the part that carries it.
WorldConnector ConnectorInFrame(const Eigen::Isometry3d& part_pose, ConnectorId connector);

/// Frame of `connector` given the module's body pose and its servo angle.
WorldConnector ModuleConnector(const Eigen::Isometry3d& body_pose, double servo_angle,
                               ConnectorId connector);

/// Pose of the part carrying `moving` so that it mates `fixed` (already at
/// `fixed_part_pose`): normals opposite, the moving north equal to the fixed
/// north turned by `angle_steps`·15° about the fixed outward normal, and the
/// moving face `gap` metres out along the fixed normal. The relation is
/// symmetric: mating A to B at angle φ puts B where mating B to A at φ would
/// leave it, so a connection can be resolved from either end.
Eigen::Isometry3d MatePartPose(const Eigen::Isometry3d& fixed_part_pose, ConnectorId fixed,
                               ConnectorId moving, int angle_steps,
                               double gap = module::kConnectionGap);

/// Body pose of a module whose connector `moving` (at servo angle
/// `moving_servo`) mates connector `fixed` of a module with body pose
/// `fixed_body` and servo angle `fixed_servo`.
Eigen::Isometry3d MateBodyPose(const Eigen::Isometry3d& fixed_body, double fixed_servo,
                               ConnectorId fixed, ConnectorId moving, double moving_servo,
                               int angle_steps, double gap = module::kConnectionGap);

/// Signed angle (rad) from `from` to `to` about `axis` (all unit, both ⟂ axis).
double SignedAngle(const Eigen::Vector3d& from, const Eigen::Vector3d& to,
                   const Eigen::Vector3d& axis);

}  // namespace yamor::physics
