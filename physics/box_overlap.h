// Separating-axis test for oriented boxes: used to reject morphologies whose
// modules interpenetrate and to find room for a module being connected.
#pragma once

#include <vector>

#include <Eigen/Geometry>

namespace yamor::physics {

/// An oriented box: pose of its centre and half edge lengths.
/// Thread-safety: plain value.
struct OrientedBox {
  Eigen::Isometry3d pose;      ///< Centre and orientation.
  Eigen::Vector3d half_size;   ///< Half edge lengths along the box axes.
};

/// True when the two boxes, each shrunk by `tolerance` on every face, intersect.
/// A positive tolerance lets faces that touch (or nearly do) pass as disjoint.
bool BoxesOverlap(const OrientedBox& a, const OrientedBox& b, double tolerance);

/// The world boxes of one module at body pose `body_pose` and servo angle `servo`.
std::vector<OrientedBox> ModuleWorldBoxes(const Eigen::Isometry3d& body_pose, double servo);

/// Lowest z over all corners of `boxes`.
double LowestPoint(const std::vector<OrientedBox>& boxes);

}  // namespace yamor::physics
