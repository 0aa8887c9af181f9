// Symmetries of a module graph (thesis 7.8.1) and a canonical morphology key,
// both with nauty.
//
// A symmetry maps every module onto a module of the same kind and turns its
// body by one of the module's own symmetries, so that every connection lands
// on a connection with the same connectors and angle. A driven module's body
// (box, hinge along y) is unchanged by a half turn about its long axis x,
// which reverses its servo; a passive module's hinge carries nothing, so its
// square body may turn by quarter turns about x. With mirrors, the robot's
// mirror image (each module reflected in its own x–z plane: left and right
// swap, connection angles change sign, servo angles stay) counts too.
// docs/cpg_build.md derives the groups of the robots in configs/worlds.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "cpg/module_graph.h"

namespace yamor::cpg {

/// One symmetry. Indexed like ModuleGraph::modules().
struct Symmetry {
  std::vector<int> image;             ///< Index of the module each module goes to.
  std::vector<Eigen::Matrix3i> body;  ///< Body map of each module: local frame -> image's.
  bool mirror = false;                ///< A reflection (det body = -1).

  /// +1 when module `index`'s servo angle maps to the same angle of its
  /// image, -1 when to the opposite one.
  int ServoSign(int index) const;
};

/// What FindSymmetries keeps.
struct SymmetryOptions {
  bool mirrors = true;          ///< Include mirror images.
  /// With module orientations in the graph, keep only symmetries that map
  /// the robot's up direction onto itself (a symmetry that turns the robot
  /// over is no symmetry on the ground).
  bool respect_gravity = true;
  /// Enumerate the group up to this many elements (orbits from every
  /// element); a larger group uses its generators only.
  int max_elements = 20000;
};

/// The symmetries found and the module orbits they induce.
struct SymmetryGroup {
  std::vector<Symmetry> generators;  ///< nauty's generators (and the mirror), all checked.
  std::vector<Symmetry> elements;    ///< The symmetries kept (whole group when enumerated).
  double full_order = 1;             ///< Order of the whole group (rotations and mirrors).
  bool enumerated = false;           ///< elements is the whole kept group.
  int dropped_for_gravity = 0;       ///< Elements left out because they turn the robot over.
  /// Module orbits under the kept symmetries, each sorted, ordered by first id.
  std::vector<std::vector<ModuleId>> orbits;
};

/// Finds the symmetries of `graph`. Deterministic; orbits are independent of
/// how the modules are numbered. Thread-safe.
SymmetryGroup FindSymmetries(const ModuleGraph& graph, const SymmetryOptions& options = {});

/// True when `symmetry` is one: a bijection of modules that keeps kinds
/// (driven/passive), uses allowed body maps, and maps every connection onto
/// a connection with the transformed connectors and angle. Independent of
/// nauty; tests use it to check FindSymmetries.
bool IsSymmetry(const ModuleGraph& graph, const Symmetry& symmetry);

/// The body maps a module of this kind may use (with or without mirrors).
std::vector<Eigen::Matrix3i> AllowedBodyMaps(bool active, bool mirror);

/// Where a connector goes under a body map, and how many 15° steps its
/// north turns about the new connector's normal (from the new connector's
/// north to the image of the old north).
std::pair<Connector, int> MapConnector(const Eigen::Matrix3i& body, Connector connector);

/// A short stable key of the labelled graph (modules' driven/passive flags
/// and the central module, connections with both connectors and the angle)
/// from nauty's canonical labelling: equal for the same robot under any
/// renumbering of module ids, different when a connector, an angle, a flag
/// or the central module differs. 16 hex digits. Thread-safe.
std::string MorphologyKey(const ModuleGraph& graph);

}  // namespace yamor::cpg
