// The robot configuration model of YaMoR Host 3 (thesis 5.5.1, C.2.1, C.4):
// modules with their oscillator parameters and limit angles, the CPG
// couplings, and the bluetooth tree rooted at the master node.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace yamor::cpg {

/// A module's real id (the id on the physical robot). SNP addresses are one
/// byte and 255 is broadcast, so valid ids are 0..254.
using ModuleId = int;

/// Highest valid module id (255 is the SNP broadcast address).
inline constexpr ModuleId kMaxModuleId = 254;

/// One module's oscillator parameters and limit angles.
struct ModuleParams {
  ModuleId id = 0;          ///< Real id.
  double amplitude = 0.0;   ///< Target amplitude R [rad].
  double offset = 0.0;      ///< Target offset X [rad].
  double speed = 0.0;       ///< Oscillator frequency [Hz]; omega = 2*pi*speed.
  double min_angle = -1.57; ///< Lower servo set-point limit [rad].
  double max_angle = 1.57;  ///< Upper servo set-point limit [rad].

  friend bool operator==(const ModuleParams&, const ModuleParams&) = default;
};

/// A directed CPG coupling: oscillator `from` is pulled by oscillator `to`.
/// It adds weight * r_to * sin(phi_to - phi_from - phase) to d(phi_from)/dt,
/// so at lock phi_to - phi_from = phase. Stored in the XML inside the
/// `from` module's element.
struct Coupling {
  ModuleId from = 0;    ///< Module whose equation holds the term.
  ModuleId to = 0;      ///< Module whose state drives the term.
  double phase = 0.0;   ///< Phase bias varphi_{from,to} [rad].
  double weight = 1.0;  ///< Coupling weight w_{from,to}.

  friend bool operator==(const Coupling&, const Coupling&) = default;
};

/// Where a value came from, for error messages ("quadruped.xml:12").
struct SourceLocation {
  std::string file;  ///< File name, or "<string>" for in-memory XML.
  int line = 0;      ///< 1-based line, 0 when unknown.
};

/// A complete robot configuration. A plain value type: copy freely.
/// Thread-safety: no internal synchronisation; const access is safe from any
/// number of threads.
struct RobotConfig {
  /// Modules in file order (the order is kept on write).
  std::vector<ModuleParams> modules;
  /// CPG couplings in file order.
  std::vector<Coupling> couplings;
  /// The bluetooth tree: child id -> parent id (toward the master). In the
  /// XML a module `P` lists `<bluetooth to="C"/>` for each child `C`, so the
  /// thesis's GUI rows "P -> C" read top-down from the master.
  std::map<ModuleId, ModuleId> bluetooth_parent;
  /// The master node (the module that talks bluetooth to the host). When the
  /// file does not say, it is the root of the bluetooth tree.
  ModuleId master_id = 0;

  /// Source lines of each module element and coupling, filled by the XML
  /// reader so validation errors can point at them. Not part of equality.
  std::map<ModuleId, SourceLocation> module_locations;
  /// Source line of each coupling element, keyed by (from, to).
  std::map<std::pair<ModuleId, ModuleId>, SourceLocation> coupling_locations;
  /// Source line of each `<bluetooth to="C"/>` element, keyed by child C.
  std::map<ModuleId, SourceLocation> bluetooth_locations;
  /// Source line of the `<yamorconfig>` element (where `master` is given).
  SourceLocation master_location;
  std::string source_file;  ///< File the config was read from, if any.

  /// The module with `id`, or nullptr.
  const ModuleParams* FindModule(ModuleId id) const;
  /// Mutable module with `id`, or nullptr.
  ModuleParams* FindModule(ModuleId id);
  /// The coupling from -> to, or nullptr.
  const Coupling* FindCoupling(ModuleId from, ModuleId to) const;
  /// Mutable coupling from -> to, or nullptr.
  Coupling* FindCoupling(ModuleId from, ModuleId to);

  /// Equality of the model (modules, couplings, tree, master); ignores
  /// source locations.
  friend bool operator==(const RobotConfig& a, const RobotConfig& b) {
    return a.modules == b.modules && a.couplings == b.couplings &&
           a.bluetooth_parent == b.bluetooth_parent &&
           a.master_id == b.master_id;
  }
};

/// Checks every invariant and throws yamor::Error(INVALID_ARGUMENT) naming
/// the file, line, module and attribute of the first violation: ids unique
/// and in 0..254, finite values, min_angle < max_angle, couplings between
/// known modules (no self-couplings, no duplicates), and the bluetooth tree
/// rooted at the master reaching every listed module without cycles.
/// Also: at least one module, amplitude >= 0, speed >= 0, finite coupling
/// phase and weight. Thread-safe (reads `config` only).
void Validate(const RobotConfig& config);

}  // namespace yamor::cpg
