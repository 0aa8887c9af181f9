// XML read/write of robot configurations in the thesis schema (C.4).
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "cpg/robot_config.h"

namespace yamor::cpg {

/// Parses and validates a configuration from XML text. `source_name` is used
/// in error messages. Accepts `realid` or `id`, `cpglink` or `cpmlink`.
/// Throws yamor::Error(INVALID_ARGUMENT) with file:line on any problem.
/// Without a `master` attribute the master is the bluetooth tree's root.
/// Couplings come out grouped by their `from` module, in module order (the
/// canonical order). Fills the source locations. Thread-safe.
RobotConfig ParseConfigXml(std::string_view xml,
                           std::string_view source_name = "<string>");

/// As ParseConfigXml, but direct children of <yamorconfig> whose element name
/// is in `extra_root_elements` are skipped instead of rejected, so a format
/// built on the robot schema (the optimizer's <optimize>/<constrain> rules)
/// can read them itself with the robot's line numbers intact. Thread-safe.
RobotConfig ParseConfigXmlSkipping(
    std::string_view xml, std::string_view source_name,
    const std::vector<std::string>& extra_root_elements);

/// Reads and validates the configuration file at `path`. Throws
/// yamor::Error(NOT_FOUND) when the file cannot be read, INVALID_ARGUMENT
/// when it is malformed.
RobotConfig LoadConfigFile(const std::string& path);

/// Writes `config` in the canonical form (`realid`, `cpglink`, a `master`
/// attribute, doubles with round-trip precision). Lossless: parsing the
/// result gives an equal config when its couplings are in canonical order
/// (grouped by `from` module in module order; other orders come back
/// regrouped). Validates first: throws INVALID_ARGUMENT for an invalid config.
std::string WriteConfigXml(const RobotConfig& config);

/// Writes `config` to `path` (canonical form). Throws yamor::Error on I/O
/// failure.
void SaveConfigFile(const RobotConfig& config, const std::string& path);

}  // namespace yamor::cpg
