#include "physics/module.h"

#include "common/status.h"

namespace yamor::physics {
namespace {

using Eigen::Vector3d;
using namespace module;

constexpr double kHalfLength = kBodyLength / 2;
constexpr double kHalfWidth = kBodyWidth / 2;
constexpr double kHalfHeight = kBodyHeight / 2;

// Handle: two arms outside the body's side faces joined by a crossbar whose
// outer face carries the screw. Arms start a little behind the pivot so the
// hinge sits inside them.
constexpr double kCrossbarThickness = 0.010;  // along x
constexpr double kCrossbarHeight = 0.020;     // along z
constexpr double kArmThickness = 0.004;       // along y
constexpr double kArmHeight = 0.014;          // along z
constexpr double kArmClearance = 0.001;       // between body side face and arm
constexpr double kArmBehindPivot = 0.006;
constexpr double kArmY = kHalfWidth + kArmClearance + kArmThickness / 2;
constexpr double kHandleWidth = 2 * (kHalfWidth + kArmClearance + kArmThickness);
constexpr double kArmLength = kArmBehindPivot + kHandleReach - kCrossbarThickness;
constexpr double kArmMass = 0.004;
constexpr double kCrossbarMass = kHandleMass - 2 * kArmMass;

const std::array<ConnectorFrame, kConnectorCount>& Frames() {
  static const std::array<ConnectorFrame, kConnectorCount> frames = {{
      {Part::kHandle, Vector3d(kHandleReach, 0, 0), Vector3d::UnitX(), Vector3d::UnitZ()},
      {Part::kBody, Vector3d(-kHalfLength, 0, 0), -Vector3d::UnitX(), Vector3d::UnitZ()},
      {Part::kBody, Vector3d(kSideConnectorX, kHalfWidth, 0), Vector3d::UnitY(),
       Vector3d::UnitZ()},
      {Part::kBody, Vector3d(kSideConnectorX, -kHalfWidth, 0), -Vector3d::UnitY(),
       Vector3d::UnitZ()},
      {Part::kBody, Vector3d(kSideConnectorX, 0, kHalfHeight), Vector3d::UnitZ(),
       Vector3d::UnitX()},
      {Part::kBody, Vector3d(kSideConnectorX, 0, -kHalfHeight), -Vector3d::UnitZ(),
       Vector3d::UnitX()},
  }};
  return frames;
}

const std::array<ModuleBox, 4>& Boxes() {
  static const std::array<ModuleBox, 4> boxes = {{
      {Part::kBody, Vector3d::Zero(), Vector3d(kBodyLength, kBodyWidth, kBodyHeight), kBodyMass,
       "body"},
      {Part::kHandle, Vector3d(kArmLength / 2 - kArmBehindPivot, kArmY, 0),
       Vector3d(kArmLength, kArmThickness, kArmHeight), kArmMass, "arm_left"},
      {Part::kHandle, Vector3d(kArmLength / 2 - kArmBehindPivot, -kArmY, 0),
       Vector3d(kArmLength, kArmThickness, kArmHeight), kArmMass, "arm_right"},
      {Part::kHandle, Vector3d(kHandleReach - kCrossbarThickness / 2, 0, 0),
       Vector3d(kCrossbarThickness, kHandleWidth, kCrossbarHeight), kCrossbarMass, "crossbar"},
  }};
  return boxes;
}

}  // namespace

std::string_view ConnectorName(ConnectorId connector) {
  switch (connector) {
    case ConnectorId::kFront: return "front";
    case ConnectorId::kRear: return "rear";
    case ConnectorId::kLeft: return "left";
    case ConnectorId::kRight: return "right";
    case ConnectorId::kTop: return "top";
    case ConnectorId::kBottom: return "bottom";
  }
  YAMOR_CHECK(false, "bad ConnectorId");
  return "";
}

std::optional<ConnectorId> ParseConnectorName(std::string_view name) {
  for (ConnectorId c : kAllConnectors) {
    if (ConnectorName(c) == name) return c;
  }
  return std::nullopt;
}

const ConnectorFrame& ConnectorFrameOf(ConnectorId connector) {
  const int index = static_cast<int>(connector);
  YAMOR_CHECK(index >= 0 && index < kConnectorCount, "bad ConnectorId");
  return Frames()[static_cast<size_t>(index)];
}

std::span<const ModuleBox> ModuleBoxes() { return Boxes(); }

double ModuleMass() { return kBodyMass + kHandleMass; }

Eigen::Vector3d HingePivot() { return Vector3d(kPivotX, 0, 0); }

Eigen::Vector3d HingeAxis() { return Vector3d::UnitY(); }

Eigen::Isometry3d HandleInBody(double angle) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = HingePivot();
  pose.linear() = Eigen::AngleAxisd(angle, HingeAxis()).toRotationMatrix();
  return pose;
}

Eigen::Isometry3d PartPose(const Eigen::Isometry3d& body_pose, Part part, double servo_angle) {
  if (part == Part::kBody) return body_pose;
  return body_pose * HandleInBody(servo_angle);
}

}  // namespace yamor::physics
