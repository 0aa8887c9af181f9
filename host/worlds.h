// Resolution of the world and configuration named by a request (OpenSimulation,
// Evaluate) or by yamord's settings: a built-in robot name, morphology XML
// text, or (settings only) a file.
#pragma once

#include <optional>
#include <string>
#include <string_view>

#include "cpg/robot_config.h"
#include "physics/morphology.h"

namespace yamor::host {

/// What a caller asked for.
struct WorldRequest {
  std::string world;           ///< Built-in name (or a file when files are allowed); "" = default.
  std::string morphology_xml;  ///< Morphology XML; overrides `world`.
  std::string config_xml;      ///< Configuration XML; "" = the built-in one of `world`, if any.
  std::string config_source = "<request>";  ///< Name of config_xml in error messages.
};

/// A resolved world.
struct ResolvedWorld {
  physics::Morphology morphology;         ///< The morphology (simulation ids).
  std::string name;                       ///< Built-in name, file, or "<request>".
  std::optional<cpg::RobotConfig> config; ///< The configuration, when one was given or built in.
};

/// Resolves `request`. `default_world` is used when both world and
/// morphology_xml are empty. Errors: NOT_FOUND unknown world name (the
/// message lists the built-in ones) or unreadable file, INVALID_ARGUMENT
/// malformed XML (with line). Files are read only when `allow_files` (yamord's
/// own settings, never a network request). Thread-safe.
ResolvedWorld ResolveWorld(const WorldRequest& request, std::string_view default_world,
                           bool allow_files);

}  // namespace yamor::host
