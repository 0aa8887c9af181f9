// yamorctl: the command-line client of yamord (gRPC API yamor.v1.Host), one
// command per RPC. The executable is a thin main() over Run() so tests can
// drive every command in-process.
#pragma once

#include <cstdint>
#include <ostream>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace yamor::yamorctl {

/// Exit status of a command line that CLI11 rejects (or a local file that
/// cannot be read): a usage error.
inline constexpr int kUsageExitCode = 2;

/// Default daemon address (the thesis's port).
inline constexpr std::string_view kDefaultHost = "127.0.0.1:2224";

/// Default deadline of a call [s]; long calls add their duration to it.
inline constexpr double kDefaultTimeout = 10.0;

/// Runs one yamorctl command line (`args` without the program name), writing
/// results to `out` and errors to `err`. Returns the exit status: 0 on
/// success, the gRPC status code number of a failed call, kUsageExitCode for
/// usage errors. Thread-safety: reentrant; each call owns its own channel.
int Run(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

/// Parses "name=value" (an Evaluate parameter, e.g. "amplitude.3=0.5");
/// throws yamor::Error(INVALID_ARGUMENT) naming the text when malformed.
std::pair<std::string, double> ParseParameterAssignment(std::string_view text);

/// Parses a module list "all" or ids ("3", "5"...) into (all, ids); throws
/// yamor::Error(INVALID_ARGUMENT) for anything else or "all" mixed with ids.
std::pair<bool, std::vector<uint32_t>> ParseModuleTargets(const std::vector<std::string>& words);

}  // namespace yamor::yamorctl
