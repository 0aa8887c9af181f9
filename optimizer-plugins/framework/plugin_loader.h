// Loading optimizer plugins (shared libraries implementing
// include/yamor/optimizer_plugin.h) and validating their configuration
// fields against what the user set with --set.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "yamor/optimizer_plugin.h"

namespace yamor::optimizer {

/// The field every plugin honours: the evaluation budget, enforced by the
/// framework (a plugin's evaluate call returns STOPPED once it is spent).
inline constexpr const char* kMaxEvaluationsField = "max_evaluations";
/// Default evaluation budget.
inline constexpr long long kDefaultMaxEvaluations = 1000;

/// A plugin configuration field (a copy of the plugin's YamorField).
struct FieldSpec {
  std::string name;           ///< Field name.
  std::string description;    ///< One line.
  YamorFieldKind kind = YAMOR_FIELD_INTEGER;  ///< Kind.
  double min = 0.0;           ///< Lower bound (INTEGER, REAL).
  double max = 0.0;           ///< Upper bound (INTEGER, REAL).
  std::string default_value;  ///< Default, as text.
  std::vector<std::string> choices;  ///< CHOICE alternatives.
  bool framework = false;     ///< Declared by yamor-optimize, not the plugin.
};

/// A loaded plugin: the dlopen handle and the plugin's checked description.
///
/// Thread safety: immutable after Load; `api().run` may be called from
/// several threads at once (the ABI requires plugins to allow it). Move-only;
/// the library is unloaded when the last LoadedPlugin referring to it dies.
class LoadedPlugin {
 public:
  /// Loads `path` with dlopen(RTLD_NOW | RTLD_LOCAL) and checks its entry
  /// symbol, ABI version, struct size (at least YAMOR_OPTIMIZER_PLUGIN_V1_SIZE;
  /// a larger struct from a newer header is accepted and its extra fields
  /// ignored) and fields. Throws yamor::Error
  /// kFailedPrecondition naming the path with dlerror()'s text, or the ABI
  /// mismatch, or the malformed field.
  static LoadedPlugin Load(const std::string& path);

  /// The plugin's ABI struct.
  const YamorOptimizerPlugin& api() const { return *api_; }
  /// The file it was loaded from.
  const std::string& path() const { return path_; }
  /// Name, version, author, description (copied from the plugin).
  const std::string& name() const { return name_; }
  /// The plugin's version string.
  const std::string& version() const { return version_; }
  /// The plugin's author.
  const std::string& author() const { return author_; }
  /// The plugin's one-line description.
  const std::string& description() const { return description_; }
  /// The framework's fields (max_evaluations) followed by the plugin's.
  const std::vector<FieldSpec>& fields() const { return fields_; }

 private:
  std::shared_ptr<void> handle_;
  const YamorOptimizerPlugin* api_ = nullptr;
  std::string path_, name_, version_, author_, description_;
  std::vector<FieldSpec> fields_;
};

/// Checks `value` against `field` and returns it normalized (booleans as
/// "true"/"false", numbers as given). Throws kInvalidArgument naming the
/// field, the value and what is allowed.
std::string NormalizeFieldValue(const FieldSpec& field, const std::string& value);

/// Every field of `plugin` with its value: `set` over the defaults. Throws
/// kInvalidArgument for an unknown key (listing the plugin's fields) or a bad
/// value.
std::map<std::string, std::string> ResolveFieldValues(const LoadedPlugin& plugin,
                                                      const std::map<std::string, std::string>& set);

/// Where plugins are looked for, in order: each entry of $YAMOR_PLUGIN_PATH
/// (colon-separated), the build tree's plugin folder, the installed one.
std::vector<std::string> DefaultPluginDirs();

/// The file for `--plugin`: a path (contains '/' or ends in ".so") is used as
/// is; a name is looked up as NAME.so in `dirs`. Throws kNotFound listing the
/// folders searched.
std::string FindPlugin(const std::string& name_or_path, const std::vector<std::string>& dirs);

/// Every *.so in `dirs` (first occurrence of a file name wins), sorted.
std::vector<std::string> ListPluginFiles(const std::vector<std::string>& dirs);

}  // namespace yamor::optimizer
