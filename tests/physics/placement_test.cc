#include "physics/placement.h"

#include <cmath>

#include <gtest/gtest.h>

namespace yamor::physics {
namespace {

Eigen::Isometry3d SomePose() {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = (Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()) *
                   Eigen::AngleAxisd(-0.3, Eigen::Vector3d::UnitX()))
                      .toRotationMatrix();
  pose.translation() = Eigen::Vector3d(0.3, -0.2, 0.15);
  return pose;
}

TEST(PlacementTest, EveryConnectorPairAndAngleMates) {
  const Eigen::Isometry3d fixed_body = SomePose();
  for (double fixed_servo : {0.0, 0.6}) {
    for (ConnectorId fixed : kAllConnectors) {
      for (ConnectorId moving : kAllConnectors) {
        for (int steps : {0, 1, 5, 6, 12, 17, 23}) {
          const Eigen::Isometry3d moving_body =
              MateBodyPose(fixed_body, fixed_servo, fixed, moving, 0.0, steps);
          const WorldConnector a = ModuleConnector(fixed_body, fixed_servo, fixed);
          const WorldConnector b = ModuleConnector(moving_body, 0.0, moving);
          SCOPED_TRACE(std::string(ConnectorName(fixed)) + " <- " +
                       std::string(ConnectorName(moving)) + " steps " + std::to_string(steps));
          EXPECT_TRUE(b.normal.isApprox(-a.normal, 1e-12));
          const Eigen::Vector3d gap = b.position - a.position;
          EXPECT_NEAR(gap.norm(), module::kConnectionGap, 1e-12);
          EXPECT_NEAR(gap.dot(a.normal), module::kConnectionGap, 1e-12);
          double angle = SignedAngle(a.north, b.north, a.normal);
          if (angle < -1e-9) angle += 2 * M_PI;
          EXPECT_NEAR(angle, steps * module::kConnectionAngleStep, 1e-9);
          EXPECT_TRUE(moving_body.linear().isUnitary(1e-12));
          EXPECT_NEAR(moving_body.linear().determinant(), 1.0, 1e-12);
        }
      }
    }
  }
}

TEST(PlacementTest, MatingIsSymmetric) {
  // Placing B from A at angle φ, then A from B at φ, gives A back.
  const Eigen::Isometry3d a = SomePose();
  for (ConnectorId ca : kAllConnectors) {
    for (ConnectorId cb : kAllConnectors) {
      for (int steps : {0, 3, 13}) {
        const Eigen::Isometry3d b = MateBodyPose(a, 0, ca, cb, 0, steps);
        const Eigen::Isometry3d back = MateBodyPose(b, 0, cb, ca, 0, steps);
        EXPECT_TRUE(back.isApprox(a, 1e-12))
            << ConnectorName(ca) << " " << ConnectorName(cb) << " " << steps;
      }
    }
  }
}

TEST(PlacementTest, MovingHandleAtAnAngleStillMates) {
  const Eigen::Isometry3d fixed_body = SomePose();
  const Eigen::Isometry3d moving_body =
      MateBodyPose(fixed_body, 0.2, ConnectorId::kTop, ConnectorId::kFront, -0.9, 4);
  const WorldConnector a = ModuleConnector(fixed_body, 0.2, ConnectorId::kTop);
  const WorldConnector b = ModuleConnector(moving_body, -0.9, ConnectorId::kFront);
  EXPECT_TRUE(b.normal.isApprox(-a.normal, 1e-12));
  EXPECT_NEAR((b.position - a.position - module::kConnectionGap * a.normal).norm(), 0, 1e-12);
}

TEST(PlacementTest, StraightChainSpacing) {
  // front -> rear at 0: modules in line, one module length plus the gap apart.
  const Eigen::Isometry3d next = MateBodyPose(Eigen::Isometry3d::Identity(), 0,
                                              ConnectorId::kFront, ConnectorId::kRear, 0, 0);
  const double length = module::kPivotX + module::kHandleReach + module::kBodyLength / 2;
  EXPECT_TRUE(next.linear().isIdentity(1e-12));
  EXPECT_NEAR(next.translation().x(), length + module::kConnectionGap, 1e-12);
  EXPECT_NEAR(next.translation().tail<2>().norm(), 0, 1e-12);
}

}  // namespace
}  // namespace yamor::physics
