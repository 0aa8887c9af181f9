// RunInProcess: runs a command's library entry point (yamorctl::Run,
// optimize::Run, lifelong::Run: args, out, err) and keeps what it wrote,
// for tests that drive a program in-process.
//
// Thread safety: as the command it runs.
#pragma once

#include <sstream>
#include <string>
#include <vector>

namespace yamor::testing {

/// A command's exit status and its two streams.
struct CommandOutcome {
  int status = -1;   ///< What the command returned.
  std::string out;   ///< Its standard output.
  std::string err;   ///< Its standard error.
};

/// True when `part` appears in `text` (a stream's contents).
inline bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

/// `run(args, out, err)` with string streams.
template <typename RunFunction>
CommandOutcome RunInProcess(RunFunction&& run, const std::vector<std::string>& args) {
  std::ostringstream out, err;
  CommandOutcome outcome;
  outcome.status = run(args, out, err);
  outcome.out = out.str();
  outcome.err = err.str();
  return outcome;
}

}  // namespace yamor::testing
