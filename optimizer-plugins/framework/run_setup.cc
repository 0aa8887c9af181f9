#include "optimizer-plugins/framework/run_setup.h"

#include <algorithm>
#include <fstream>
#include <optional>
#include <set>
#include <sstream>

#include <toml++/toml.h>

#include "common/format.h"
#include "common/status.h"
#include "cpg/config_xml.h"

namespace yamor::optimizer {
namespace {

std::string Where(const std::string& path, const toml::node& node) {
  const auto& source = node.source();
  return path + ":" + std::to_string(source.begin.line);
}

bool ValidInstanceName(const std::string& name) {
  return !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.';
  }) && name != "." && name != "..";
}

std::string ValueText(const std::string& path, const std::string& key, const toml::node& node) {
  if (auto s = node.value<std::string>()) return *s;
  if (node.is_integer()) return std::to_string(*node.value<int64_t>());
  if (node.is_floating_point()) {
    return FormatDouble(*node.value<double>());
  }
  if (node.is_boolean()) return *node.value<bool>() ? "true" : "false";
  throw Error(StatusCode::kInvalidArgument,
              Where(path, node) + ": set." + key + " must be a string, number or boolean");
}

}  // namespace

std::map<std::string, std::string> ParseFieldSettings(const std::vector<std::string>& settings) {
  std::map<std::string, std::string> set;
  for (const std::string& kv : settings) {
    const auto eq = kv.find('=');
    if (eq == std::string::npos || eq == 0) {
      throw Error(StatusCode::kInvalidArgument, "--set " + kv + ": expected KEY=VALUE");
    }
    set[kv.substr(0, eq)] = kv.substr(eq + 1);
  }
  return set;
}

Problem MakeProblem(const OptimizationConfig& config) {
  Problem problem;
  const std::vector<double> start = config.StartValues();
  for (std::size_t i = 0; i < config.optimized().size(); ++i) {
    const OptimizeRule& rule = config.optimized()[i];
    problem.parameters.push_back({rule.param, rule.min, rule.max, start[i]});
  }
  problem.to_candidate = [&config](const std::vector<double>& x) {
    return Candidate{config.Resolve(x)};
  };
  problem.config_xml = [&config](const std::vector<double>& x) {
    return cpg::WriteConfigXml(config.Apply(x));
  };
  problem.source = config.source();
  return problem;
}

std::vector<BatchInstance> LoadBatchFile(const std::string& path, std::uint64_t default_seed) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(StatusCode::kNotFound, "cannot read batch file " + path);
  std::ostringstream text;
  text << in.rdbuf();
  return ParseBatchToml(text.str(), path, default_seed);
}

std::vector<BatchInstance> ParseBatchToml(std::string_view text, const std::string& path,
                                          std::uint64_t default_seed) {
  toml::table root;
  try {
    root = toml::parse(text, path);
  } catch (const toml::parse_error& e) {
    throw Error(StatusCode::kInvalidArgument,
                path + ":" + std::to_string(e.source().begin.line) + ": " + std::string(e.description()));
  }
  for (const auto& [key, node] : root) {
    if (key.str() != "instance") {
      throw Error(StatusCode::kInvalidArgument,
                  Where(path, node) + ": unknown key '" + std::string(key.str()) +
                      "' (a batch file holds [[instance]] tables)");
    }
  }
  const toml::array* instances = root["instance"].as_array();
  if (instances == nullptr || instances->empty()) {
    throw Error(StatusCode::kInvalidArgument, path + ": no [[instance]] in the batch file");
  }
  std::vector<BatchInstance> out;
  std::set<std::string> names;
  for (std::size_t i = 0; i < instances->size(); ++i) {
    const toml::node& node = *instances->get(i);
    const toml::table* table = node.as_table();
    if (table == nullptr) {
      throw Error(StatusCode::kInvalidArgument, Where(path, node) + ": instance must be a table");
    }
    BatchInstance instance;
    instance.seed = default_seed + i;
    for (const auto& [key, value] : *table) {
      const std::string k(key.str());
      if (k == "name") {
        auto s = value.value<std::string>();
        if (!s || !ValidInstanceName(*s)) {
          throw Error(StatusCode::kInvalidArgument,
                      Where(path, value) + ": name must be a string of letters, digits, '_', '-', '.'");
        }
        instance.name = *s;
      } else if (k == "seed") {
        // Integers only: toml++ (3.x) converting a float beyond int64's range
        // is undefined behaviour (found by batch_fuzzer under UBSan).
        const std::optional<int64_t> v =
            value.is_integer() ? value.value<int64_t>() : std::nullopt;
        if (!v || *v < 0) {
          throw Error(StatusCode::kInvalidArgument, Where(path, value) + ": seed must be an integer >= 0");
        }
        instance.seed = static_cast<std::uint64_t>(*v);
      } else if (k == "set") {
        const toml::table* set = value.as_table();
        if (set == nullptr) {
          throw Error(StatusCode::kInvalidArgument, Where(path, value) + ": set must be a table");
        }
        for (const auto& [field, field_value] : *set) {
          if (field.str().empty()) {
            // `"" = 1` is valid TOML but names no field (batch_fuzzer's check).
            throw Error(StatusCode::kInvalidArgument,
                        Where(path, field_value) + ": set has an empty field name");
          }
          instance.set[std::string(field.str())] = ValueText(path, std::string(field.str()), field_value);
        }
      } else {
        throw Error(StatusCode::kInvalidArgument,
                    Where(path, value) + ": unknown instance key '" + k + "' (name, seed, set)");
      }
    }
    if (instance.name.empty()) instance.name = "instance-" + std::to_string(i + 1);
    if (!names.insert(instance.name).second) {
      throw Error(StatusCode::kInvalidArgument,
                  Where(path, node) + ": instance name '" + instance.name + "' is used twice");
    }
    out.push_back(std::move(instance));
  }
  return out;
}

}  // namespace yamor::optimizer
