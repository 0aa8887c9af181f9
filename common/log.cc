#include "common/log.h"

#include <spdlog/sinks/stdout_color_sinks.h>

#include <string>

#include "common/status.h"

namespace yamor {

spdlog::logger& Log() {
  // Function-local static: created once, thread-safe initialisation.
  static std::shared_ptr<spdlog::logger> logger = [] {
    auto existing = spdlog::get("yamor");
    if (existing) return existing;
    auto created = spdlog::stderr_color_mt("yamor");
    created->set_pattern("%Y-%m-%dT%H:%M:%S.%e %^%l%$ [%n] %v");
    return created;
  }();
  return *logger;
}

void SetLogLevel(std::string_view level) {
  const auto parsed = spdlog::level::from_str(std::string(level));
  // from_str maps unknown names to "off"; only accept "off" when asked for.
  if (parsed == spdlog::level::off && level != "off") {
    throw Error(StatusCode::kInvalidArgument,
                "unknown log level '" + std::string(level) +
                    "' (expected trace, debug, info, warn, error, critical or off)");
  }
  Log().set_level(parsed);
}

}  // namespace yamor
