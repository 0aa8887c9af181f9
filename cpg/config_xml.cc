#include "cpg/config_xml.h"

#include <tinyxml2.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <initializer_list>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "common/format.h"
#include "common/status.h"

namespace yamor::cpg {
namespace {

using tinyxml2::XMLAttribute;
using tinyxml2::XMLElement;
using tinyxml2::XMLNode;

[[noreturn]] void Fail(const std::string& message) {
  throw Error(StatusCode::kInvalidArgument, message);
}

// XML Schema collapses whitespace around numeric values, so do we.
std::string_view Trim(std::string_view text) {
  constexpr std::string_view kSpace = " \t\r\n";
  const auto first = text.find_first_not_of(kSpace);
  if (first == std::string_view::npos) return {};
  return text.substr(first, text.find_last_not_of(kSpace) - first + 1);
}

// Reads one document; every message starts with "<file>:<line>: ".
// Thread-safety: single use by one thread (one Reader per parse).
class Reader {
 public:
  explicit Reader(std::string_view source_name,
                  std::vector<std::string> skipped_root_elements = {})
      : file_(source_name),
        skipped_root_elements_(std::move(skipped_root_elements)) {}

  RobotConfig Read(std::string_view xml) {
    tinyxml2::XMLDocument document;
    if (document.Parse(xml.data(), xml.size()) != tinyxml2::XML_SUCCESS) {
      Fail(At(document.ErrorLineNum()) + "malformed XML: " +
           document.ErrorStr());
    }
    config_.source_file = file_;
    const XMLElement* root = nullptr;
    for (const XMLNode* node = document.FirstChild(); node != nullptr;
         node = node->NextSibling()) {
      if (node->ToDeclaration() != nullptr || node->ToComment() != nullptr) {
        continue;
      }
      if (const XMLElement* element = node->ToElement()) {
        if (root != nullptr) {
          Fail(At(element) + "a second root element <" + element->Name() +
               "> after <" + root->Name() + ">");
        }
        root = element;
        continue;
      }
      CheckIgnorable(node, "the document");
    }
    if (root == nullptr) Fail(At(1) + "no <yamorconfig> element");
    ReadRoot(*root);
    Validate(config_);
    return std::move(config_);
  }

 private:
  std::string At(int line) const {
    return file_ + ":" + std::to_string(std::max(line, 1)) + ": ";
  }
  std::string At(const XMLNode* node) const { return At(node->GetLineNum()); }

  SourceLocation Location(const XMLNode* node) const {
    return SourceLocation{file_, node->GetLineNum()};
  }

  // Comments and whitespace may appear anywhere; anything else is an error.
  void CheckIgnorable(const XMLNode* node, const std::string& parent) const {
    if (node->ToComment() != nullptr) return;
    if (node->ToText() != nullptr && Trim(node->Value()).empty()) return;
    if (node->ToText() != nullptr) {
      Fail(At(node) + "unexpected text \"" + std::string(Trim(node->Value())) +
           "\" in " + parent);
    }
    Fail(At(node) + "unexpected markup \"" + node->Value() + "\" in " +
         parent);
  }

  // Rejects attributes other than `allowed` (typos must not pass silently).
  void CheckAttributes(const XMLElement& element,
                       std::initializer_list<std::string_view> allowed,
                       const std::string& context) const {
    for (const XMLAttribute* attribute = element.FirstAttribute();
         attribute != nullptr; attribute = attribute->Next()) {
      const std::string_view name = attribute->Name();
      if (std::find(allowed.begin(), allowed.end(), name) == allowed.end()) {
        Fail(At(attribute->GetLineNum()) + context + "unknown attribute " +
             std::string(name) + " on <" + element.Name() + ">");
      }
    }
  }

  const XMLAttribute& Required(const XMLElement& element, const char* name,
                               const std::string& context) const {
    const XMLAttribute* attribute = element.FindAttribute(name);
    if (attribute == nullptr) {
      Fail(At(&element) + context + "missing attribute " + name + " on <" +
           element.Name() + ">");
    }
    return *attribute;
  }

  int ParseInt(const XMLAttribute& attribute,
               const std::string& context) const {
    const std::string_view text = Trim(attribute.Value());
    int value = 0;
    const auto [end, error] =
        std::from_chars(text.data(), text.data() + text.size(), value);
    if (text.empty() || error != std::errc() ||
        end != text.data() + text.size()) {
      Fail(At(attribute.GetLineNum()) + context + attribute.Name() + " (\"" +
           attribute.Value() + "\") is not an integer module id");
    }
    return value;
  }

  // std::from_chars, unlike strtod, ignores the locale's decimal point.
  double ParseDouble(const XMLAttribute& attribute,
                     const std::string& context) const {
    std::string_view text = Trim(attribute.Value());
    if (text.size() > 1 && text[0] == '+' && text[1] != '-') {
      text.remove_prefix(1);
    }
    double value = 0.0;
    const auto [end, error] =
        std::from_chars(text.data(), text.data() + text.size(), value);
    const std::string where = At(attribute.GetLineNum()) + context +
                              attribute.Name() + " (\"" + attribute.Value() +
                              "\")";
    if (text.empty() || end != text.data() + text.size() ||
        (error != std::errc() && error != std::errc::result_out_of_range)) {
      Fail(where + " is not a number");
    }
    if (error == std::errc::result_out_of_range) {
      Fail(where + " is out of the range of a finite double");
    }
    if (!std::isfinite(value)) Fail(where + " must be finite");
    return value;
  }

  void ReadRoot(const XMLElement& root) {
    if (std::string_view(root.Name()) != "yamorconfig") {
      Fail(At(&root) + "root element is <" + root.Name() +
           ">, expected <yamorconfig>");
    }
    config_.master_location = Location(&root);
    std::optional<ModuleId> master;
    for (const XMLAttribute* attribute = root.FirstAttribute();
         attribute != nullptr; attribute = attribute->Next()) {
      const std::string_view name = attribute->Name();
      if (name == "master") {
        master = ParseInt(*attribute, "");
      } else if (!name.starts_with("xmlns") && !name.starts_with("xsi:")) {
        Fail(At(attribute->GetLineNum()) + "unknown attribute " +
             std::string(name) + " on <yamorconfig>");
      }
    }
    const XMLElement* list = nullptr;
    for (const XMLNode* node = root.FirstChild(); node != nullptr;
         node = node->NextSibling()) {
      const XMLElement* element = node->ToElement();
      if (element == nullptr) {
        CheckIgnorable(node, "<yamorconfig>");
        continue;
      }
      if (std::find(skipped_root_elements_.begin(),
                    skipped_root_elements_.end(),
                    element->Name()) != skipped_root_elements_.end()) {
        continue;
      }
      if (std::string_view(element->Name()) != "modulelist") {
        Fail(At(element) + "unknown element <" + element->Name() +
             "> in <yamorconfig>");
      }
      if (list != nullptr) {
        Fail(At(element) + "a second <modulelist> (the first is at line " +
             std::to_string(list->GetLineNum()) + ")");
      }
      list = element;
    }
    if (list == nullptr) Fail(At(&root) + "<yamorconfig> has no <modulelist>");
    ReadModuleList(*list);
    CheckBluetoothChildren();
    if (master.has_value()) {
      config_.master_id = *master;
    } else {
      config_.master_id = RootOfTree(root);
    }
  }

  void ReadModuleList(const XMLElement& list) {
    CheckAttributes(list, {}, "");
    for (const XMLNode* node = list.FirstChild(); node != nullptr;
         node = node->NextSibling()) {
      const XMLElement* element = node->ToElement();
      if (element == nullptr) {
        CheckIgnorable(node, "<modulelist>");
        continue;
      }
      if (std::string_view(element->Name()) != "module") {
        Fail(At(element) + "unknown element <" + element->Name() +
             "> in <modulelist>");
      }
      ReadModule(*element);
    }
    if (config_.modules.empty()) {
      Fail(At(&list) + "<modulelist> has no <module>: a configuration needs "
                       "at least one");
    }
  }

  ModuleId ReadModuleId(const XMLElement& element) const {
    const XMLAttribute* realid = element.FindAttribute("realid");
    const XMLAttribute* id = element.FindAttribute("id");
    if (realid == nullptr && id == nullptr) {
      Fail(At(&element) + "missing attribute realid (or id) on <module>");
    }
    if (realid != nullptr && id != nullptr) {
      const ModuleId a = ParseInt(*realid, "");
      const ModuleId b = ParseInt(*id, "");
      if (a != b) {
        Fail(At(&element) + "module " + std::to_string(a) + ": realid (" +
             std::to_string(a) + ") and id (" + std::to_string(b) +
             ") disagree");
      }
      return a;
    }
    return ParseInt(realid != nullptr ? *realid : *id, "");
  }

  void ReadModule(const XMLElement& element) {
    ModuleParams module;
    module.id = ReadModuleId(element);
    const std::string context = "module " + std::to_string(module.id) + ": ";
    CheckAttributes(element,
                    {"realid", "id", "amplitude", "speed", "offset",
                     "minangle", "maxangle"},
                    context);
    const auto number = [&](const char* name) {
      return ParseDouble(Required(element, name, context), context);
    };
    module.amplitude = number("amplitude");
    module.offset = number("offset");
    module.speed = number("speed");
    module.min_angle = number("minangle");
    module.max_angle = number("maxangle");
    if (const auto it = config_.module_locations.find(module.id);
        it != config_.module_locations.end()) {
      Fail(At(&element) + context + "realid " + std::to_string(module.id) +
           " duplicates the module at line " + std::to_string(it->second.line));
    }
    config_.module_locations[module.id] = Location(&element);
    config_.modules.push_back(module);

    for (const XMLNode* node = element.FirstChild(); node != nullptr;
         node = node->NextSibling()) {
      const XMLElement* child = node->ToElement();
      if (child == nullptr) {
        CheckIgnorable(node, "<module>");
        continue;
      }
      const std::string_view name = child->Name();
      if (name == "bluetooth") {
        ReadBluetooth(*child, module.id, context);
      } else if (name == "cpglink" || name == "cpmlink") {
        ReadCoupling(*child, module.id, context);
      } else {
        Fail(At(child) + context + "unknown element <" + std::string(name) +
             "> in <module>");
      }
    }
  }

  void ReadBluetooth(const XMLElement& element, ModuleId parent,
                     const std::string& context) {
    CheckAttributes(element, {"to"}, context);
    const ModuleId child =
        ParseInt(Required(element, "to", context), context + "bluetooth ");
    if (const auto it = config_.bluetooth_parent.find(child);
        it != config_.bluetooth_parent.end()) {
      Fail(At(&element) + context + "bluetooth to (" + std::to_string(child) +
           "): module " + std::to_string(child) +
           " already has bluetooth parent " + std::to_string(it->second) +
           " (line " +
           std::to_string(config_.bluetooth_locations[child].line) + ")");
    }
    config_.bluetooth_parent[child] = parent;
    config_.bluetooth_locations[child] = Location(&element);
  }

  void ReadCoupling(const XMLElement& element, ModuleId from,
                    const std::string& context) {
    CheckAttributes(element, {"to", "phase", "weight"}, context);
    Coupling coupling;
    coupling.from = from;
    coupling.to = ParseInt(Required(element, "to", context),
                           context + element.Name() + " ");
    const std::string link_context =
        context + "cpglink to (" + std::to_string(coupling.to) + "): ";
    coupling.phase =
        ParseDouble(Required(element, "phase", link_context), link_context);
    coupling.weight =
        ParseDouble(Required(element, "weight", link_context), link_context);
    if (const auto it = config_.coupling_locations.find({from, coupling.to});
        it != config_.coupling_locations.end()) {
      Fail(At(&element) + context + "cpglink to (" +
           std::to_string(coupling.to) + ") appears twice (first at line " +
           std::to_string(it->second.line) + ")");
    }
    config_.coupling_locations[{from, coupling.to}] = Location(&element);
    config_.couplings.push_back(coupling);
  }

  // Checked before the root is inferred so that a typo in a child id reads
  // as such, not as a second root.
  void CheckBluetoothChildren() const {
    for (const auto& [child, parent] : config_.bluetooth_parent) {
      if (!config_.module_locations.contains(child)) {
        Fail(At(config_.bluetooth_locations.at(child).line) + "module " +
             std::to_string(parent) + ": bluetooth to (" +
             std::to_string(child) + ") names no listed module");
      }
    }
  }

  ModuleId RootOfTree(const XMLElement& root) const {
    std::vector<ModuleId> roots;
    for (const ModuleParams& module : config_.modules) {
      if (!config_.bluetooth_parent.contains(module.id)) {
        roots.push_back(module.id);
      }
    }
    if (roots.size() == 1) return roots.front();
    if (roots.empty()) {
      Fail(At(&root) + "no master attribute, and the bluetooth tree has no "
                       "root (every module is a bluetooth child: a cycle)");
    }
    std::string list;
    for (ModuleId id : roots) {
      list += (list.empty() ? "" : ", ") + std::to_string(id);
    }
    Fail(At(&root) + "no master attribute, and the bluetooth tree has " +
         std::to_string(roots.size()) + " roots (modules " + list +
         "); connect them or name the master");
  }

  std::string file_;
  std::vector<std::string> skipped_root_elements_;
  RobotConfig config_;
};

}  // namespace

RobotConfig ParseConfigXml(std::string_view xml, std::string_view source_name) {
  return Reader(source_name).Read(xml);
}

RobotConfig ParseConfigXmlSkipping(
    std::string_view xml, std::string_view source_name,
    const std::vector<std::string>& extra_root_elements) {
  return Reader(source_name, extra_root_elements).Read(xml);
}

RobotConfig LoadConfigFile(const std::string& path) {
  std::error_code error;
  if (std::filesystem::is_directory(path, error)) {
    throw Error(StatusCode::kNotFound,
                "cannot read config file " + path + ": it is a directory");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    throw Error(StatusCode::kNotFound, "cannot read config file " + path +
                                           ": " + std::strerror(errno));
  }
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) {
    throw Error(StatusCode::kNotFound,
                "cannot read config file " + path + ": read error");
  }
  return ParseConfigXml(text.str(), path);
}

std::string WriteConfigXml(const RobotConfig& config) {
  Validate(config);
  std::map<ModuleId, std::vector<ModuleId>> children;  // sorted by child id
  for (const auto& [child, parent] : config.bluetooth_parent) {
    children[parent].push_back(child);
  }
  std::string out = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  out += "<yamorconfig master=\"" + std::to_string(config.master_id) + "\">\n";
  out += "  <modulelist>\n";
  for (const ModuleParams& module : config.modules) {
    out += "    <module realid=\"" + std::to_string(module.id) +
           "\" amplitude=\"" + FormatDouble(module.amplitude) + "\" offset=\"" +
           FormatDouble(module.offset) + "\" speed=\"" + FormatDouble(module.speed) +
           "\" minangle=\"" + FormatDouble(module.min_angle) + "\" maxangle=\"" +
           FormatDouble(module.max_angle) + "\"";
    std::string body;
    if (const auto it = children.find(module.id); it != children.end()) {
      for (ModuleId child : it->second) {
        body += "      <bluetooth to=\"" + std::to_string(child) + "\"/>\n";
      }
    }
    for (const Coupling& coupling : config.couplings) {
      if (coupling.from != module.id) continue;
      body += "      <cpglink to=\"" + std::to_string(coupling.to) +
              "\" phase=\"" + FormatDouble(coupling.phase) + "\" weight=\"" +
              FormatDouble(coupling.weight) + "\"/>\n";
    }
    out += body.empty() ? "/>\n" : ">\n" + body + "    </module>\n";
  }
  out += "  </modulelist>\n";
  out += "</yamorconfig>\n";
  return out;
}

void SaveConfigFile(const RobotConfig& config, const std::string& path) {
  const std::string text = WriteConfigXml(config);
  // Write beside the target and rename, so a failure never leaves half a file.
  const std::string temporary = path + ".tmp";
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    if (!out) {
      throw Error(StatusCode::kNotFound, "cannot write config file " + path +
                                             ": " + std::strerror(errno));
    }
    out << text;
    out.flush();
    if (!out) {
      std::remove(temporary.c_str());
      throw Error(StatusCode::kDataLoss,
                  "cannot write config file " + path + ": write error");
    }
  }
  if (std::rename(temporary.c_str(), path.c_str()) != 0) {
    const std::string reason = std::strerror(errno);
    std::remove(temporary.c_str());
    throw Error(StatusCode::kDataLoss,
                "cannot write config file " + path + ": " + reason);
  }
}

}  // namespace yamor::cpg
