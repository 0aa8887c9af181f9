#include "optimizer-plugins/framework/resume.h"

#include <toml++/toml.h>

#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "common/format.h"
#include "common/status.h"
#include "optimizer-plugins/framework/session.h"

namespace yamor::optimizer {
namespace {

// The fixed columns after the candidate's values (Session::Record).
constexpr const char* kTrailingColumns[] = {"velocity", "distance", "diverged", "host",
                                            "wall_seconds"};
constexpr std::size_t kTrailing = std::size(kTrailingColumns);

bool ParseNumber(const std::string& text, double& value) {
  if (text.empty()) return false;
  const char* begin = text.data();
  const char* end = text.data() + text.size();
  const auto [stop, error] = std::from_chars(begin, end, value);
  return error == std::errc() && stop == end && std::isfinite(value);
}

bool ParseIndex(const std::string& text, long long& value) {
  if (text.empty()) return false;
  const auto [stop, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  return error == std::errc() && stop == text.data() + text.size();
}

// Why `line` is no row `expected` of a file with `columns` values, or "".
std::string ParseRow(std::string_view line, std::size_t columns, long long expected,
                     RecordedEvaluation& row) {
  std::vector<std::string> fields;
  if (!SplitCsvLine(line, fields)) return "an unterminated quoted field";
  if (fields.size() != 1 + columns + kTrailing) {
    return std::to_string(fields.size()) + " fields, expected " +
           std::to_string(1 + columns + kTrailing);
  }
  if (!ParseIndex(fields[0], row.index) || row.index != expected) {
    return "index '" + fields[0] + "', expected " + std::to_string(expected);
  }
  row.values.resize(columns);
  for (std::size_t i = 0; i < columns; ++i) {
    if (!ParseNumber(fields[1 + i], row.values[i])) {
      return "value '" + fields[1 + i] + "' is not a finite number";
    }
  }
  const std::size_t t = 1 + columns;
  Evaluation& e = row.evaluation;
  if (!ParseNumber(fields[t], e.velocity)) return "velocity '" + fields[t] + "' is not a number";
  if (!ParseNumber(fields[t + 1], e.distance)) {
    return "distance '" + fields[t + 1] + "' is not a number";
  }
  if (fields[t + 2] != "0" && fields[t + 2] != "1") {
    return "diverged '" + fields[t + 2] + "' is not 0 or 1";
  }
  e.diverged = fields[t + 2] == "1";
  e.host = fields[t + 3];
  if (!ParseNumber(fields[t + 4], e.wall_seconds)) {
    return "wall_seconds '" + fields[t + 4] + "' is not a number";
  }
  return "";
}

std::string ReadAll(const std::string& path, const char* what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(StatusCode::kNotFound, std::string("cannot read ") + what + " " + path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace

RunIdentity EvaluationIdentity(const OptimizationConfig& config,
                               const EvaluationSettings& settings) {
  std::string canonical = config.RobotXml();
  for (const OptimizeRule& rule : config.optimized()) {
    canonical += "optimize " + rule.param + " " + FormatDouble(rule.min) + " " +
                 FormatDouble(rule.max) + "\n";
  }
  for (const ConstrainRule& rule : config.constrained()) {
    canonical += "constrain " + rule.param + " " + rule.expr + "\n";
  }
  std::string evaluation = "world=" + settings.world;
  evaluation += " morphology=" + (settings.morphology_xml.empty()
                                      ? std::string("none")
                                      : Fingerprint(settings.morphology_xml));
  evaluation += " warmup=" + FormatDouble(settings.warmup) +
                " duration=" + FormatDouble(settings.duration) +
                " seed=" + std::to_string(settings.seed) +
                " time_step=" + FormatDouble(settings.time_step);
  // The robot's condition (model-mode evaluations) changes every velocity too.
  for (const auto& [id, defect] : settings.motor_defects) {
    evaluation += " motor_defect." + std::to_string(id) + "=" +
                  std::to_string(static_cast<int>(defect));
  }
  for (int id : settings.module_defects) evaluation += " module_defect." + std::to_string(id);
  const auto optional = [&](const char* name, const std::optional<double>& value) {
    if (value) evaluation += std::string(" ") + name + "=" + FormatDouble(*value);
  };
  optional("ground_friction", settings.ground_friction);
  optional("ground_slope", settings.ground_slope);
  optional("ground_slope_direction", settings.ground_slope_direction);
  if (settings.upside_down) evaluation += " upside_down";
  return {{"configuration", Fingerprint(canonical)}, {"evaluation", evaluation}};
}

std::string Fingerprint(std::string_view bytes) {
  std::uint64_t hash = 14695981039346656037ull;
  for (unsigned char c : bytes) {
    hash ^= c;
    hash *= 1099511628211ull;
  }
  char text[32];
  std::snprintf(text, sizeof(text), "fnv1a64:%016llx", static_cast<unsigned long long>(hash));
  return text;
}

std::string FileFingerprint(const std::string& path) {
  return Fingerprint(ReadAll(path, "file"));
}

void WriteRunFile(const std::string& path, const RunIdentity& identity,
                  const std::map<std::string, std::string>& info) {
  toml::table identity_table;
  for (const auto& [key, value] : identity) identity_table.insert(key, value);
  toml::table info_table;
  for (const auto& [key, value] : info) info_table.insert(key, value);
  toml::table root;
  root.insert("identity", std::move(identity_table));
  root.insert("info", std::move(info_table));
  std::ostringstream text;
  text << "# What this run was started with; yamor-optimize --resume compares [identity].\n"
       << root << "\n";
  WriteFileAtomically(path, text.str());
}

RunIdentity ReadRunFile(const std::string& path, std::map<std::string, std::string>* info) {
  const std::string text = ReadAll(path, "run file");
  toml::table root;
  try {
    root = toml::parse(text, path);
  } catch (const toml::parse_error& e) {
    throw Error(StatusCode::kDataLoss, path + ":" + std::to_string(e.source().begin.line) + ": " +
                                           std::string(e.description()));
  }
  const auto read = [&](const char* name, std::map<std::string, std::string>& out) {
    const toml::table* table = root[name].as_table();
    if (table == nullptr) {
      throw Error(StatusCode::kDataLoss, path + ": no [" + std::string(name) + "] table");
    }
    for (const auto& [key, node] : *table) {
      const auto value = node.value<std::string>();
      if (!value) {
        throw Error(StatusCode::kDataLoss, path + ": " + std::string(name) + "." +
                                               std::string(key.str()) + " is not a string");
      }
      out[std::string(key.str())] = *value;
    }
  };
  RunIdentity identity;
  read("identity", identity);
  if (info != nullptr) read("info", *info);
  return identity;
}

std::string IdentityDifferences(const RunIdentity& recorded, const RunIdentity& current) {
  std::string out;
  const auto add = [&](const std::string& text) { out += (out.empty() ? "" : "; ") + text; };
  for (const auto& [key, value] : recorded) {
    const auto it = current.find(key);
    if (it == current.end()) {
      add(key + ": recorded '" + value + "', now not set");
    } else if (it->second != value) {
      add(key + ": recorded '" + value + "', now '" + it->second + "'");
    }
  }
  for (const auto& [key, value] : current) {
    if (!recorded.contains(key)) add(key + ": not recorded, now '" + value + "'");
  }
  return out;
}

bool SplitCsvLine(std::string_view line, std::vector<std::string>& fields) {
  fields.clear();
  std::string field;
  bool quoted = false;
  bool at_start = true;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"') {
        if (i + 1 < line.size() && line[i + 1] == '"') {
          field += '"';
          ++i;
        } else {
          quoted = false;
        }
      } else {
        field += c;
      }
    } else if (c == '"' && at_start) {
      quoted = true;
      at_start = false;
    } else if (c == ',') {
      fields.push_back(std::move(field));
      field.clear();
      at_start = true;
    } else {
      field += c;
      at_start = false;
    }
  }
  if (quoted) return false;
  fields.push_back(std::move(field));
  return true;
}

EvaluationRecordFile ParseEvaluationRecord(std::string_view text, const std::string& source) {
  EvaluationRecordFile record;
  // Complete lines end in '\n'; what follows the last one is torn.
  std::vector<std::pair<std::string_view, std::size_t>> lines;  // line, offset after it
  std::size_t start = 0;
  while (start < text.size()) {
    const std::size_t end = text.find('\n', start);
    if (end == std::string_view::npos) {
      record.torn = true;
      record.torn_reason = "line " + std::to_string(lines.size() + 1) +
                           " has no end of line (" + std::to_string(text.size() - start) +
                           " bytes)";
      break;
    }
    lines.emplace_back(text.substr(start, end - start), end + 1);
    start = end + 1;
  }
  if (lines.empty()) return record;

  const auto drop_last = [&](std::size_t line_number, const std::string& why) {
    record.torn = true;
    record.torn_reason = "line " + std::to_string(line_number) + ": " + why;
  };
  std::vector<std::string> header;
  if (!SplitCsvLine(lines[0].first, header) || header.size() < 1 + kTrailing ||
      header[0] != "index" ||
      !std::equal(header.end() - kTrailing, header.end(), std::begin(kTrailingColumns))) {
    if (lines.size() == 1) {
      drop_last(1, "not a complete header");
      return record;
    }
    throw Error(StatusCode::kDataLoss,
                source + ":1: not an evaluations.csv header (index, the candidate's "
                         "parameters, velocity, distance, diverged, host, wall_seconds)");
  }
  record.columns.assign(header.begin() + 1, header.end() - kTrailing);
  record.valid_bytes = lines[0].second;
  for (std::size_t i = 1; i < lines.size(); ++i) {
    RecordedEvaluation row;
    const std::string why = ParseRow(lines[i].first, record.columns.size(),
                                     static_cast<long long>(record.rows.size()), row);
    if (!why.empty()) {
      if (i + 1 == lines.size() && !record.torn) {
        drop_last(i + 1, why);
        break;
      }
      throw Error(StatusCode::kDataLoss, source + ":" + std::to_string(i + 1) + ": " + why +
                                             " (not the last line: the record is damaged, "
                                             "not torn)");
    }
    record.rows.push_back(std::move(row));
    record.valid_bytes = lines[i].second;
  }
  return record;
}

EvaluationRecordFile ReadEvaluationRecord(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return {};
  return ParseEvaluationRecord(ReadAll(path, "evaluation record"), path);
}

}  // namespace yamor::optimizer
