#include "physics/morphology.h"

#include <cmath>
#include <cstdlib>
#include <deque>
#include <fstream>
#include <set>
#include <sstream>

#include <tinyxml2.h>

#include "common/format.h"
#include "common/status.h"
#include "physics/box_overlap.h"
#include "physics/placement.h"

namespace yamor::physics {
namespace {

constexpr double kPi = 3.14159265358979323846;
// A loop-closing connection is accepted when the pose it implies agrees with
// the pose already computed within these tolerances.
constexpr double kClosurePositionTolerance = 5e-4;               // m
constexpr double kClosureAngleTolerance = 0.5 * kPi / 180.0;     // rad
// Boxes are shrunk by this much per face before the overlap test, so faces
// that merely touch (connected modules sit 100 µm apart) do not count.
constexpr double kOverlapTolerance = 5e-4;  // m
constexpr int kMaxModuleId = 1 << 20;
// Starting hinge angles stay inside the servo's ±90° stops.
constexpr double kMaxStartAngleDegrees = 90.0;

[[noreturn]] void Fail(const std::string& message) {
  throw Error(StatusCode::kInvalidArgument, message);
}

std::string Quote(std::string_view text) {
  std::string quoted;
  quoted.reserve(text.size() + 2);
  quoted.push_back('"');
  quoted.append(text);
  quoted.push_back('"');
  return quoted;
}

// Strict parsers: the whole attribute must be consumed.
bool ParseInt(const char* text, int* value) {
  if (text == nullptr || *text == '\0') return false;
  char* end = nullptr;
  const long parsed = std::strtol(text, &end, 10);
  if (*end != '\0' || parsed < -kMaxModuleId || parsed > kMaxModuleId) return false;
  *value = static_cast<int>(parsed);
  return true;
}

bool ParseDouble(const char* text, double* value) {
  if (text == nullptr || *text == '\0') return false;
  char* end = nullptr;
  const double parsed = std::strtod(text, &end);
  if (*end != '\0' || !std::isfinite(parsed)) return false;
  *value = parsed;
  return true;
}

class ElementReader {
 public:
  ElementReader(const tinyxml2::XMLElement* element, std::string where)
      : element_(element), where_(std::move(where)) {}

  // Rejects attributes outside `allowed` (catches typos such as "conto").
  void CheckAttributes(const std::set<std::string_view>& allowed) const {
    for (const tinyxml2::XMLAttribute* a = element_->FirstAttribute(); a; a = a->Next()) {
      if (allowed.count(a->Name()) == 0) {
        Fail(where_ + ": <" + element_->Name() + "> has unknown attribute " + a->Name() + "=" +
             Quote(a->Value()));
      }
    }
  }

  const char* Required(const char* name) const {
    const char* value = element_->Attribute(name);
    if (value == nullptr) {
      Fail(where_ + ": <" + element_->Name() + "> is missing attribute " + name);
    }
    return value;
  }

  int RequiredId(const char* name) const {
    const char* text = Required(name);
    int id = 0;
    if (!ParseInt(text, &id) || id < 0) {
      Fail(where_ + ": " + name + "=" + Quote(text) + " is not a module id (a non-negative integer)");
    }
    return id;
  }

  ConnectorId RequiredConnector(const char* name, const char* owner_attribute) const {
    const char* text = Required(name);
    const auto connector = ParseConnectorName(text);
    if (!connector) {
      Fail(where_ + ": module " + element_->Attribute(owner_attribute) + ": unknown connector " +
           name + "=" + Quote(text) + " (expected front, rear, left, right, top or bottom)");
    }
    return *connector;
  }

  bool OptionalBool(const char* name, bool fallback) const {
    const char* text = element_->Attribute(name);
    if (text == nullptr) return fallback;
    const std::string_view value(text);
    if (value == "true" || value == "1") return true;
    if (value == "false" || value == "0") return false;
    Fail(where_ + ": " + name + "=" + Quote(text) + " is not a boolean (true or false)");
  }

 private:
  const tinyxml2::XMLElement* element_;
  std::string where_;
};

int AngleSteps(const char* text, const std::string& where) {
  double degrees = 0;
  if (!ParseDouble(text, &degrees)) {
    Fail(where + ": angle=" + Quote(text) + " is not a number of degrees");
  }
  const double steps = degrees / 15.0;
  const double rounded = std::round(steps);
  if (std::abs(steps - rounded) > 1e-9) {
    Fail(where + ": angle=" + Quote(text) + " is not a multiple of 15 degrees");
  }
  const int modulo = static_cast<int>(std::fmod(rounded, module::kConnectionAngleSteps));
  return (modulo + module::kConnectionAngleSteps) % module::kConnectionAngleSteps;
}

// Text safe inside a double-quoted XML attribute.
std::string EscapeXml(std::string_view text) {
  std::string out;
  for (const char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\n': out += "&#10;"; break;
      case '\r': out += "&#13;"; break;
      case '\t': out += "&#9;"; break;
      default: out.push_back(c);
    }
  }
  return out;
}

// Three numbers separated by blanks; false unless exactly three finite ones.
bool ParseTriple(const char* text, Eigen::Vector3d* value) {
  if (text == nullptr) return false;
  std::istringstream in(text);
  Eigen::Vector3d parsed;
  std::string word[3];
  std::string rest;
  if (!(in >> word[0] >> word[1] >> word[2]) || (in >> rest)) return false;
  for (int i = 0; i < 3; ++i) {
    if (!ParseDouble(word[i].c_str(), &parsed[i])) return false;
  }
  *value = parsed;
  return true;
}

std::string FormatTriple(const Eigen::Vector3d& v) {
  return FormatDouble(v.x()) + " " + FormatDouble(v.y()) + " " + FormatDouble(v.z());
}

std::string FormatNumber(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

}  // namespace

double MorphologyModule::StartAngle() const { return angle_degrees * (kPi / 180.0); }

Eigen::Vector3d NearestFrameAxis(const Eigen::Vector3d& direction) {
  Eigen::Index axis = 0;
  direction.cwiseAbs().maxCoeff(&axis);
  Eigen::Vector3d unit = Eigen::Vector3d::Zero();
  unit[axis] = direction[axis] < 0.0 ? -1.0 : 1.0;
  return unit;
}

Eigen::Vector3d CentralUpAxis(const Morphology& morphology) {
  const Eigen::Matrix3d rotation = morphology.BodyPose(morphology.central()).linear();
  return NearestFrameAxis(rotation.transpose() * Eigen::Vector3d::UnitZ());
}

Eigen::Matrix3d RotationFromRollPitchYaw(const Eigen::Vector3d& degrees) {
  const Eigen::Vector3d radians = degrees * (kPi / 180.0);
  return (Eigen::AngleAxisd(radians.z(), Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(radians.y(), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(radians.x(), Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

Morphology Morphology::LoadFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    throw Error(StatusCode::kNotFound, "cannot read morphology file " + path.string());
  }
  std::ostringstream text;
  text << in.rdbuf();
  return Parse(text.str(), path.string());
}

Morphology Morphology::Parse(std::string_view xml, std::string_view source) {
  Morphology result;
  result.source_ = std::string(source);
  tinyxml2::XMLDocument document;
  if (document.Parse(xml.data(), xml.size()) != tinyxml2::XML_SUCCESS) {
    Fail(result.Where(document.ErrorLineNum()) + ": malformed XML: " + document.ErrorStr());
  }
  const tinyxml2::XMLElement* root = document.RootElement();
  if (root == nullptr || std::string_view(root->Name()) != "morphology") {
    Fail(result.Where(root ? root->GetLineNum() : 1) +
         ": the document element must be <morphology>");
  }
  const ElementReader root_reader(root, result.Where(root->GetLineNum()));
  root_reader.CheckAttributes({"central", "orientation"});
  result.central_ = root_reader.RequiredId("central");
  if (const char* orientation = root->Attribute("orientation")) {
    std::istringstream in(orientation);
    Eigen::Vector3d degrees;
    std::string rest;
    if (!(in >> degrees.x() >> degrees.y() >> degrees.z()) || (in >> rest) ||
        !degrees.allFinite()) {
      Fail(result.Where(root->GetLineNum()) + ": orientation=" + Quote(orientation) +
           " is not three numbers (roll pitch yaw in degrees)");
    }
    result.orientation_degrees_ = degrees;
  }

  for (const tinyxml2::XMLElement* element = root->FirstChildElement(); element;
       element = element->NextSiblingElement()) {
    const std::string where = result.Where(element->GetLineNum());
    const ElementReader reader(element, where);
    const std::string_view name(element->Name());
    if (name == "module") {
      reader.CheckAttributes({"id", "free", "angle"});
      MorphologyModule module;
      module.id = reader.RequiredId("id");
      module.free = reader.OptionalBool("free", false);
      if (const char* angle = element->Attribute("angle")) {
        if (!ParseDouble(angle, &module.angle_degrees)) {
          Fail(where + ": module " + std::to_string(module.id) + ": angle=" + Quote(angle) +
               " is not a number of degrees");
        }
      }
      module.line = element->GetLineNum();
      result.modules_.push_back(module);
    } else if (name == "connect") {
      reader.CheckAttributes({"idfrom", "connfrom", "idto", "connto", "angle"});
      MorphologyConnection connection;
      connection.from = reader.RequiredId("idfrom");
      connection.from_connector = reader.RequiredConnector("connfrom", "idfrom");
      connection.to = reader.RequiredId("idto");
      connection.to_connector = reader.RequiredConnector("connto", "idto");
      const char* angle = element->Attribute("angle");
      connection.angle_steps = angle == nullptr ? 0 : AngleSteps(angle, where);
      connection.line = element->GetLineNum();
      result.connections_.push_back(connection);
    } else if (name == "box") {
      reader.CheckAttributes({"name", "size", "position", "orientation"});
      StaticBox box;
      box.line = element->GetLineNum();
      if (const char* box_name = element->Attribute("name")) box.name = box_name;
      const std::string label =
          "box " + (box.name.empty() ? std::to_string(result.boxes_.size() + 1) : Quote(box.name));
      const char* size = reader.Required("size");
      if (!ParseTriple(size, &box.size)) {
        Fail(where + ": " + label + ": size=" + Quote(size) +
             " is not three finite numbers (x y z edge lengths in metres)");
      }
      if (const char* position = element->Attribute("position")) {
        if (!ParseTriple(position, &box.position)) {
          Fail(where + ": " + label + ": position=" + Quote(position) +
               " is not three finite numbers (x y z of the centre in metres)");
        }
      }
      if (const char* orientation = element->Attribute("orientation")) {
        if (!ParseTriple(orientation, &box.orientation_degrees)) {
          Fail(where + ": " + label + ": orientation=" + Quote(orientation) +
               " is not three finite numbers (roll pitch yaw in degrees)");
        }
      }
      result.boxes_.push_back(std::move(box));
    } else {
      Fail(where + ": unknown element <" + std::string(name) +
           "> (expected <module>, <connect> or <box>)");
    }
  }
  result.Validate();
  return result;
}

Morphology Morphology::Build(int central, std::vector<MorphologyModule> modules,
                             std::vector<MorphologyConnection> connections,
                             const Eigen::Vector3d& orientation_degrees, std::string source,
                             std::vector<StaticBox> boxes) {
  Morphology result;
  result.central_ = central;
  result.boxes_ = std::move(boxes);
  result.modules_ = std::move(modules);
  result.connections_ = std::move(connections);
  result.orientation_degrees_ = orientation_degrees;
  result.source_ = std::move(source);
  if (!orientation_degrees.allFinite()) {
    Fail(result.source_ + ": orientation is not finite");
  }
  for (MorphologyConnection& c : result.connections_) {
    if (c.angle_steps < 0 || c.angle_steps >= module::kConnectionAngleSteps) {
      Fail(result.Where(c.line) + ": connection " + std::to_string(c.from) + " -> " +
           std::to_string(c.to) + ": angle step " + std::to_string(c.angle_steps) +
           " outside [0, 24)");
    }
  }
  result.Validate();
  return result;
}

std::string Morphology::Where(int line) const {
  if (line <= 0) return source_;
  return source_ + ":" + std::to_string(line);
}

const MorphologyModule& Morphology::Module(int id) const {
  const auto it = index_.find(id);
  if (it == index_.end()) {
    throw Error(StatusCode::kNotFound, "morphology " + source_ + " has no module " +
                                           std::to_string(id));
  }
  return modules_[it->second];
}

const Eigen::Isometry3d& Morphology::BodyPose(int id) const {
  const MorphologyModule& module = Module(id);
  if (module.free) {
    throw Error(StatusCode::kFailedPrecondition,
                "module " + std::to_string(id) + " is free and has no pose in the robot");
  }
  return body_poses_.at(id);
}

void Morphology::Validate() {
  ValidateBoxes();
  for (size_t i = 0; i < modules_.size(); ++i) {
    const MorphologyModule& module = modules_[i];
    if (module.id < 0 || module.id > kMaxModuleId) {
      Fail(Where(module.line) + ": module id " + std::to_string(module.id) + " out of range");
    }
    if (!std::isfinite(module.angle_degrees) ||
        std::abs(module.angle_degrees) > kMaxStartAngleDegrees) {
      Fail(Where(module.line) + ": module " + std::to_string(module.id) + ": angle=" +
           Quote(FormatDouble(module.angle_degrees)) +
           " is outside the hinge range [-90, 90] degrees");
    }
    if (module.free && module.angle_degrees != 0.0) {
      Fail(Where(module.line) + ": module " + std::to_string(module.id) +
           " is free: a spare is connected with its servo at 0, so it takes no angle");
    }
    if (!index_.emplace(module.id, i).second) {
      Fail(Where(module.line) + ": duplicate module id=\"" + std::to_string(module.id) +
           "\" (first declared at line " + std::to_string(modules_[index_[module.id]].line) + ")");
    }
  }
  if (!Contains(central_)) {
    Fail(Where(0) + ": central module " + std::to_string(central_) + " is not declared");
  }
  if (Module(central_).free) {
    Fail(Where(Module(central_).line) + ": central module " + std::to_string(central_) +
         " cannot be free");
  }

  // Per connection checks: known modules, distinct ends, connectors used once,
  // free modules unconnected.
  std::map<std::pair<int, ConnectorId>, int> used;  // (module, connector) -> line
  for (const MorphologyConnection& c : connections_) {
    const std::string where = Where(c.line);
    for (const auto& [id, attribute] : {std::pair{c.from, "idfrom"}, std::pair{c.to, "idto"}}) {
      if (!Contains(id)) {
        Fail(where + ": " + attribute + "=\"" + std::to_string(id) + "\": unknown module");
      }
      if (Module(id).free) {
        Fail(where + ": " + attribute + "=\"" + std::to_string(id) +
             "\": module is marked free and cannot be connected");
      }
    }
    if (c.from == c.to) {
      Fail(where + ": module " + std::to_string(c.from) + " cannot connect to itself");
    }
    for (const auto& [id, connector, attribute] :
         {std::tuple{c.from, c.from_connector, "connfrom"},
          std::tuple{c.to, c.to_connector, "connto"}}) {
      const auto [it, inserted] = used.emplace(std::pair{id, connector}, c.line);
      if (!inserted) {
        Fail(where + ": module " + std::to_string(id) + ": connector " + attribute + "=\"" +
             std::string(ConnectorName(connector)) + "\" already used (line " +
             std::to_string(it->second) + ")");
      }
    }
  }

  // Breadth-first placement from the central module. A connection whose both
  // ends are already placed closes a loop and must agree with the poses.
  Eigen::Isometry3d root = Eigen::Isometry3d::Identity();
  root.linear() = RotationFromRollPitchYaw(orientation_degrees_);
  body_poses_.clear();
  body_poses_[central_] = root;
  std::map<int, int> placed_by_line{{central_, Module(central_).line}};
  std::vector<bool> resolved(connections_.size(), false);
  std::deque<int> frontier{central_};
  while (!frontier.empty()) {
    const int current = frontier.front();
    frontier.pop_front();
    for (size_t k = 0; k < connections_.size(); ++k) {
      const MorphologyConnection& c = connections_[k];
      if (resolved[k] || (c.from != current && c.to != current)) continue;
      resolved[k] = true;
      const bool from_is_current = c.from == current;
      const int other = from_is_current ? c.to : c.from;
      const ConnectorId fixed = from_is_current ? c.from_connector : c.to_connector;
      const ConnectorId moving = from_is_current ? c.to_connector : c.from_connector;
      const Eigen::Isometry3d pose =
          MateBodyPose(body_poses_.at(current), Module(current).StartAngle(), fixed, moving,
                       Module(other).StartAngle(), c.angle_steps);
      const auto existing = body_poses_.find(other);
      if (existing == body_poses_.end()) {
        body_poses_[other] = pose;
        placed_by_line[other] = c.line;
        frontier.push_back(other);
        continue;
      }
      const double position_error = (existing->second.translation() - pose.translation()).norm();
      const double angle_error =
          Eigen::AngleAxisd(existing->second.linear().transpose() * pose.linear()).angle();
      if (position_error > kClosurePositionTolerance || angle_error > kClosureAngleTolerance) {
        Fail(Where(c.line) + ": connection idfrom=\"" + std::to_string(c.from) + "\" idto=\"" +
             std::to_string(c.to) + "\" closes a loop inconsistently (connectors " +
             FormatNumber(position_error * 1000) + " mm and " +
             FormatNumber(angle_error * 180 / kPi) + " degrees apart)");
      }
    }
  }
  for (const MorphologyModule& module : modules_) {
    if (!module.free && body_poses_.count(module.id) == 0) {
      Fail(Where(module.line) + ": module id=\"" + std::to_string(module.id) +
           "\" is not connected to central module " + std::to_string(central_) +
           " (mark it free=\"true\" if it is a spare)");
    }
  }

  // Overlap test between every pair of placed modules (servos at their start).
  std::vector<int> placed;
  std::map<int, std::vector<OrientedBox>> boxes;
  for (const MorphologyModule& module : modules_) {
    if (module.free) continue;
    placed.push_back(module.id);
    boxes[module.id] = ModuleWorldBoxes(body_poses_.at(module.id), module.StartAngle());
  }
  for (size_t i = 0; i < placed.size(); ++i) {
    for (size_t j = i + 1; j < placed.size(); ++j) {
      const auto& boxes_i = boxes[placed[i]];
      const auto& boxes_j = boxes[placed[j]];
      for (size_t a = 0; a < boxes_i.size(); ++a) {
        for (size_t b = 0; b < boxes_j.size(); ++b) {
          if (BoxesOverlap(boxes_i[a], boxes_j[b], kOverlapTolerance)) {
            Fail(Where(placed_by_line.at(placed[j])) + ": module id=\"" +
                 std::to_string(placed[j]) + "\" (" + std::string(ModuleBoxes()[b].name) +
                 ") overlaps module id=\"" + std::to_string(placed[i]) + "\" (" +
                 std::string(ModuleBoxes()[a].name) + ") once placed");
          }
        }
      }
    }
  }
}

void Morphology::ValidateBoxes() {
  if (boxes_.size() > kMaxStaticBoxes) {
    Fail(Where(boxes_[kMaxStaticBoxes].line) + ": " + std::to_string(boxes_.size()) +
         " static boxes, at most " + std::to_string(kMaxStaticBoxes));
  }
  std::set<std::string> names;
  for (size_t i = 0; i < boxes_.size(); ++i) {
    StaticBox& box = boxes_[i];
    if (box.name.empty()) box.name = "box " + std::to_string(i + 1);
    const std::string label = Where(box.line) + ": box " + Quote(box.name);
    if (!names.insert(box.name).second) Fail(label + ": duplicate box name");
    for (int k = 0; k < 3; ++k) {
      if (!std::isfinite(box.size[k]) || box.size[k] < kMinStaticBoxEdge ||
          box.size[k] > kMaxStaticBoxExtent) {
        Fail(label + ": size=" + Quote(FormatTriple(box.size)) + " needs three edge lengths in [" +
             FormatDouble(kMinStaticBoxEdge) + ", " + FormatDouble(kMaxStaticBoxExtent) + "] m (" +
             "xyz"[k] + " is " + FormatDouble(box.size[k]) + ")");
      }
      if (!std::isfinite(box.position[k]) || std::abs(box.position[k]) > kMaxStaticBoxExtent) {
        Fail(label + ": position=" + Quote(FormatTriple(box.position)) +
             " needs three finite coordinates within " + FormatDouble(kMaxStaticBoxExtent) +
             " m of the origin (" + "xyz"[k] + " is " + FormatDouble(box.position[k]) + ")");
      }
      if (!std::isfinite(box.orientation_degrees[k])) {
        Fail(label + ": orientation=" + Quote(FormatTriple(box.orientation_degrees)) +
             " is not finite (roll pitch yaw in degrees)");
      }
    }
  }
}

Eigen::Isometry3d StaticBox::Pose() const {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = RotationFromRollPitchYaw(orientation_degrees);
  pose.translation() = position;
  return pose;
}

std::string Morphology::ToXml() const {
  std::ostringstream out;
  out << "<morphology central=\"" << central_ << "\"";
  if (!orientation_degrees_.isZero()) {
    out << " orientation=\"" << FormatNumber(orientation_degrees_.x()) << " "
        << FormatNumber(orientation_degrees_.y()) << " " << FormatNumber(orientation_degrees_.z())
        << "\"";
  }
  out << ">\n";
  for (const MorphologyModule& module : modules_) {
    out << "  <module id=\"" << module.id << "\"" << (module.free ? " free=\"true\"" : "");
    if (module.angle_degrees != 0.0) out << " angle=\"" << FormatDouble(module.angle_degrees) << "\"";
    out << "/>\n";
  }
  for (const MorphologyConnection& c : connections_) {
    out << "  <connect idfrom=\"" << c.from << "\" connfrom=\"" << ConnectorName(c.from_connector)
        << "\" idto=\"" << c.to << "\" connto=\"" << ConnectorName(c.to_connector)
        << "\" angle=\"" << c.angle_steps * 15 << "\"/>\n";
  }
  for (const StaticBox& box : boxes_) {
    out << "  <box name=" << Quote(EscapeXml(box.name)) << " size=" << Quote(FormatTriple(box.size))
        << " position=" << Quote(FormatTriple(box.position));
    if (!box.orientation_degrees.isZero()) {
      out << " orientation=" << Quote(FormatTriple(box.orientation_degrees));
    }
    out << "/>\n";
  }
  out << "</morphology>\n";
  return out.str();
}

}  // namespace yamor::physics
