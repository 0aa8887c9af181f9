#include "physics/box_overlap.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "physics/module.h"

namespace yamor::physics {
namespace {

// Projected half extent of a box onto a unit axis.
double Radius(const Eigen::Matrix3d& axes, const Eigen::Vector3d& half,
              const Eigen::Vector3d& axis) {
  return half.x() * std::abs(axes.col(0).dot(axis)) + half.y() * std::abs(axes.col(1).dot(axis)) +
         half.z() * std::abs(axes.col(2).dot(axis));
}

}  // namespace

bool BoxesOverlap(const OrientedBox& a, const OrientedBox& b, double tolerance) {
  const Eigen::Vector3d ha = (a.half_size.array() - tolerance).max(0.0).matrix();
  const Eigen::Vector3d hb = (b.half_size.array() - tolerance).max(0.0).matrix();
  const Eigen::Vector3d d = b.pose.translation() - a.pose.translation();
  if (d.norm() > ha.norm() + hb.norm()) return false;
  const Eigen::Matrix3d& ra = a.pose.linear();
  const Eigen::Matrix3d& rb = b.pose.linear();
  Eigen::Vector3d axes[15];
  int count = 0;
  for (int i = 0; i < 3; ++i) axes[count++] = ra.col(i);
  for (int i = 0; i < 3; ++i) axes[count++] = rb.col(i);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      const Eigen::Vector3d cross = ra.col(i).cross(rb.col(j));
      const double norm = cross.norm();
      if (norm > 1e-9) axes[count++] = cross / norm;  // parallel edges: covered by face axes
    }
  }
  for (int k = 0; k < count; ++k) {
    const double separation = std::abs(d.dot(axes[k]));
    if (separation >= Radius(ra, ha, axes[k]) + Radius(rb, hb, axes[k])) return false;
  }
  return true;
}

std::vector<OrientedBox> ModuleWorldBoxes(const Eigen::Isometry3d& body_pose, double servo) {
  std::vector<OrientedBox> boxes;
  const Eigen::Isometry3d handle = PartPose(body_pose, Part::kHandle, servo);
  for (const ModuleBox& box : ModuleBoxes()) {
    const Eigen::Isometry3d& part = box.part == Part::kBody ? body_pose : handle;
    OrientedBox world;
    world.pose = part * Eigen::Translation3d(box.center);
    world.half_size = box.size / 2;
    boxes.push_back(world);
  }
  return boxes;
}

double LowestPoint(const std::vector<OrientedBox>& boxes) {
  double lowest = std::numeric_limits<double>::infinity();
  for (const OrientedBox& box : boxes) {
    for (int corner = 0; corner < 8; ++corner) {
      const Eigen::Vector3d local((corner & 1) ? box.half_size.x() : -box.half_size.x(),
                                  (corner & 2) ? box.half_size.y() : -box.half_size.y(),
                                  (corner & 4) ? box.half_size.z() : -box.half_size.z());
      lowest = std::min(lowest, (box.pose * local).z());
    }
  }
  return lowest;
}

}  // namespace yamor::physics
