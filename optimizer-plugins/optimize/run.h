// yamor-optimize: runs an optimizer plugin against a pool of yamord hosts
// (thesis 5.7, appendix D), or online on one live robot (--live, thesis 6.3).
// See `yamor-optimize --help` and docs/optimizers.md. The executable is a
// thin main() over Run(), so tests run the command in-process.
#pragma once

#include <ostream>
#include <string>
#include <vector>

namespace yamor::optimize {

/// Runs one yamor-optimize command line (`args` without the program name),
/// writing results to `out` and progress, warnings and errors to `err`;
/// `program` is the name recorded in run.toml and shown in --help. Returns
/// the exit status: 0 done, 1 a failed run or error, 2 an invalid argument
/// or missing file, 130 stopped by SIGINT/SIGTERM (a run installs handlers
/// that count them, and leaves them installed), CLI11's code for a rejected
/// command line. Thread-safety: one Run at a time per process (the handlers).
int Run(const std::vector<std::string>& args, std::ostream& out, std::ostream& err,
        const std::string& program = "yamor-optimize");

}  // namespace yamor::optimize
