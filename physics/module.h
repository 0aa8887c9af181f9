// The YaMoR module as a rigid-body model: a body box and a U-shaped handle on
// a 1-DOF hinge, six connectors, and a hobby servo. Pure geometry and data:
// nothing here touches ODE. Figures and their sources are in docs/module.md.
#pragma once

#include <array>
#include <optional>
#include <span>
#include <string_view>

#include <Eigen/Geometry>

namespace yamor::physics {

/// A rigid part of a module: the body box, or the handle the servo moves.
enum class Part { kBody = 0, kHandle = 1 };

/// The six connectors of a module. `kFront` is the screw at the handle's tip.
enum class ConnectorId { kFront = 0, kRear, kLeft, kRight, kTop, kBottom };

/// Number of connectors on a module.
inline constexpr int kConnectorCount = 6;

/// All connectors in declaration order (front, rear, left, right, top, bottom).
inline constexpr std::array<ConnectorId, kConnectorCount> kAllConnectors = {
    ConnectorId::kFront, ConnectorId::kRear, ConnectorId::kLeft,
    ConnectorId::kRight, ConnectorId::kTop,  ConnectorId::kBottom};

/// The thesis's name of a connector: "front", "rear", "left", "right", "top", "bottom".
std::string_view ConnectorName(ConnectorId connector);

/// Parses a connector name (exact, lower case); nullopt when unknown.
std::optional<ConnectorId> ParseConnectorName(std::string_view name);

/// A connector in the frame of the part that carries it.
/// Thread-safety: plain value; the table returned by ConnectorFrameOf is immutable.
struct ConnectorFrame {
  Part part;                  ///< Part carrying the connector.
  Eigen::Vector3d position;   ///< Centre of the mating face, metres, part frame.
  Eigen::Vector3d normal;     ///< Unit outward normal, part frame.
  Eigen::Vector3d north;      ///< Unit "north" vector, perpendicular to normal.
};

/// The fixed frame of `connector` in its part's frame.
const ConnectorFrame& ConnectorFrameOf(ConnectorId connector);

/// One collision/mass box of a module, axis-aligned in its part's frame.
struct ModuleBox {
  Part part;                ///< Part the box belongs to.
  Eigen::Vector3d center;   ///< Box centre in the part frame, metres.
  Eigen::Vector3d size;     ///< Full edge lengths (x, y, z), metres.
  double mass;              ///< Mass in kg (uniform density within the box).
  std::string_view name;    ///< "body", "arm_left", "arm_right", "crossbar".
};

/// The boxes that make up one module (body box, two handle arms, crossbar).
std::span<const ModuleBox> ModuleBoxes();

/// Geometry, mass and servo figures of a YaMoR module (see docs/module.md).
/// Frames: the body frame has its origin at the centre of the body box, x along
/// the module towards the handle, y along the hinge axis (towards `left`), z
/// towards `top`. The handle frame has its origin on the hinge axis at the pivot
/// and coincides in orientation with the body frame when the servo is at 0.
namespace module {
inline constexpr double kBodyLength = 0.070;   ///< Body box along x, m.
inline constexpr double kBodyWidth = 0.050;    ///< Body box along y, m.
inline constexpr double kBodyHeight = 0.050;   ///< Body box along z, m.
inline constexpr double kPivotX = 0.027;       ///< Hinge axis x in the body frame, m.
inline constexpr double kHandleReach = 0.045;  ///< Pivot to front connector, m.
inline constexpr double kSideConnectorX = -0.010;  ///< x of left/right/top/bottom connectors, m.
inline constexpr double kBodyMass = 0.080;     ///< Body (servo, electronics, battery), kg.
inline constexpr double kHandleMass = 0.020;   ///< U-shaped handle, kg.
inline constexpr double kServoLimit = 1.5707963267948966;  ///< Hinge range ±90°, rad.
inline constexpr double kConnectionAngleStep = 0.2617993877991494;  ///< 15° = π/12, rad.
inline constexpr int kConnectionAngleSteps = 24;  ///< Distinct connection angles per turn.
inline constexpr double kConnectionGap = 1e-4;  ///< Gap between mated connectors (thesis 5.4.2), m.
/// Position of the accelerometer (sensor board at the bottom of the box), body frame.
inline const Eigen::Vector3d kSensorPosition{0.0, 0.0, -0.020};
}  // namespace module

/// Total mass of one module, kg.
double ModuleMass();

/// The hinge pivot point in the body frame.
Eigen::Vector3d HingePivot();

/// The hinge axis (unit, +y) in the body frame; a positive servo angle turns the
/// handle by that angle about this axis (right-hand rule), so the tip moves to -z.
Eigen::Vector3d HingeAxis();

/// Pose of the handle frame in the body frame at servo angle `angle` (rad).
Eigen::Isometry3d HandleInBody(double angle);

/// Pose of `part` in the world, given the body pose and the servo angle.
Eigen::Isometry3d PartPose(const Eigen::Isometry3d& body_pose, Part part, double servo_angle);

/// Servo model: a hobby position servo as a velocity-limited, torque-limited
/// P-controller on the hinge (see docs/module.md for the figures and sources).
/// Thread-safety: plain value.
struct ServoSpec {
  double stall_torque = 0.30;     ///< Maximum motor torque, N·m.
  double max_speed = 5.236;       ///< No-load speed, rad/s (60° in 0.2 s).
  double gain = 20.0;             ///< P gain: commanded speed per rad of error, 1/s.
  double limp_friction = 0.002;   ///< Back-drive friction torque when unpowered/limp, N·m.
  double lock_torque = 50.0;      ///< Torque holding a stuck (jammed) servo, N·m.
  double lock_gain = 200.0;       ///< P gain keeping a stuck servo at its angle, 1/s.
};

}  // namespace yamor::physics
