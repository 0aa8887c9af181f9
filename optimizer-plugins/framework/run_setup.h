// What yamor-optimize sets up before sessions run: the problem of an
// optimization configuration, and the instances of a batch start.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "optimizer-plugins/framework/optimization_config.h"
#include "optimizer-plugins/framework/session.h"

namespace yamor::optimizer {

/// The problem of `config`: its optimize rules as parameters (start values
/// clamped into the bounds), candidates with the constraints applied, and
/// best.xml as the robot configuration with a point applied. The problem
/// refers to `config`, which must outlive it.
Problem MakeProblem(const OptimizationConfig& config);

/// Plugin field values from repeated --set KEY=VALUE (yamor-optimize and
/// yamor-lifelong); a later KEY wins. Throws kInvalidArgument naming an
/// entry without '=' or with an empty KEY.
std::map<std::string, std::string> ParseFieldSettings(const std::vector<std::string>& settings);

/// One instance of a batch start (the thesis's BatchStart, D.2.2).
struct BatchInstance {
  std::string name;                        ///< Results subfolder and log label.
  std::uint64_t seed = 0;                  ///< The instance's seed.
  std::map<std::string, std::string> set;  ///< Field values over the command line's.
};

/// Reads a batch file (TOML):
///   [[instance]]
///   name = "classic"        # [A-Za-z0-9_.-]+, unique
///   seed = 1                # optional; default: --seed + instance number
///   [instance.set]          # optional field values (strings, numbers, booleans)
///   max_evaluations = 300
/// Throws kInvalidArgument naming the file, line and key, kNotFound when
/// the file cannot be read.
std::vector<BatchInstance> LoadBatchFile(const std::string& path, std::uint64_t default_seed);

/// As LoadBatchFile, from the file's text; `source` names it in errors.
std::vector<BatchInstance> ParseBatchToml(std::string_view text, const std::string& source,
                                          std::uint64_t default_seed);

}  // namespace yamor::optimizer
