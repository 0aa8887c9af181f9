// CPG network construction from the module graph (thesis 7.4.1): the largest
// connected piece, a coupling both ways for every physical edge, phase 0 and
// weight 1.
#pragma once

#include <string>
#include <vector>

#include "cpg/module_graph.h"

namespace yamor::cpg {

/// How passive modules enter the network.
struct NetworkOptions {
  /// Leave passive modules out of the network and couple across them
  /// (default). A passive module's oscillator has zero amplitude, so its
  /// coupling term r_j·sin(...) is zero and the thesis's literal network
  /// (every module an oscillator) would not connect the modules on either
  /// side of it. Across one passive module, neighbours on adjacent faces are
  /// coupled; neighbours on opposite faces only when the adjacent-face
  /// couplings leave them apart. Around a piece of several passive modules,
  /// every pair of driven neighbours is coupled. When false, every module of
  /// the piece is an oscillator and only physical edges are coupled.
  bool couple_across_passive = true;
};

/// One undirected coupling u–v (u < v) of the network; the robot gets the
/// two directed couplings u→v and v→u.
struct NetworkEdge {
  ModuleId u = 0;          ///< Smaller id.
  ModuleId v = 0;          ///< Larger id.
  bool physical = true;    ///< A physical connection, or across passive modules.
  ModuleId via = -1;       ///< The passive module crossed (the smallest, for a passive piece).
  bool from_base = false;  ///< Not from the body: a coupling the base configuration has.

  friend bool operator==(const NetworkEdge&, const NetworkEdge&) = default;
};

/// The oscillator network of the largest piece.
struct CpgNetwork {
  std::vector<ModuleId> piece;        ///< Every module of the largest piece, sorted.
  std::vector<ModuleId> oscillators;  ///< Modules with an oscillator, sorted.
  std::vector<ModuleId> passive;      ///< Passive modules of the piece left out, sorted.
  std::vector<ModuleId> ignored;      ///< Modules outside the largest piece, sorted.
  std::vector<NetworkEdge> edges;     ///< Couplings, sorted by (u, v).

  /// The edge u–v in either order, or nullptr.
  const NetworkEdge* FindEdge(ModuleId a, ModuleId b) const;
};

/// Builds the network. Throws yamor::Error kInvalidArgument when the largest
/// piece holds no driven module (naming the piece's modules). Deterministic
/// and independent of the order of the graph's edges.
CpgNetwork BuildNetwork(const ModuleGraph& graph, const NetworkOptions& options = {});

/// The robot configuration of a network as the thesis builds it: every
/// module of the piece, each oscillator with `amplitude`, `offset` 0 and
/// `speed`, passive modules all zero; couplings both ways with phase 0 and
/// weight 1; the bluetooth tree breadth-first over the physical piece from
/// `master` (the central module when -1 or not in the piece).
RobotConfig NetworkConfig(const ModuleGraph& graph, const CpgNetwork& network,
                          double amplitude, double speed, ModuleId master = -1);

}  // namespace yamor::cpg
