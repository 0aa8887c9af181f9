// The physical graph of a robot: which modules exist and which connector of
// one is screwed onto which connector of another, at which angle. Immutable
// and validated on construction; module poses are computed from connector
// frames with every servo at its starting angle (0 unless the file gives one;
// thesis 5.4.2 places at 0). The XML format is documented in docs/module.md.
#pragma once

#include <cstddef>
#include <filesystem>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Geometry>

#include "physics/module.h"

namespace yamor::physics {

/// One module of a morphology.
struct MorphologyModule {
  int id = 0;         ///< The module's real id (matches the robot configuration).
  bool free = false;  ///< A spare module, not part of the robot until connected.
  int line = 0;       ///< Source line (0 when built in code).
  /// Starting hinge angle in degrees (XML `angle`), finite and within ±90.
  double angle_degrees = 0.0;

  /// The starting hinge angle in radians.
  double StartAngle() const;
};

/// One connection: connector `from_connector` of module `from` is mated to
/// `to_connector` of module `to`, the norths `angle_steps`·15° apart.
struct MorphologyConnection {
  int from = 0;                                    ///< Source module id (idfrom).
  ConnectorId from_connector = ConnectorId::kFront;  ///< connfrom.
  int to = 0;                                      ///< Destination module id (idto).
  ConnectorId to_connector = ConnectorId::kRear;   ///< connto.
  int angle_steps = 0;                             ///< Connection angle / 15°, in [0, 24).
  int line = 0;                                    ///< Source line (0 when built in code).
};

/// A static box of the world the robot lives in (a table, a platform, a
/// step): never moves, collides with every module with the ground's friction.
/// Given by a world file's `<box>` elements (docs/module.md).
struct StaticBox {
  std::string name;  ///< Name in messages (XML `name`; default "box N", N counted from 1).
  Eigen::Vector3d size = Eigen::Vector3d::Zero();      ///< Full edge lengths [m], each in [0.001, 1000].
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< Centre in the world frame [m].
  /// Roll, pitch, yaw of the box in degrees (as the morphology's orientation).
  Eigen::Vector3d orientation_degrees = Eigen::Vector3d::Zero();
  int line = 0;  ///< Source line (0 when built in code).

  /// The box's pose in the world frame (centre and rotation).
  Eigen::Isometry3d Pose() const;
};

/// Most static boxes in one world (what a rendered scene can carry).
inline constexpr std::size_t kMaxStaticBoxes = 1024;
/// Largest static box edge and coordinate magnitude [m].
inline constexpr double kMaxStaticBoxExtent = 1000.0;
/// Smallest static box edge [m] (thinner boxes make ODE's contacts degenerate).
inline constexpr double kMinStaticBoxEdge = 0.001;

/// A validated morphology with the pose of every connected module, and the
/// static boxes of the world it is placed in (the world file carries both).
/// Thread-safety: immutable after construction; safe to share between threads.
class Morphology {
 public:
  /// Loads and validates a morphology file. Errors: kNotFound when the file
  /// cannot be read, kInvalidArgument (message with file:line) when invalid.
  static Morphology LoadFile(const std::filesystem::path& path);

  /// Parses and validates XML text; `source` names it in error messages.
  static Morphology Parse(std::string_view xml, std::string_view source);

  /// Validates a morphology built in code (same rules as the XML path).
  /// `orientation_degrees` is roll, pitch, yaw of the central module;
  /// `boxes` the static boxes of its world.
  static Morphology Build(int central, std::vector<MorphologyModule> modules,
                          std::vector<MorphologyConnection> connections,
                          const Eigen::Vector3d& orientation_degrees = Eigen::Vector3d::Zero(),
                          std::string source = "<built>", std::vector<StaticBox> boxes = {});

  /// Id of the central (tracked, LED-carrying) module.
  int central() const { return central_; }
  /// Where the morphology came from (file path or a given name).
  const std::string& source() const { return source_; }
  /// Modules in declaration order.
  const std::vector<MorphologyModule>& modules() const { return modules_; }
  /// Connections in declaration order.
  const std::vector<MorphologyConnection>& connections() const { return connections_; }
  /// Roll, pitch, yaw (degrees) of the central module in the robot frame.
  const Eigen::Vector3d& orientation_degrees() const { return orientation_degrees_; }
  /// Static boxes of the world, in declaration order.
  const std::vector<StaticBox>& boxes() const { return boxes_; }

  /// True when a module with this id exists.
  bool Contains(int id) const { return index_.count(id) != 0; }
  /// The module with this id; kNotFound when absent.
  const MorphologyModule& Module(int id) const;
  /// Body pose of a connected module in the robot frame (central module at
  /// the origin, every servo at its starting angle); kNotFound for an unknown id, kFailedPrecondition
  /// for a free module.
  const Eigen::Isometry3d& BodyPose(int id) const;

  /// Canonical XML of this morphology.
  std::string ToXml() const;

 private:
  Morphology() = default;
  void Validate();
  void ValidateBoxes();
  std::string Where(int line) const;

  int central_ = 0;
  std::string source_;
  std::vector<MorphologyModule> modules_;
  std::vector<MorphologyConnection> connections_;
  Eigen::Vector3d orientation_degrees_ = Eigen::Vector3d::Zero();
  std::vector<StaticBox> boxes_;
  std::map<int, size_t> index_;                  // id -> modules_ index
  std::map<int, Eigen::Isometry3d> body_poses_;  // connected modules only
};

/// Rotation of roll, pitch, yaw (degrees) about fixed x, y, z axes: Rz·Ry·Rx.
Eigen::Matrix3d RotationFromRollPitchYaw(const Eigen::Vector3d& degrees);

/// The frame axis (±x, ±y or ±z, a unit vector) nearest to `direction`
/// (any non-zero vector; ties go to x, then y).
Eigen::Vector3d NearestFrameAxis(const Eigen::Vector3d& direction);

/// The central module's axis, in its own frame, that points up in the
/// morphology's starting pose: the face carrying the tracking LED (the LED
/// looks up at the ceiling camera when the robot stands as built).
Eigen::Vector3d CentralUpAxis(const Morphology& morphology);

}  // namespace yamor::physics
