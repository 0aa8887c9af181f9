#include "cpg/parameters.h"

#include <charconv>
#include <map>
#include <sstream>

#include "common/format.h"
#include "common/status.h"

namespace yamor::cpg {
namespace {

cpg::ModuleParams& Module(cpg::RobotConfig& config, int id) {
  cpg::ModuleParams* m = config.FindModule(id);
  if (m == nullptr) {
    throw Error(StatusCode::kNotFound,
                "module " + std::to_string(id) + " is not in the configuration");
  }
  return *m;
}

void CheckFinite(double value, const std::string& what) {
  if (!std::isfinite(value)) {
    throw Error(StatusCode::kInvalidArgument, what + " is not finite: " + FormatRounded(value));
  }
}

void CheckRange(double value, double lo, double hi, const std::string& what) {
  if (!(value >= lo && value <= hi)) {
    throw Error(StatusCode::kOutOfRange,
                what + " = " + FormatRounded(value) + " is outside [" + FormatRounded(lo) + ", " + FormatRounded(hi) + "]");
  }
}

std::string ModuleWhat(ModuleField field, int id) {
  return std::string(FieldName(field)) + " of module " + std::to_string(id);
}

std::string CouplingWhat(CouplingField field, int from, int to) {
  return std::string(FieldName(field)) + " of coupling " + std::to_string(from) + " -> " +
         std::to_string(to);
}

void CheckCouplingValue(CouplingField field, double value, const std::string& what) {
  CheckFinite(value, what);
  if (field == CouplingField::kPhase) {
    CheckRange(value, -kMaxCouplingPhase, kMaxCouplingPhase, what);
  } else {
    CheckRange(value, -kMaxCouplingWeight, kMaxCouplingWeight, what);
  }
}

void CheckOrder(const cpg::ModuleParams& m) {
  if (!(m.min_angle < m.max_angle)) {
    throw Error(StatusCode::kOutOfRange,
                "module " + std::to_string(m.id) + ": min angle " + FormatRounded(m.min_angle) +
                    " must be below max angle " + FormatRounded(m.max_angle));
  }
}

bool ParseId(std::string_view text, int& id) {
  auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), id);
  return !text.empty() && ec == std::errc() && ptr == text.data() + text.size() && id >= 0 &&
         id <= cpg::kMaxModuleId;
}

}  // namespace

std::string_view FieldName(ModuleField field) {
  switch (field) {
    case ModuleField::kAmplitude: return "amplitude";
    case ModuleField::kOffset: return "offset";
    case ModuleField::kSpeed: return "speed";
    case ModuleField::kMinAngle: return "minangle";
    case ModuleField::kMaxAngle: return "maxangle";
  }
  return "?";
}

std::string_view FieldName(CouplingField field) {
  return field == CouplingField::kPhase ? "phase" : "weight";
}

double GetModuleField(const cpg::RobotConfig& config, int id, ModuleField field) {
  const cpg::ModuleParams* found = config.FindModule(id);
  if (found == nullptr) {
    throw Error(StatusCode::kNotFound,
                "module " + std::to_string(id) + " is not in the configuration");
  }
  const cpg::ModuleParams& m = *found;
  switch (field) {
    case ModuleField::kAmplitude: return m.amplitude;
    case ModuleField::kOffset: return m.offset;
    case ModuleField::kSpeed: return m.speed;
    case ModuleField::kMinAngle: return m.min_angle;
    case ModuleField::kMaxAngle: return m.max_angle;
  }
  return 0.0;
}

void SetModuleField(cpg::RobotConfig& config, int id, ModuleField field, double value,
                    bool check_order) {
  cpg::ModuleParams& m = Module(config, id);
  const std::string what = ModuleWhat(field, id);
  CheckFinite(value, what);
  cpg::ModuleParams next = m;
  switch (field) {
    case ModuleField::kAmplitude:
      CheckRange(value, 0.0, kMaxAmplitude, what);
      next.amplitude = value;
      break;
    case ModuleField::kOffset:
      CheckRange(value, -kMaxAmplitude, kMaxAmplitude, what);
      next.offset = value;
      break;
    case ModuleField::kSpeed:
      CheckRange(value, 0.0, kMaxSpeedHz, what);
      next.speed = value;
      break;
    case ModuleField::kMinAngle:
      CheckRange(value, -kMaxLimitAngle, kMaxLimitAngle, what);
      next.min_angle = value;
      break;
    case ModuleField::kMaxAngle:
      CheckRange(value, -kMaxLimitAngle, kMaxLimitAngle, what);
      next.max_angle = value;
      break;
  }
  if (check_order) CheckOrder(next);
  m = next;
}

double GetCouplingField(const cpg::RobotConfig& config, int from, int to, CouplingField field) {
  const cpg::Coupling* c = config.FindCoupling(from, to);
  if (c == nullptr) {
    throw Error(StatusCode::kNotFound, "no coupling " + std::to_string(from) + " -> " +
                                           std::to_string(to) + " in the configuration");
  }
  return field == CouplingField::kPhase ? c->phase : c->weight;
}

void SetCouplingField(cpg::RobotConfig& config, int from, int to, CouplingField field,
                      double value) {
  cpg::Coupling* c = config.FindCoupling(from, to);
  if (c == nullptr) {
    throw Error(StatusCode::kNotFound, "no coupling " + std::to_string(from) + " -> " +
                                           std::to_string(to) + " in the configuration");
  }
  CheckCouplingValue(field, value, CouplingWhat(field, from, to));
  (field == CouplingField::kPhase ? c->phase : c->weight) = value;
}

void AddCoupling(cpg::RobotConfig& config, int from, int to, double phase, double weight) {
  Module(config, from);
  Module(config, to);
  if (from == to) {
    throw Error(StatusCode::kInvalidArgument,
                "module " + std::to_string(from) + " cannot be coupled to itself");
  }
  CheckCouplingValue(CouplingField::kPhase, phase, CouplingWhat(CouplingField::kPhase, from, to));
  CheckCouplingValue(CouplingField::kWeight, weight,
                     CouplingWhat(CouplingField::kWeight, from, to));
  if (cpg::Coupling* c = config.FindCoupling(from, to)) {
    c->phase = phase;
    c->weight = weight;
    return;
  }
  // Keep the canonical grouping: after the last coupling of `from`.
  auto pos = config.couplings.end();
  for (auto it = config.couplings.begin(); it != config.couplings.end(); ++it) {
    if (it->from == from) pos = it + 1;
  }
  config.couplings.insert(pos, cpg::Coupling{.from = from, .to = to, .phase = phase,
                                             .weight = weight});
}

ParameterName ParseParameterName(std::string_view name) {
  static constexpr std::pair<std::string_view, ModuleField> kModuleFields[] = {
      {"amplitude", ModuleField::kAmplitude}, {"offset", ModuleField::kOffset},
      {"speed", ModuleField::kSpeed},         {"minangle", ModuleField::kMinAngle},
      {"maxangle", ModuleField::kMaxAngle}};
  const std::size_t dot = name.find('.');
  const std::string_view kind = name.substr(0, dot);
  const std::string_view ids = dot == std::string_view::npos ? std::string_view() : name.substr(dot + 1);
  for (const auto& [field_name, field] : kModuleFields) {
    if (kind != field_name) continue;
    ParameterName parsed{.module_field = field};
    if (!ParseId(ids, parsed.id)) {
      throw Error(StatusCode::kInvalidArgument,
                  "expected " + std::string(field_name) + ".<module id 0..254>");
    }
    return parsed;
  }
  if (kind == "phase" || kind == "weight") {
    ParameterName parsed{.coupling = true,
                         .coupling_field = kind == "phase" ? CouplingField::kPhase
                                                           : CouplingField::kWeight};
    const std::size_t dot2 = ids.find('.');
    if (dot2 == std::string_view::npos || !ParseId(ids.substr(0, dot2), parsed.from) ||
        !ParseId(ids.substr(dot2 + 1), parsed.to)) {
      throw Error(StatusCode::kInvalidArgument,
                  "expected " + std::string(kind) + ".<from id>.<to id>");
    }
    return parsed;
  }
  throw Error(StatusCode::kInvalidArgument,
              "unknown parameter; expected amplitude.<id>, offset.<id>, speed.<id>, "
              "minangle.<id>, maxangle.<id>, phase.<from>.<to> or weight.<from>.<to>");
}

void ApplyParameters(cpg::RobotConfig& config,
                     const std::vector<std::pair<std::string, double>>& parameters) {
  std::map<int, std::string> limit_parameter;  // module -> last limit parameter applied
  for (const auto& [name, value] : parameters) {
    const std::string prefix = "parameter '" + name + "': ";
    try {
      const ParameterName parsed = ParseParameterName(name);
      if (parsed.coupling) {
        SetCouplingField(config, parsed.from, parsed.to, parsed.coupling_field, value);
      } else {
        SetModuleField(config, parsed.id, parsed.module_field, value, /*check_order=*/false);
        if (parsed.module_field == ModuleField::kMinAngle ||
            parsed.module_field == ModuleField::kMaxAngle) {
          limit_parameter[parsed.id] = name;
        }
      }
    } catch (const Error& e) {
      throw Error(e.code(), prefix + e.what());
    }
  }
  for (const cpg::ModuleParams& m : config.modules) {
    try {
      CheckOrder(m);
    } catch (const Error& e) {
      auto it = limit_parameter.find(m.id);
      if (it == limit_parameter.end()) throw;
      throw Error(e.code(), "parameter '" + it->second + "': " + e.what());
    }
  }
}

}  // namespace yamor::cpg
