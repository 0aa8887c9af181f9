// yamor-lifelong: keeps one robot walking for life (thesis chapter 7). See
// `yamor-lifelong --help` and docs/lifelong.md. The executable is a thin
// main() over Run(), so tests run the command in-process.
#pragma once

#include <ostream>
#include <string>
#include <vector>

namespace yamor::lifelong {

/// Runs one yamor-lifelong command line (`args` without the program name;
/// a --scenario's [options] fill in the options not given), writing the
/// summary to `out` and progress, warnings and errors to `err`; `program`
/// is the name --help shows. Returns the exit status: 0 done, 1 an error,
/// 2 an invalid argument or missing file, 130 stopped by SIGINT/SIGTERM (a
/// life installs handlers that count them, and leaves them installed),
/// CLI11's code for a rejected command line. Thread-safety: one Run at a
/// time per process (the handlers).
int Run(const std::vector<std::string>& args, std::ostream& out, std::ostream& err,
        const std::string& program = "yamor-lifelong");

}  // namespace yamor::lifelong
