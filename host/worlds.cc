#include "host/worlds.h"

#include <filesystem>

#include "common/status.h"
#include "cpg/config_xml.h"
#include "host/builtin_robots.h"

namespace yamor::host {

ResolvedWorld ResolveWorld(const WorldRequest& request, std::string_view default_world,
                           bool allow_files) {
  std::optional<cpg::RobotConfig> config;
  if (!request.config_xml.empty()) {
    config = cpg::ParseConfigXml(request.config_xml, request.config_source);
  }
  if (!request.morphology_xml.empty()) {
    return ResolvedWorld{
        .morphology = physics::Morphology::Parse(request.morphology_xml, "<request morphology>"),
        .name = "<request>",
        .config = std::move(config)};
  }
  const std::string name = request.world.empty() ? std::string(default_world) : request.world;
  if (const BuiltinRobot* robot = FindBuiltinRobot(name)) {
    if (!config) config = cpg::ParseConfigXml(robot->config_xml, name + " (built-in robot)");
    return ResolvedWorld{
        .morphology = physics::Morphology::Parse(robot->morphology_xml, name + " (built-in world)"),
        .name = name,
        .config = std::move(config)};
  }
  if (allow_files && std::filesystem::is_regular_file(name)) {
    return ResolvedWorld{.morphology = physics::Morphology::LoadFile(name),
                         .name = name,
                         .config = std::move(config)};
  }
  std::string known;
  for (const std::string& n : BuiltinRobotNames()) known += (known.empty() ? "" : ", ") + n;
  throw Error(StatusCode::kNotFound, "unknown world '" + name + "'" +
                                         (allow_files ? " (neither built in nor a file)" : "") +
                                         "; built-in worlds: " + known);
}

}  // namespace yamor::host
