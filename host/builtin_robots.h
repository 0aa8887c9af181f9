// The robots compiled into yamord: every configs/worlds/<name>.xml morphology
// with its configs/robots/<name>.xml configuration, so the daemon works from
// any directory without its source tree.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace yamor::host {

/// One built-in robot: a morphology and its CPG configuration (same ids).
/// Thread-safety: immutable static data; safe from any thread.
struct BuiltinRobot {
  std::string_view name;            ///< "quadruped", "snake", ...
  std::string_view morphology_xml;  ///< configs/worlds/<name>.xml, verbatim.
  std::string_view config_xml;      ///< configs/robots/<name>.xml, verbatim.
};

/// The built-in robot called `name`, or nullptr.
const BuiltinRobot* FindBuiltinRobot(std::string_view name);

/// Names of every built-in robot, sorted.
std::vector<std::string> BuiltinRobotNames();

/// The world yamord opens when nothing else is asked for.
inline constexpr std::string_view kDefaultWorld = "quadruped";

}  // namespace yamor::host
