// The one project logger. Library code logs through it and never prints.
#pragma once

#include <spdlog/spdlog.h>

namespace yamor {

/// The process-wide "yamor" logger (stderr, created on first use).
/// Thread-safety: spdlog loggers are thread-safe; safe from any thread.
spdlog::logger& Log();

/// Sets the level of the yamor logger from a name ("trace" … "off");
/// throws yamor::Error(INVALID_ARGUMENT) for an unknown name.
void SetLogLevel(std::string_view level);

}  // namespace yamor
