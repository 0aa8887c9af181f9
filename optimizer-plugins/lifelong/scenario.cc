#include "optimizer-plugins/lifelong/scenario.h"

#include <grpcpp/grpcpp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>
#include <set>
#include <sstream>
#include <toml++/toml.h>

#include "common/format.h"
#include "common/status.h"

namespace yamor::lifelong {
namespace {

namespace fs = std::filesystem;

std::string Where(const std::string& path, const toml::node& node) {
  return path + ":" + std::to_string(node.source().begin.line);
}

std::string ReadFile(const fs::path& path, const std::string& what) {
  std::ifstream in(path);
  if (!in) throw Error(StatusCode::kNotFound, what + " " + path.string() + " cannot be read");
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

[[noreturn]] void Bad(const std::string& where, const std::string& message) {
  throw Error(StatusCode::kInvalidArgument, where + ": " + message);
}

double Number(const std::string& path, const toml::node& node, const std::string& key) {
  if (auto v = node.value<double>()) {
    if (std::isfinite(*v)) return *v;
  }
  Bad(Where(path, node), key + " must be a finite number");
}

int ModuleId(const std::string& path, const toml::node& node, const std::string& key) {
  // Integers only: toml++ converting a float beyond int64's range is
  // undefined behaviour.
  const std::optional<int64_t> v = node.is_integer() ? node.value<int64_t>() : std::nullopt;
  if (!v || *v < 0 || *v > 254) Bad(Where(path, node), key + " must be a module id in 0..254");
  return static_cast<int>(*v);
}

std::string Text(const std::string& path, const toml::node& node, const std::string& key) {
  auto v = node.value<std::string>();
  if (!v) Bad(Where(path, node), key + " must be a string");
  return *v;
}

std::string OptionText(const std::string& path, const toml::node& node, const std::string& key) {
  if (auto s = node.value<std::string>()) return *s;
  if (node.is_integer()) return std::to_string(*node.value<int64_t>());
  if (node.is_floating_point()) return FormatDouble(*node.value<double>());
  if (node.is_boolean()) return *node.value<bool>() ? "true" : "false";
  Bad(Where(path, node), "options." + key + " must be a string, number, boolean or an array of them");
}

std::optional<v1::ConnectorName> Connector(const std::string& name) {
  static const std::pair<const char*, v1::ConnectorName> kNames[] = {
      {"front", v1::CONNECTOR_FRONT}, {"rear", v1::CONNECTOR_REAR}, {"left", v1::CONNECTOR_LEFT},
      {"right", v1::CONNECTOR_RIGHT}, {"top", v1::CONNECTOR_TOP},   {"bottom", v1::CONNECTOR_BOTTOM}};
  for (const auto& [n, c] : kNames) {
    if (name == n) return c;
  }
  return std::nullopt;
}

ScenarioChange ParseChange(const std::string& path, const fs::path& base, const toml::node& node) {
  const toml::table* table = node.as_table();
  if (!table) Bad(Where(path, node), "change must be a table");
  ScenarioChange c;
  c.line = static_cast<int>(node.source().begin.line);
  std::set<std::string> allowed = {"at", "do"};
  if (const toml::node* at = table->get("at")) {
    c.at = Number(path, *at, "at");
    if (c.at < 0) Bad(Where(path, *at), "at must be >= 0");
  } else {
    Bad(Where(path, node), "change without at (robot time in seconds)");
  }
  const toml::node* action = table->get("do");
  if (!action) Bad(Where(path, node), "change without do");
  c.action = Text(path, *action, "do");
  auto need = [&](const char* key) -> const toml::node& {
    allowed.insert(key);
    const toml::node* n = table->get(key);
    if (!n) Bad(Where(path, node), "change '" + c.action + "' needs " + key);
    return *n;
  };
  auto maybe = [&](const char* key) -> const toml::node* {
    allowed.insert(key);
    return table->get(key);
  };
  if (c.action == "script") {
    const fs::path file = base / Text(path, need("file"), "file");
    c.file = file.string();
    c.script_xml = ReadFile(file, "transformation script");
  } else if (c.action == "upside_down") {
  } else if (c.action == "ground") {
    if (auto* n = maybe("friction")) c.friction = Number(path, *n, "friction");
    if (auto* n = maybe("slope")) c.slope = Number(path, *n, "slope");
    if (auto* n = maybe("slope_direction")) c.slope_direction = Number(path, *n, "slope_direction");
    if (!c.friction && !c.slope && !c.slope_direction) {
      Bad(Where(path, node), "ground change without friction, slope or slope_direction");
    }
  } else if (c.action == "motor_defect") {
    c.module = ModuleId(path, need("module"), "module");
    c.defect = Text(path, need("defect"), "defect");
    if (c.defect != "limp" && c.defect != "stuck" && c.defect != "ok") {
      Bad(Where(path, node), "defect \"" + c.defect + "\" is not limp, stuck or ok");
    }
  } else if (c.action == "module_defect") {
    c.module = ModuleId(path, need("module"), "module");
    if (auto* n = maybe("defective")) {
      auto v = n->value<bool>();
      if (!v) Bad(Where(path, *n), "defective must be true or false");
      c.defective = *v;
    }
  } else if (c.action == "disconnect") {
    c.module = ModuleId(path, need("module"), "module");
  } else if (c.action == "connect") {
    c.module = ModuleId(path, need("module"), "module");
    c.to = ModuleId(path, need("to"), "to");
    if (auto* n = maybe("connector")) c.from_connector = Text(path, *n, "connector");
    if (auto* n = maybe("to_connector")) c.to_connector = Text(path, *n, "to_connector");
    if (auto* n = maybe("angle")) c.angle = Number(path, *n, "angle");
    for (const std::string& name : {c.from_connector, c.to_connector}) {
      if (!Connector(name)) Bad(Where(path, node), "unknown connector \"" + name + "\"");
    }
  } else {
    Bad(Where(path, *action),
        "unknown change \"" + c.action +
            "\" (script, upside_down, ground, motor_defect, module_defect, disconnect, connect)");
  }
  for (const auto& [key, value] : *table) {
    if (!allowed.count(std::string(key.str()))) {
      Bad(Where(path, value), "unknown key '" + std::string(key.str()) + "' in a '" + c.action + "' change");
    }
  }
  return c;
}


}  // namespace

std::string ScenarioChange::Describe() const {
  std::ostringstream out;
  out << action;
  if (action == "script") out << " " << fs::path(file).filename().string();
  if (module >= 0) out << " module " << module;
  if (action == "motor_defect") out << " " << defect;
  if (action == "module_defect") out << (defective ? " set" : " repaired");
  if (action == "connect") out << " to " << to;
  if (friction) out << " friction " << FormatRounded(*friction);
  if (slope) out << " slope " << FormatRounded(*slope);
  if (slope_direction) out << " towards " << FormatRounded(*slope_direction);
  return out.str();
}

Scenario Scenario::Load(const std::string& path) {
  const std::string text = ReadFile(path, "scenario");
  toml::table root;
  try {
    root = toml::parse(text, path);
  } catch (const toml::parse_error& e) {
    throw Error(StatusCode::kInvalidArgument,
                path + ":" + std::to_string(e.source().begin.line) + ": " + std::string(e.description()));
  }
  const fs::path base = fs::path(path).parent_path();
  Scenario s;
  s.path = path;
  for (const auto& [key, node] : root) {
    const std::string k(key.str());
    if (k == "description") {
      s.description = Text(path, node, k);
    } else if (k == "world") {
      const std::string world = Text(path, node, k);
      if (world.size() > 4 && world.substr(world.size() - 4) == ".xml") {
        s.morphology_xml = ReadFile(base / world, "world");
      } else {
        s.world = world;
      }
    } else if (k == "config") {
      s.config_path = (base / Text(path, node, k)).string();
      if (!fs::exists(s.config_path)) {
        throw Error(StatusCode::kNotFound, Where(path, node) + ": config " + s.config_path + " does not exist");
      }
    } else if (k == "seed") {
      const std::optional<int64_t> v = node.is_integer() ? node.value<int64_t>() : std::nullopt;
      if (!v || *v < 0) Bad(Where(path, node), "seed must be an integer >= 0");
      s.seed = static_cast<std::uint64_t>(*v);
    } else if (k == "options") {
      const toml::table* options = node.as_table();
      if (!options) Bad(Where(path, node), "options must be a table");
      for (const auto& [name, value] : *options) {
        std::vector<std::string> values;
        if (const toml::array* array = value.as_array()) {
          for (const toml::node& item : *array) values.push_back(OptionText(path, item, std::string(name.str())));
        } else {
          values.push_back(OptionText(path, value, std::string(name.str())));
        }
        s.options.emplace_back(std::string(name.str()), values);
      }
    } else if (k == "change") {
      const toml::array* changes = node.as_array();
      if (!changes) Bad(Where(path, node), "change must be an array of tables ([[change]])");
      for (const toml::node& c : *changes) s.changes.push_back(ParseChange(path, base, c));
    } else {
      Bad(Where(path, node), "unknown key '" + k + "' (description, world, config, seed, options, change)");
    }
  }
  if (s.config_path.empty()) throw Error(StatusCode::kInvalidArgument, path + ": no config (the starting gait)");
  std::stable_sort(s.changes.begin(), s.changes.end(),
                   [](const ScenarioChange& a, const ScenarioChange& b) { return a.at < b.at; });
  return s;
}

ScenarioPlayer::ScenarioPlayer(Scenario scenario, client::HostClient& host, double rpc_deadline,
                               std::function<void(double, const ScenarioChange&)> on_change)
    : scenario_(std::move(scenario)), host_(host), deadline_(rpc_deadline), on_change_(std::move(on_change)) {}

void ScenarioPlayer::Setup(const std::string& config_xml) {
  v1::OpenSimulationRequest request;
  request.set_world(scenario_.world);
  request.set_morphology_xml(scenario_.morphology_xml);
  request.set_seed(scenario_.seed);
  request.set_config_xml(config_xml);
  host_.Call(&v1::Host::Stub::OpenSimulation, request, "OpenSimulation for scenario " + scenario_.path,
             {.deadline = deadline_ + 30});
  next_ = 0;  // a fresh world: the changes start over
}

bool ScenarioPlayer::ApplyDue(double robot_time) {
  bool any = false;
  while (next_ < scenario_.changes.size() && scenario_.changes[next_].at <= robot_time) {
    const ScenarioChange& change = scenario_.changes[next_];
    Apply(change);
    ++next_;
    any = true;
    if (on_change_) on_change_(robot_time, change);
  }
  return any;
}

void ScenarioPlayer::Apply(const ScenarioChange& c) {
  const std::string what = scenario_.path + ":" + std::to_string(c.line) + ": " + c.Describe();
  const client::CallOptions options{.deadline = deadline_ + 60};
  const google::protobuf::Empty empty;
  if (c.action == "script") {
    v1::RunTransformationScriptRequest r;
    r.set_script_xml(c.script_xml);
    host_.Call(&v1::Host::Stub::RunTransformationScript, r, "RunTransformationScript (" + what + ")", options);
  } else if (c.action == "upside_down") {
    host_.Call(&v1::Host::Stub::TurnUpsideDown, empty, "TurnUpsideDown (" + what + ")", options);
  } else if (c.action == "ground") {
    v1::SetGroundRequest r;
    if (c.friction) r.set_friction(*c.friction);
    if (c.slope) r.set_slope(*c.slope);
    if (c.slope_direction) r.set_slope_direction(*c.slope_direction);
    host_.Call(&v1::Host::Stub::SetGround, r, "SetGround (" + what + ")", options);
  } else if (c.action == "motor_defect") {
    v1::SetMotorDefectRequest r;
    r.set_module_id(static_cast<uint32_t>(c.module));
    r.set_defect(c.defect == "limp" ? v1::MOTOR_LIMP : c.defect == "stuck" ? v1::MOTOR_STUCK : v1::MOTOR_OK);
    host_.Call(&v1::Host::Stub::SetMotorDefect, r, "SetMotorDefect (" + what + ")", options);
  } else if (c.action == "module_defect") {
    v1::SetModuleDefectRequest r;
    r.set_module_id(static_cast<uint32_t>(c.module));
    r.set_defective(c.defective);
    host_.Call(&v1::Host::Stub::SetModuleDefect, r, "SetModuleDefect (" + what + ")", options);
  } else if (c.action == "disconnect") {
    v1::ModuleRequest r;
    r.set_module_id(static_cast<uint32_t>(c.module));
    host_.Call(&v1::Host::Stub::DisconnectModule, r, "DisconnectModule (" + what + ")", options);
  } else if (c.action == "connect") {
    v1::ConnectModulesRequest r;
    r.set_from_id(static_cast<uint32_t>(c.module));
    r.set_from_connector(*Connector(c.from_connector));
    r.set_to_id(static_cast<uint32_t>(c.to));
    r.set_to_connector(*Connector(c.to_connector));
    r.set_angle_degrees(c.angle);
    host_.Call(&v1::Host::Stub::ConnectModules, r, "ConnectModules (" + what + ")", options);
  }
}

}  // namespace yamor::lifelong
