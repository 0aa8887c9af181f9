#include "host/builtin_robots.h"

#include <algorithm>

#include "host/builtin_robots_data.h"

namespace yamor::host {

const BuiltinRobot* FindBuiltinRobot(std::string_view name) {
  for (std::size_t i = 0; i < internal::kBuiltinRobotCount; ++i) {
    if (internal::kBuiltinRobots[i].name == name) return &internal::kBuiltinRobots[i];
  }
  return nullptr;
}

std::vector<std::string> BuiltinRobotNames() {
  std::vector<std::string> names;
  for (std::size_t i = 0; i < internal::kBuiltinRobotCount; ++i) {
    names.emplace_back(internal::kBuiltinRobots[i].name);
  }
  std::sort(names.begin(), names.end());
  return names;
}

}  // namespace yamor::host
