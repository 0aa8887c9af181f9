// Internal: the table written by host/embed_robots.cmake at build time.
#pragma once

#include <cstddef>

#include "host/builtin_robots.h"

namespace yamor::host::internal {

/// Every built-in robot, sorted by name (generated).
extern const BuiltinRobot kBuiltinRobots[];
/// Number of entries of kBuiltinRobots.
extern const std::size_t kBuiltinRobotCount;

}  // namespace yamor::host::internal
