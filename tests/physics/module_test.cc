#include "physics/module.h"

#include <cmath>

#include <gtest/gtest.h>

#include "physics/box_overlap.h"

namespace yamor::physics {
namespace {

TEST(ModuleTest, ConnectorNamesRoundTrip) {
  for (ConnectorId c : kAllConnectors) {
    const auto parsed = ParseConnectorName(ConnectorName(c));
    ASSERT_TRUE(parsed.has_value());
    EXPECT_EQ(*parsed, c);
  }
  EXPECT_FALSE(ParseConnectorName("frnt").has_value());
  EXPECT_FALSE(ParseConnectorName("Front").has_value());
  EXPECT_FALSE(ParseConnectorName("").has_value());
}

TEST(ModuleTest, ConnectorFramesAreOrthonormal) {
  for (ConnectorId c : kAllConnectors) {
    const ConnectorFrame& f = ConnectorFrameOf(c);
    EXPECT_NEAR(f.normal.norm(), 1.0, 1e-15) << ConnectorName(c);
    EXPECT_NEAR(f.north.norm(), 1.0, 1e-15) << ConnectorName(c);
    EXPECT_NEAR(f.normal.dot(f.north), 0.0, 1e-15) << ConnectorName(c);
  }
}

TEST(ModuleTest, ConnectorFramesMatchTheirFaces) {
  using namespace module;
  struct Expected {
    ConnectorId id;
    Part part;
    Eigen::Vector3d position;
    Eigen::Vector3d normal;
  };
  const Expected expected[] = {
      {ConnectorId::kFront, Part::kHandle, {kHandleReach, 0, 0}, Eigen::Vector3d::UnitX()},
      {ConnectorId::kRear, Part::kBody, {-kBodyLength / 2, 0, 0}, -Eigen::Vector3d::UnitX()},
      {ConnectorId::kLeft, Part::kBody, {kSideConnectorX, kBodyWidth / 2, 0},
       Eigen::Vector3d::UnitY()},
      {ConnectorId::kRight, Part::kBody, {kSideConnectorX, -kBodyWidth / 2, 0},
       -Eigen::Vector3d::UnitY()},
      {ConnectorId::kTop, Part::kBody, {kSideConnectorX, 0, kBodyHeight / 2},
       Eigen::Vector3d::UnitZ()},
      {ConnectorId::kBottom, Part::kBody, {kSideConnectorX, 0, -kBodyHeight / 2},
       -Eigen::Vector3d::UnitZ()},
  };
  for (const Expected& e : expected) {
    const ConnectorFrame& f = ConnectorFrameOf(e.id);
    EXPECT_EQ(f.part, e.part) << ConnectorName(e.id);
    EXPECT_TRUE(f.position.isApprox(e.position, 1e-12)) << ConnectorName(e.id);
    EXPECT_TRUE(f.normal.isApprox(e.normal, 1e-12)) << ConnectorName(e.id);
  }
}

TEST(ModuleTest, BodyConnectorsLieOnTheBodySurface) {
  const ModuleBox& body = ModuleBoxes()[0];
  ASSERT_EQ(body.name, "body");
  for (ConnectorId c : kAllConnectors) {
    const ConnectorFrame& f = ConnectorFrameOf(c);
    if (f.part != Part::kBody) continue;
    // On the face the normal points out of, and inside that face's extent.
    const Eigen::Vector3d half = body.size / 2;
    EXPECT_NEAR(f.position.dot(f.normal), half.dot(f.normal.cwiseAbs()), 1e-12);
    EXPECT_TRUE((f.position.cwiseAbs().array() <= half.array() + 1e-12).all());
  }
}

TEST(ModuleTest, FrontConnectorIsTheCrossbarOuterFace) {
  const ModuleBox* crossbar = nullptr;
  for (const ModuleBox& box : ModuleBoxes()) {
    if (box.name == "crossbar") crossbar = &box;
  }
  ASSERT_NE(crossbar, nullptr);
  EXPECT_EQ(crossbar->part, Part::kHandle);
  const ConnectorFrame& front = ConnectorFrameOf(ConnectorId::kFront);
  EXPECT_NEAR(crossbar->center.x() + crossbar->size.x() / 2, front.position.x(), 1e-12);
}

TEST(ModuleTest, MassIsTheSumOfTheBoxes) {
  double sum = 0;
  for (const ModuleBox& box : ModuleBoxes()) sum += box.mass;
  EXPECT_NEAR(sum, ModuleMass(), 1e-12);
  EXPECT_NEAR(ModuleMass(), module::kBodyMass + module::kHandleMass, 1e-12);
}

TEST(ModuleTest, PositiveServoAngleTurnsTheTipDown) {
  const Eigen::Vector3d tip = ConnectorFrameOf(ConnectorId::kFront).position;
  const Eigen::Vector3d at_zero = HandleInBody(0) * tip;
  const Eigen::Vector3d at_plus = HandleInBody(0.5) * tip;
  EXPECT_LT(at_plus.z(), at_zero.z() - 0.01);
  EXPECT_NEAR((at_plus - HingePivot()).norm(), (at_zero - HingePivot()).norm(), 1e-12);
}

TEST(ModuleTest, HandleClearsTheBodyAtEveryAngle) {
  // The handle turns through ±90° without touching its own body box.
  const auto body = ModuleWorldBoxes(Eigen::Isometry3d::Identity(), 0)[0];
  for (double angle = -module::kServoLimit; angle <= module::kServoLimit; angle += 0.05) {
    const auto boxes = ModuleWorldBoxes(Eigen::Isometry3d::Identity(), angle);
    for (size_t i = 1; i < boxes.size(); ++i) {
      EXPECT_FALSE(BoxesOverlap(body, boxes[i], 0.0)) << "angle " << angle << " box " << i;
    }
  }
}

}  // namespace
}  // namespace yamor::physics
