#include "physics/script.h"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include <tinyxml2.h>

#include "common/status.h"
#include "physics/world.h"

namespace yamor::physics {
namespace {

[[noreturn]] void Fail(const std::string& message) {
  throw Error(StatusCode::kInvalidArgument, message);
}

std::string Attribute(const tinyxml2::XMLElement* e, const char* name, const std::string& where) {
  const char* value = e->Attribute(name);
  if (value == nullptr) Fail(where + ": <" + e->Name() + "> is missing attribute " + name);
  return value;
}

long Integer(const tinyxml2::XMLElement* e, const char* name, const std::string& where,
             long min, long max) {
  const std::string text = Attribute(e, name, where);
  char* end = nullptr;
  const long value = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || value < min || value > max) {
    Fail(where + ": " + name + "=\"" + text + "\" is not an integer in [" + std::to_string(min) +
         ", " + std::to_string(max) + "]");
  }
  return value;
}

ConnectorId Connector(const tinyxml2::XMLElement* e, const char* name, const std::string& where) {
  const std::string text = Attribute(e, name, where);
  const auto connector = ParseConnectorName(text);
  if (!connector) {
    Fail(where + ": unknown connector " + name + "=\"" + text +
         "\" (expected front, rear, left, right, top or bottom)");
  }
  return *connector;
}

void CheckAttributes(const tinyxml2::XMLElement* e, std::initializer_list<std::string_view> allowed,
                     const std::string& where) {
  for (const tinyxml2::XMLAttribute* a = e->FirstAttribute(); a; a = a->Next()) {
    bool known = false;
    for (std::string_view name : allowed) known = known || name == a->Name();
    if (!known) Fail(where + ": <" + e->Name() + "> has unknown attribute " + a->Name());
  }
}

}  // namespace

TransformationScript TransformationScript::LoadFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(StatusCode::kNotFound, "cannot read script file " + path.string());
  std::ostringstream text;
  text << in.rdbuf();
  return Parse(text.str(), path.string());
}

TransformationScript TransformationScript::Parse(std::string_view xml, std::string_view source) {
  TransformationScript script;
  script.source_ = std::string(source);
  tinyxml2::XMLDocument document;
  if (document.Parse(xml.data(), xml.size()) != tinyxml2::XML_SUCCESS) {
    Fail(script.source_ + ":" + std::to_string(document.ErrorLineNum()) +
         ": malformed XML: " + document.ErrorStr());
  }
  const tinyxml2::XMLElement* root = document.RootElement();
  if (root == nullptr || std::string_view(root->Name()) != "script") {
    Fail(script.source_ + ":" + std::to_string(root ? root->GetLineNum() : 1) +
         ": the document element must be <script>");
  }
  for (const tinyxml2::XMLElement* e = root->FirstChildElement(); e;
       e = e->NextSiblingElement()) {
    const std::string where = script.source_ + ":" + std::to_string(e->GetLineNum());
    const std::string_view name(e->Name());
    ScriptCommand command;
    command.line = e->GetLineNum();
    if (name == "connect") {
      CheckAttributes(e, {"idfrom", "connfrom", "idto", "connto", "angle"}, where);
      command.kind = ScriptCommand::Kind::kConnect;
      command.connection.from = static_cast<int>(Integer(e, "idfrom", where, 0, 1 << 20));
      command.connection.from_connector = Connector(e, "connfrom", where);
      command.connection.to = static_cast<int>(Integer(e, "idto", where, 0, 1 << 20));
      command.connection.to_connector = Connector(e, "connto", where);
      const char* angle = e->Attribute("angle");
      const long degrees = angle ? Integer(e, "angle", where, -360000, 360000) : 0;
      if (degrees % 15 != 0) {
        Fail(where + ": angle=\"" + std::to_string(degrees) + "\" is not a multiple of 15 degrees");
      }
      command.connection.angle_steps = static_cast<int>(((degrees / 15) % 24 + 24) % 24);
      command.connection.line = command.line;
    } else if (name == "disconnect") {
      CheckAttributes(e, {"id"}, where);
      command.kind = ScriptCommand::Kind::kDisconnect;
      command.id = static_cast<int>(Integer(e, "id", where, 0, 1 << 20));
    } else if (name == "pause") {
      CheckAttributes(e, {"delay"}, where);
      command.kind = ScriptCommand::Kind::kPause;
      command.delay_ms = static_cast<int>(Integer(e, "delay", where, 0, 24 * 3600 * 1000));
    } else {
      Fail(where + ": unknown command <" + std::string(name) +
           "> (expected <connect>, <disconnect> or <pause>)");
    }
    script.commands_.push_back(command);
  }
  return script;
}

void RunScript(World& world, const TransformationScript& script,
               const std::function<void(World&)>& before_step) {
  for (const ScriptCommand& command : script.commands()) {
    try {
      switch (command.kind) {
        case ScriptCommand::Kind::kConnect: {
          const MorphologyConnection& c = command.connection;
          world.Connect(c.from, c.from_connector, c.to, c.to_connector, c.angle_steps);
          break;
        }
        case ScriptCommand::Kind::kDisconnect:
          world.Disconnect(command.id, /*put_away=*/true);
          break;
        case ScriptCommand::Kind::kPause: {
          const auto steps = static_cast<long>(
              std::llround(command.delay_ms * 1e-3 / world.options().time_step));
          for (long s = 0; s < steps; ++s) {
            if (before_step) before_step(world);
            world.Step();
            if (world.Diverged()) {
              throw Error(StatusCode::kFailedPrecondition,
                          "world diverged: " + world.Divergence().reason);
            }
          }
          break;
        }
      }
    } catch (const Error& error) {
      throw Error(error.code(),
                  script.source() + ":" + std::to_string(command.line) + ": " + error.what());
    }
  }
}

}  // namespace yamor::physics
