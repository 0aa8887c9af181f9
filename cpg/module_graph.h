// The module graph of thesis 7.4.1: vertices are the robot's modules (driven
// or passive), edges its physical connections labelled with both connectors
// and the connection angle. A plain value type with no ODE in it; a
// physics::Morphology (or a world as it is now) produces one.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "cpg/robot_config.h"

namespace yamor::cpg {

/// The six connectors of a YaMoR module (docs/module.md, "Connectors").
enum class Connector : uint8_t { kFront, kRear, kLeft, kRight, kTop, kBottom };

/// Number of connectors of a module.
inline constexpr int kConnectorCount = 6;

/// Connection angles are multiples of 15°: 24 steps make a turn.
inline constexpr int kAngleSteps = 24;

/// The connector's name as in a morphology file ("front", "rear", ...).
std::string_view ConnectorName(Connector connector);

/// The connector named `name`, or nullopt.
std::optional<Connector> ConnectorFromName(std::string_view name);

/// The connector on the other side of the module body (front/rear,
/// left/right, top/bottom).
Connector OppositeConnector(Connector connector);

/// Outward unit normal of a connector in the frame of the part carrying it
/// (docs/module.md): integer entries.
Eigen::Vector3i ConnectorNormal(Connector connector);

/// Unit north vector of a connector (perpendicular to its normal).
Eigen::Vector3i ConnectorNorth(Connector connector);

/// One module of the graph.
struct GraphModule {
  ModuleId id = 0;      ///< Real id.
  bool active = true;   ///< Driven (has an oscillator) or passive.
  /// Rotation of the module body in the robot frame, when the graph comes
  /// from a placed morphology; used to keep only symmetries that respect
  /// gravity.
  std::optional<Eigen::Matrix3d> orientation;

  friend bool operator==(const GraphModule&, const GraphModule&) = default;
};

/// One physical connection: connector `a_connector` of module `a` mates
/// `b_connector` of module `b`; `angle_steps`·15° is the angle from b's north
/// to a's north about b's outward normal (the same seen from either end,
/// docs/module.md).
struct GraphEdge {
  ModuleId a = 0;                              ///< One module.
  Connector a_connector = Connector::kFront;   ///< Its connector.
  ModuleId b = 0;                              ///< The other module.
  Connector b_connector = Connector::kRear;    ///< Its connector.
  int angle_steps = 0;                         ///< In [0, 24).

  friend bool operator==(const GraphEdge&, const GraphEdge&) = default;
};

/// A validated module graph. Immutable after construction.
/// Thread-safety: const access is safe from any number of threads.
class ModuleGraph {
 public:
  /// Validates and builds. Throws yamor::Error kInvalidArgument naming the
  /// module or edge: no module, an id outside 0..254 or repeated, an edge to
  /// an unknown module or to itself, a connector used twice on one module,
  /// an angle outside [0, 24), a central module that is not in the graph,
  /// orientations given for some modules but not all, or a non-unit `up`.
  ModuleGraph(ModuleId central, std::vector<GraphModule> modules,
              std::vector<GraphEdge> edges,
              std::optional<Eigen::Vector3d> up = std::nullopt);

  /// The central (tracked) module.
  ModuleId central() const { return central_; }
  /// Modules sorted by id.
  const std::vector<GraphModule>& modules() const { return modules_; }
  /// Edges in the order given.
  const std::vector<GraphEdge>& edges() const { return edges_; }
  /// The robot frame's up direction (against gravity), when known.
  const std::optional<Eigen::Vector3d>& up() const { return up_; }
  /// True when every module carries an orientation.
  bool has_geometry() const { return !modules_.empty() && modules_.front().orientation.has_value(); }

  /// True when a module with `id` exists.
  bool Contains(ModuleId id) const;
  /// The module with `id`; kNotFound when absent.
  const GraphModule& Module(ModuleId id) const;
  /// Index of `id` in modules(); kNotFound when absent.
  int IndexOf(ModuleId id) const;
  /// Ids of the modules physically connected to `id`, sorted.
  std::vector<ModuleId> Neighbours(ModuleId id) const;

  /// Connected pieces, each sorted by id. The largest comes first; among
  /// equal sizes the one holding the central module, then the one with the
  /// smallest id.
  std::vector<std::vector<ModuleId>> Components() const;

  /// The graph restricted to `ids` (edges inside it only); the central module
  /// stays when kept, else the smallest id becomes central.
  ModuleGraph Subgraph(const std::vector<ModuleId>& ids) const;

  /// The same graph with every module passive or driven as `active` says
  /// (modules not listed keep their flag).
  ModuleGraph WithActivity(const std::vector<std::pair<ModuleId, bool>>& active) const;

  /// A human-readable listing: modules with flags, then each edge.
  std::string Describe() const;

 private:
  ModuleId central_ = 0;
  std::vector<GraphModule> modules_;
  std::vector<GraphEdge> edges_;
  std::optional<Eigen::Vector3d> up_;
};

/// The passive/driven split a robot configuration implies for the modules
/// `ids`: a module whose oscillator is all zero (amplitude, offset and speed
/// 0) is passive, as bridge::IsInactive decides, and so is a module the
/// configuration does not name (it is never configured, and a module powers
/// up with its motor off).
std::vector<std::pair<ModuleId, bool>> ActivityFromConfig(const RobotConfig& config,
                                                          const std::vector<ModuleId>& ids);

}  // namespace yamor::cpg
