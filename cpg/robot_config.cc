#include "cpg/robot_config.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <set>
#include <string>
#include <vector>

#include "common/format.h"
#include "common/status.h"
#include "cpg/parameters.h"

namespace yamor::cpg {

const ModuleParams* RobotConfig::FindModule(ModuleId id) const {
  for (const ModuleParams& module : modules) {
    if (module.id == id) return &module;
  }
  return nullptr;
}

ModuleParams* RobotConfig::FindModule(ModuleId id) {
  return const_cast<ModuleParams*>(std::as_const(*this).FindModule(id));
}

const Coupling* RobotConfig::FindCoupling(ModuleId from, ModuleId to) const {
  for (const Coupling& coupling : couplings) {
    if (coupling.from == from && coupling.to == to) return &coupling;
  }
  return nullptr;
}

Coupling* RobotConfig::FindCoupling(ModuleId from, ModuleId to) {
  return const_cast<Coupling*>(std::as_const(*this).FindCoupling(from, to));
}

namespace {

// Builds the "file:line: " prefix of messages; empty when nothing is known.
// Thread-safety: reads the config only; lives within one Validate call.
class Locator {
 public:
  explicit Locator(const RobotConfig& config) : config_(config) {}

  std::string Prefix(const SourceLocation* location) const {
    std::string file = config_.source_file;
    int line = 0;
    if (location != nullptr) {
      if (!location->file.empty()) file = location->file;
      line = location->line;
    }
    if (line > 0) {
      return (file.empty() ? std::string("<config>") : file) + ":" +
             std::to_string(line) + ": ";
    }
    return file.empty() ? std::string() : file + ": ";
  }

  std::string Module(ModuleId id) const {
    return Prefix(Find(config_.module_locations, id));
  }

  // A coupling's own element, else the element of the module holding it.
  std::string CouplingAt(const Coupling& coupling) const {
    const auto it =
        config_.coupling_locations.find({coupling.from, coupling.to});
    if (it != config_.coupling_locations.end()) return Prefix(&it->second);
    return Module(coupling.from);
  }

  // The `<bluetooth to="child"/>` element, else the child's module element.
  std::string Bluetooth(ModuleId child) const {
    if (const SourceLocation* at = Find(config_.bluetooth_locations, child)) {
      return Prefix(at);
    }
    return Module(child);
  }

  std::string Master() const { return Prefix(&config_.master_location); }

 private:
  static const SourceLocation* Find(
      const std::map<ModuleId, SourceLocation>& locations, ModuleId id) {
    const auto it = locations.find(id);
    return it == locations.end() ? nullptr : &it->second;
  }

  const RobotConfig& config_;
};

[[noreturn]] void Fail(const std::string& message) {
  throw Error(StatusCode::kInvalidArgument, message);
}

void CheckModule(const ModuleParams& module, const Locator& at) {
  const std::string where = at.Module(module.id) + "module " +
                            std::to_string(module.id) + ": ";
  if (module.id < 0 || module.id > kMaxModuleId) {
    Fail(where + "realid (" + std::to_string(module.id) + ") must be in 0.." +
         std::to_string(kMaxModuleId));
  }
  const std::pair<const char*, double> values[] = {
      {"amplitude", module.amplitude}, {"offset", module.offset},
      {"speed", module.speed},         {"minangle", module.min_angle},
      {"maxangle", module.max_angle}};
  for (const auto& [name, value] : values) {
    if (!std::isfinite(value)) {
      Fail(where + name + " (" + FormatDouble(value) + ") must be finite");
    }
  }
  if (module.amplitude < 0.0) {
    Fail(where + "amplitude (" + FormatDouble(module.amplitude) + ") must be >= 0");
  }
  if (module.speed < 0.0) {
    Fail(where + "speed (" + FormatDouble(module.speed) + ") must be >= 0");
  }
  // The ranges the named parameters (cpg/parameters.h) accept: beyond them
  // the oscillators overflow (robot_config_fuzzer: amplitude 1e308 gave a NaN
  // set-point).
  const auto check_range = [&](const char* name, double value, double lo, double hi) {
    if (value < lo || value > hi) {
      Fail(where + name + " (" + FormatDouble(value) + ") must be in [" + FormatDouble(lo) +
           ", " + FormatDouble(hi) + "]");
    }
  };
  check_range("amplitude", module.amplitude, 0.0, kMaxAmplitude);
  check_range("offset", module.offset, -kMaxAmplitude, kMaxAmplitude);
  check_range("speed", module.speed, 0.0, kMaxSpeedHz);
  check_range("minangle", module.min_angle, -kMaxLimitAngle, kMaxLimitAngle);
  check_range("maxangle", module.max_angle, -kMaxLimitAngle, kMaxLimitAngle);
  if (!(module.min_angle < module.max_angle)) {
    Fail(where + "minangle (" + FormatDouble(module.min_angle) +
         ") must be < maxangle (" + FormatDouble(module.max_angle) + ")");
  }
}

void CheckCouplings(const RobotConfig& config, const std::set<ModuleId>& ids,
                    const Locator& at) {
  std::set<std::pair<ModuleId, ModuleId>> seen;
  for (const Coupling& coupling : config.couplings) {
    const std::string where = at.CouplingAt(coupling) + "module " +
                              std::to_string(coupling.from) + ": cpglink to (" +
                              std::to_string(coupling.to) + ")";
    if (!ids.contains(coupling.from)) {
      Fail(where + ": the coupling's from-module " +
           std::to_string(coupling.from) + " is not a listed module");
    }
    if (!ids.contains(coupling.to)) {
      Fail(where + " names no listed module");
    }
    if (coupling.from == coupling.to) {
      Fail(where + " couples the module to itself");
    }
    if (!seen.insert({coupling.from, coupling.to}).second) {
      Fail(where + " appears twice");
    }
    if (!std::isfinite(coupling.phase)) {
      Fail(where + ": phase (" + FormatDouble(coupling.phase) + ") must be finite");
    }
    if (!std::isfinite(coupling.weight)) {
      Fail(where + ": weight (" + FormatDouble(coupling.weight) + ") must be finite");
    }
    // Any finite phase is an angle (the random gaits of Table 6.1 exceed 4π).
    if (std::fabs(coupling.weight) > kMaxCouplingWeight) {
      Fail(where + ": weight (" + FormatDouble(coupling.weight) + ") must be in [" +
           FormatDouble(-kMaxCouplingWeight) + ", " + FormatDouble(kMaxCouplingWeight) + "]");
    }
  }
}

// The tree must be rooted at the master, reach every module, have no cycle.
void CheckBluetoothTree(const RobotConfig& config,
                        const std::set<ModuleId>& ids, const Locator& at) {
  for (const auto& [child, parent] : config.bluetooth_parent) {
    if (!ids.contains(parent)) {
      Fail(at.Bluetooth(child) + "module " + std::to_string(parent) +
           ": bluetooth to (" + std::to_string(child) +
           "): the parent module " + std::to_string(parent) +
           " is not a listed module");
    }
    if (!ids.contains(child)) {
      Fail(at.Bluetooth(child) + "module " + std::to_string(parent) +
           ": bluetooth to (" + std::to_string(child) +
           ") names no listed module");
    }
  }
  const ModuleId master = config.master_id;
  if (!ids.contains(master)) {
    Fail(at.Master() + "master (" + std::to_string(master) +
         ") is not a listed module");
  }
  if (const auto it = config.bluetooth_parent.find(master);
      it != config.bluetooth_parent.end()) {
    Fail(at.Master() + "module " + std::to_string(master) + ": master (" +
         std::to_string(master) +
         ") is not the root of the bluetooth tree: module " +
         std::to_string(it->second) + " lists it as a bluetooth child");
  }
  // Every parent chain must end within ids.size() steps, else it loops.
  for (const ModuleParams& module : config.modules) {
    ModuleId node = module.id;
    std::size_t steps = 0;
    for (auto it = config.bluetooth_parent.find(node);
         it != config.bluetooth_parent.end() && steps <= ids.size();
         it = config.bluetooth_parent.find(node)) {
      node = it->second;
      ++steps;
    }
    if (steps <= ids.size()) continue;
    // `node` is on the cycle now; list it from its smallest id.
    std::vector<ModuleId> cycle{node};
    for (ModuleId next = config.bluetooth_parent.at(node); next != node;
         next = config.bluetooth_parent.at(next)) {
      cycle.push_back(next);
    }
    std::rotate(cycle.begin(), std::min_element(cycle.begin(), cycle.end()),
                cycle.end());
    std::string path;
    for (ModuleId id : cycle) path += std::to_string(id) + " -> ";
    path += std::to_string(cycle.front());
    Fail(at.Bluetooth(cycle.front()) + "module " +
         std::to_string(cycle.front()) +
         ": bluetooth tree has a cycle (child -> parent: " + path + ")");
  }
  // Without cycles every chain ends at a root; any root but the master is
  // a branch the master cannot reach.
  for (const ModuleParams& module : config.modules) {
    if (module.id != master && !config.bluetooth_parent.contains(module.id)) {
      Fail(at.Module(module.id) + "module " + std::to_string(module.id) +
           ": bluetooth: unreachable from master " + std::to_string(master) +
           " (no module lists it as a bluetooth child; the tree has a second "
           "root)");
    }
  }
}

}  // namespace

void Validate(const RobotConfig& config) {
  const Locator at(config);
  if (config.modules.empty()) {
    Fail(at.Master() + "no modules: a configuration needs at least one");
  }
  std::set<ModuleId> ids;
  for (const ModuleParams& module : config.modules) {
    CheckModule(module, at);
    if (!ids.insert(module.id).second) {
      Fail(at.Module(module.id) + "module " + std::to_string(module.id) +
           ": realid " + std::to_string(module.id) +
           " is used by two modules");
    }
  }
  CheckCouplings(config, ids, at);
  CheckBluetoothTree(config, ids, at);
}

}  // namespace yamor::cpg
