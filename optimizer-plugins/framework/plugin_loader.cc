#include "optimizer-plugins/framework/plugin_loader.h"

#include <dlfcn.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <set>
#include <sstream>

#include "common/format.h"
#include "common/status.h"

namespace yamor::optimizer {
namespace {

namespace fs = std::filesystem;

std::string Text(const char* s) { return s == nullptr ? std::string() : std::string(s); }

[[noreturn]] void Fail(const std::string& path, const std::string& why) {
  throw Error(StatusCode::kFailedPrecondition, "optimizer plugin " + path + ": " + why);
}

bool ValidName(const std::string& name) {
  if (name.empty()) return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
  });
}

std::vector<std::string> SplitChoices(const std::string& choices) {
  std::vector<std::string> out;
  std::string item;
  std::istringstream in(choices);
  while (std::getline(in, item, '|')) out.push_back(item);
  return out;
}

bool ParseDouble(const std::string& text, double& value) {
  const char* begin = text.data();
  const char* end = begin + text.size();
  auto [ptr, ec] = std::from_chars(begin, end, value);
  return ec == std::errc() && ptr == end && std::isfinite(value);
}

bool ParseInteger(const std::string& text, long long& value) {
  const char* begin = text.data();
  const char* end = begin + text.size();
  auto [ptr, ec] = std::from_chars(begin, end, value);
  return ec == std::errc() && ptr == end;
}

FieldSpec MaxEvaluationsField() {
  FieldSpec f;
  f.name = kMaxEvaluationsField;
  f.description = "evaluation budget: the run stops after this many evaluations";
  f.kind = YAMOR_FIELD_INTEGER;
  f.min = 1;
  f.max = 1e9;
  f.default_value = std::to_string(kDefaultMaxEvaluations);
  f.framework = true;
  return f;
}

}  // namespace

std::string NormalizeFieldValue(const FieldSpec& field, const std::string& value) {
  auto bad = [&](const std::string& allowed) -> Error {
    return Error(StatusCode::kInvalidArgument,
                 "field '" + field.name + "': '" + value + "' is not " + allowed);
  };
  switch (field.kind) {
    case YAMOR_FIELD_INTEGER: {
      long long v = 0;
      if (!ParseInteger(value, v)) throw bad("an integer");
      if (v < field.min || v > field.max) {
        throw bad("in [" + FormatDouble(field.min) + ", " + FormatDouble(field.max) + "]");
      }
      return std::to_string(v);
    }
    case YAMOR_FIELD_REAL: {
      double v = 0.0;
      if (!ParseDouble(value, v)) throw bad("a finite number");
      if (v < field.min || v > field.max) {
        throw bad("in [" + FormatDouble(field.min) + ", " + FormatDouble(field.max) + "]");
      }
      return value;
    }
    case YAMOR_FIELD_BOOLEAN: {
      std::string v = value;
      std::transform(v.begin(), v.end(), v.begin(), [](unsigned char c) { return std::tolower(c); });
      if (v == "true" || v == "1" || v == "yes" || v == "on") return "true";
      if (v == "false" || v == "0" || v == "no" || v == "off") return "false";
      throw bad("a boolean (true/false, 1/0, yes/no, on/off)");
    }
    case YAMOR_FIELD_FILE:
      if (value.empty() && field.min > 0) throw bad("a file name (required)");
      return value;
    case YAMOR_FIELD_CHOICE: {
      if (std::find(field.choices.begin(), field.choices.end(), value) != field.choices.end()) {
        return value;
      }
      std::string all;
      for (const auto& c : field.choices) all += (all.empty() ? "" : "|") + c;
      throw bad("one of " + all);
    }
    case YAMOR_FIELD_TEXT:
      return value;
  }
  throw bad("valid (unknown field kind)");
}

LoadedPlugin LoadedPlugin::Load(const std::string& path) {
  dlerror();
  void* raw = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (raw == nullptr) Fail(path, "cannot be loaded: " + Text(dlerror()));
  LoadedPlugin plugin;
  plugin.handle_ = std::shared_ptr<void>(raw, [](void* h) { dlclose(h); });
  plugin.path_ = path;

  dlerror();
  void* symbol = dlsym(raw, YAMOR_OPTIMIZER_ENTRY_SYMBOL);
  if (symbol == nullptr) {
    Fail(path, std::string("has no entry symbol '") + YAMOR_OPTIMIZER_ENTRY_SYMBOL + "': " +
                   Text(dlerror()));
  }
  auto entry = reinterpret_cast<YamorOptimizerEntry>(symbol);
  const YamorOptimizerPlugin* api = entry();
  if (api == nullptr) Fail(path, "entry symbol returned no plugin description");
  if (api->abi_version != YAMOR_OPTIMIZER_ABI_VERSION) {
    Fail(path, "was built for plugin ABI version " + std::to_string(api->abi_version) +
                   ", this yamor-optimize speaks version " +
                   std::to_string(YAMOR_OPTIMIZER_ABI_VERSION) + " (rebuild the plugin)");
  }
  // Structs only grow at their end: at least version 1's fields, and only
  // the fields this loader knows are read (a newer plugin's extra ones are not).
  if (api->struct_size < YAMOR_OPTIMIZER_PLUGIN_V1_SIZE) {
    Fail(path, "declares a plugin struct of " + std::to_string(api->struct_size) +
                   " bytes, smaller than ABI version 1's " +
                   std::to_string(YAMOR_OPTIMIZER_PLUGIN_V1_SIZE) +
                   " (built against a different or damaged header)");
  }
  plugin.name_ = Text(api->name);
  if (!ValidName(plugin.name_)) Fail(path, "has an invalid name '" + plugin.name_ + "'");
  if (api->run == nullptr) Fail(path, "has no run callback");
  if (api->field_count > 0 && api->fields == nullptr) Fail(path, "declares fields but lists none");
  plugin.version_ = Text(api->version);
  plugin.author_ = Text(api->author);
  plugin.description_ = Text(api->description);
  plugin.api_ = api;

  plugin.fields_.push_back(MaxEvaluationsField());
  std::set<std::string> names = {kMaxEvaluationsField};
  for (std::size_t i = 0; i < api->field_count; ++i) {
    const YamorField& f = api->fields[i];
    FieldSpec spec;
    spec.name = Text(f.name);
    spec.description = Text(f.description);
    spec.min = f.min;
    spec.max = f.max;
    spec.default_value = Text(f.default_value);
    const std::string where = "field " + std::to_string(i) + " ('" + spec.name + "')";
    if (!ValidName(spec.name) || spec.name.find('-') != std::string::npos) {
      Fail(path, where + " has an invalid name");
    }
    if (!names.insert(spec.name).second) {
      // A plugin may re-declare max_evaluations only to change its default.
      if (spec.name != kMaxEvaluationsField || f.kind != YAMOR_FIELD_INTEGER) {
        Fail(path, where + " is declared twice");
      }
    }
    if (f.kind < YAMOR_FIELD_INTEGER || f.kind > YAMOR_FIELD_TEXT) {
      Fail(path, where + " has unknown kind " + std::to_string(f.kind));
    }
    spec.kind = static_cast<YamorFieldKind>(f.kind);
    if ((spec.kind == YAMOR_FIELD_INTEGER || spec.kind == YAMOR_FIELD_REAL) &&
        !(std::isfinite(spec.min) && std::isfinite(spec.max) && spec.min <= spec.max)) {
      Fail(path, where + " has invalid bounds [" + FormatDouble(spec.min) + ", " + FormatDouble(spec.max) + "]");
    }
    if (spec.kind == YAMOR_FIELD_CHOICE) {
      spec.choices = SplitChoices(Text(f.choices));
      if (spec.choices.empty()) Fail(path, where + " is a choice without choices");
    }
    try {
      spec.default_value = NormalizeFieldValue(spec, spec.default_value);
    } catch (const Error& e) {
      Fail(path, where + " has an invalid default: " + e.what());
    }
    if (spec.name == kMaxEvaluationsField) {
      plugin.fields_.front().default_value = spec.default_value;
      continue;
    }
    plugin.fields_.push_back(std::move(spec));
  }
  return plugin;
}

std::map<std::string, std::string> ResolveFieldValues(const LoadedPlugin& plugin,
                                                      const std::map<std::string, std::string>& set) {
  std::map<std::string, std::string> values;
  for (const FieldSpec& f : plugin.fields()) values[f.name] = f.default_value;
  for (const auto& [key, value] : set) {
    auto it = std::find_if(plugin.fields().begin(), plugin.fields().end(),
                           [&](const FieldSpec& f) { return f.name == key; });
    if (it == plugin.fields().end()) {
      std::string known;
      for (const FieldSpec& f : plugin.fields()) known += (known.empty() ? "" : ", ") + f.name;
      throw Error(StatusCode::kInvalidArgument, "plugin '" + plugin.name() +
                                                    "' has no field '" + key + "' (fields: " +
                                                    known + ")");
    }
    values[key] = NormalizeFieldValue(*it, value);
  }
  return values;
}

std::vector<std::string> DefaultPluginDirs() {
  std::vector<std::string> dirs;
  if (const char* env = std::getenv("YAMOR_PLUGIN_PATH"); env != nullptr) {
    std::istringstream in(env);
    std::string dir;
    while (std::getline(in, dir, ':')) {
      if (!dir.empty()) dirs.push_back(dir);
    }
  }
  dirs.push_back(YAMOR_PLUGIN_BUILD_DIR);
  dirs.push_back(YAMOR_PLUGIN_INSTALL_DIR);
  return dirs;
}

std::string FindPlugin(const std::string& name_or_path, const std::vector<std::string>& dirs) {
  const bool is_path = name_or_path.find('/') != std::string::npos ||
                       (name_or_path.size() > 3 &&
                        name_or_path.compare(name_or_path.size() - 3, 3, ".so") == 0);
  if (is_path) {
    if (!fs::exists(name_or_path)) {
      throw Error(StatusCode::kNotFound, "optimizer plugin file " + name_or_path + " does not exist");
    }
    return name_or_path;
  }
  std::string searched;
  for (const std::string& dir : dirs) {
    const fs::path candidate = fs::path(dir) / (name_or_path + ".so");
    std::error_code ec;
    if (fs::is_regular_file(candidate, ec)) return candidate.string();
    searched += (searched.empty() ? "" : ", ") + dir;
  }
  throw Error(StatusCode::kNotFound, "no optimizer plugin named '" + name_or_path +
                                         "' (looked for " + name_or_path + ".so in " + searched +
                                         "; --list-plugins shows what is there)");
}

std::vector<std::string> ListPluginFiles(const std::vector<std::string>& dirs) {
  std::map<std::string, std::string> by_name;
  for (const std::string& dir : dirs) {
    std::error_code ec;
    for (const auto& entry : fs::directory_iterator(dir, ec)) {
      if (entry.path().extension() != ".so") continue;
      by_name.emplace(entry.path().filename().string(), entry.path().string());
    }
  }
  std::vector<std::string> out;
  for (const auto& [name, path] : by_name) out.push_back(path);
  return out;
}

}  // namespace yamor::optimizer
