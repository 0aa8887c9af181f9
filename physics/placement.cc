#include "physics/placement.h"

#include <cmath>

namespace yamor::physics {
namespace {

// Orthonormal basis (normal, north, normal × north) as matrix columns.
Eigen::Matrix3d Basis(const Eigen::Vector3d& normal, const Eigen::Vector3d& north) {
  Eigen::Matrix3d basis;
  basis.col(0) = normal;
  basis.col(1) = north;
  basis.col(2) = normal.cross(north);
  return basis;
}

}  // namespace

WorldConnector ConnectorInFrame(const Eigen::Isometry3d& part_pose, ConnectorId connector) {
  const ConnectorFrame& local = ConnectorFrameOf(connector);
  return {part_pose * local.position, part_pose.linear() * local.normal,
          part_pose.linear() * local.north};
}

WorldConnector ModuleConnector(const Eigen::Isometry3d& body_pose, double servo_angle,
                               ConnectorId connector) {
  const Part part = ConnectorFrameOf(connector).part;
  return ConnectorInFrame(PartPose(body_pose, part, servo_angle), connector);
}

Eigen::Isometry3d MatePartPose(const Eigen::Isometry3d& fixed_part_pose, ConnectorId fixed,
                               ConnectorId moving, int angle_steps, double gap) {
  const WorldConnector target = ConnectorInFrame(fixed_part_pose, fixed);
  const double phi = angle_steps * module::kConnectionAngleStep;
  const Eigen::Vector3d normal = -target.normal;
  const Eigen::Vector3d north = Eigen::AngleAxisd(phi, target.normal) * target.north;

  const ConnectorFrame& local = ConnectorFrameOf(moving);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Basis(normal, north) * Basis(local.normal, local.north).transpose();
  const Eigen::Vector3d face = target.position + gap * target.normal;
  pose.translation() = face - pose.linear() * local.position;
  return pose;
}

Eigen::Isometry3d MateBodyPose(const Eigen::Isometry3d& fixed_body, double fixed_servo,
                               ConnectorId fixed, ConnectorId moving, double moving_servo,
                               int angle_steps, double gap) {
  const Part fixed_part = ConnectorFrameOf(fixed).part;
  const Eigen::Isometry3d part_pose =
      MatePartPose(PartPose(fixed_body, fixed_part, fixed_servo), fixed, moving, angle_steps, gap);
  if (ConnectorFrameOf(moving).part == Part::kBody) return part_pose;
  return part_pose * HandleInBody(moving_servo).inverse();
}

double SignedAngle(const Eigen::Vector3d& from, const Eigen::Vector3d& to,
                   const Eigen::Vector3d& axis) {
  return std::atan2(axis.dot(from.cross(to)), from.dot(to));
}

}  // namespace yamor::physics
