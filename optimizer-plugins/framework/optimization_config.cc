#include "optimizer-plugins/framework/optimization_config.h"

#include <muParser.h>
#include <tinyxml2.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <mutex>
#include <optional>
#include <sstream>
#include <string_view>
#include <system_error>

#include "common/format.h"
#include "common/log.h"
#include "common/status.h"
#include "cpg/config_xml.h"
#include "cpg/parameters.h"

namespace yamor::optimizer {
namespace {

constexpr double kTwoPi = 2.0 * M_PI;

// muParser's default name characters plus '.', so that the parameter names
// of DESIGN.md ("phase.0.1") are function names. Numbers like "2.5" still
// read as values: they are no defined name, and muParser then tries values.
constexpr char kNameChars[] =
    "0123456789_.abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ";

[[noreturn]] void Fail(const std::string& message) {
  throw Error(StatusCode::kInvalidArgument, message);
}

std::string_view Trim(std::string_view text) {
  constexpr std::string_view kSpace = " \t\r\n";
  const auto first = text.find_first_not_of(kSpace);
  if (first == std::string_view::npos) return {};
  return text.substr(first, text.find_last_not_of(kSpace) - first + 1);
}

bool IsNameChar(char c) {
  return c != '\0' && std::strchr(kNameChars, c) != nullptr;
}

// What the module firmware accepts for a parameter (cpg/parameters.h), so a
// bound or constrained value that passes here is never refused downstream.
struct FieldRange {
  double lo = 0;
  double hi = 0;
};

FieldRange RangeOf(std::string_view kind) {
  if (kind == "amplitude") return {0.0, cpg::kMaxAmplitude};
  if (kind == "offset") return {-cpg::kMaxAmplitude, cpg::kMaxAmplitude};
  if (kind == "speed") return {0.0, cpg::kMaxSpeedHz};
  if (kind == "minangle" || kind == "maxangle") {
    return {-cpg::kMaxLimitAngle, cpg::kMaxLimitAngle};
  }
  if (kind == "phase") return {-cpg::kMaxCouplingPhase, cpg::kMaxCouplingPhase};
  return {-cpg::kMaxCouplingWeight, cpg::kMaxCouplingWeight};  // weight
}

std::string_view KindOf(std::string_view name) { return name.substr(0, name.find('.')); }

// muParser callbacks. A parameter's user data points at its slot in the
// parser set's value array.
double ReadSlot(void* slot) { return *static_cast<const double*>(slot); }
double M2PiCallback(double x) { return M2Pi(x); }

// Parses "kind.id" / "kind.from.to" strictly (canonical decimal ids), so a
// name means one slot and equal names are equal strings.
bool IsCanonicalId(std::string_view text) {
  if (text.empty() || text.size() > 3) return false;
  if (!std::all_of(text.begin(), text.end(), [](char c) { return c >= '0' && c <= '9'; })) {
    return false;
  }
  return text == "0" || text[0] != '0';
}

// Why `name` is no parameter of `robot`, for the error message.
std::string WhyUnknown(const std::string& name, const cpg::RobotConfig& robot) {
  const std::string expected =
      "expected amplitude.<id>, offset.<id>, speed.<id>, minangle.<id>, maxangle.<id>, "
      "phase.<from>.<to> or weight.<from>.<to> with real module ids";
  const std::string_view kind = KindOf(name);
  const std::size_t dot = name.find('.');
  const std::string_view ids =
      dot == std::string::npos ? std::string_view() : std::string_view(name).substr(dot + 1);
  const auto id = [](std::string_view text) {
    int value = 0;
    std::from_chars(text.data(), text.data() + text.size(), value);
    return value;
  };
  if (kind == "amplitude" || kind == "offset" || kind == "speed" || kind == "minangle" ||
      kind == "maxangle") {
    if (!IsCanonicalId(ids)) return "unknown parameter '" + name + "'; " + expected;
    return "parameter '" + name + "': module " + std::string(ids) + " is not in the configuration";
  }
  if (kind == "phase" || kind == "weight") {
    const std::size_t dot2 = ids.find('.');
    if (dot2 == std::string_view::npos || !IsCanonicalId(ids.substr(0, dot2)) ||
        !IsCanonicalId(ids.substr(dot2 + 1))) {
      return "unknown parameter '" + name + "'; " + expected;
    }
    const int from = id(ids.substr(0, dot2));
    const int to = id(ids.substr(dot2 + 1));
    if (robot.FindModule(from) == nullptr) {
      return "parameter '" + name + "': module " + std::to_string(from) +
             " is not in the configuration";
    }
    if (robot.FindModule(to) == nullptr) {
      return "parameter '" + name + "': module " + std::to_string(to) +
             " is not in the configuration";
    }
    if (from == to) return "parameter '" + name + "': a module is never coupled to itself";
    return "parameter '" + name + "': the configuration has no coupling " +
           std::to_string(from) + " -> " + std::to_string(to) + " (add a <cpglink> to module " +
           std::to_string(from) + ")";
  }
  return "unknown parameter '" + name + "'; " + expected;
}

std::string ReadFile(const std::string& path) {
  std::error_code error;
  if (std::filesystem::is_directory(path, error)) {
    throw Error(StatusCode::kNotFound,
                "cannot read optimization config " + path + ": it is a directory");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    throw Error(StatusCode::kNotFound,
                "cannot read optimization config " + path + ": " + std::strerror(errno));
  }
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) {
    throw Error(StatusCode::kNotFound, "cannot read optimization config " + path + ": read error");
  }
  return text.str();
}

}  // namespace

double M2Pi(double x) {
  if (!std::isfinite(x)) return std::numeric_limits<double>::quiet_NaN();
  double r = std::fmod(-x, kTwoPi);  // in (-2π, 2π)
  if (r < 0) r += kTwoPi;            // in [0, 2π]
  // A sum of phases meant to close a ring lands a few ulps off a multiple of
  // 2π; answering ~2π there would flip the closing link by a full turn.
  const double tolerance = 1e-9 * std::max(1.0, std::abs(x));
  if (r < tolerance || kTwoPi - r < tolerance) return 0.0;
  return r;
}

// The immutable tables of a loaded configuration and a pool of compiled
// parser sets. Thread safety: everything but the pool is immutable after
// construction; the pool is guarded by mu.
struct OptimizationConfig::Engine {
  // One compiled copy of every constrain rule's expression, reading the
  // parameter values of its own value array.
  struct ParserSet {
    std::unique_ptr<double[]> values;  // one slot per parameter; never moves
    std::vector<std::unique_ptr<mu::Parser>> parsers;  // one per constrain rule
  };

  // Hands a parser set back to the pool however the evaluation ends.
  class Lease {
   public:
    explicit Lease(const Engine& engine) : engine_(engine), set_(engine.Take()) {}
    ~Lease() { engine_.Give(std::move(set_)); }
    Lease(const Lease&) = delete;
    Lease& operator=(const Lease&) = delete;
    ParserSet& set() { return *set_; }

   private:
    const Engine& engine_;
    std::unique_ptr<ParserSet> set_;
  };

  std::string source;
  cpg::RobotConfig robot;          // for messages about unknown names
  std::vector<std::string> names;  // every parameter of the robot configuration
  std::vector<double> base;        // its value in the file
  std::vector<FieldRange> ranges;  // what the modules accept
  std::map<std::string, int, std::less<>> index;  // name -> position in names
  std::vector<OptimizeRule> optimized;
  std::vector<ConstrainRule> constrained;
  std::vector<int> optimized_index;    // per optimize rule
  std::vector<int> constrained_index;  // per constrain rule
  // Modules whose limit angles a candidate sets, whose order the firmware
  // checks: the minangle and maxangle slots and the line of the last rule
  // setting either.
  struct LimitPair {
    int min = 0;
    int max = 0;
    int line = 0;
  };
  std::vector<LimitPair> limit_pairs;

  mutable std::mutex mu;
  mutable std::vector<std::unique_ptr<ParserSet>> free_sets;  // guarded by mu

  std::string At(int line) const { return source + ":" + std::to_string(line) + ": "; }

  std::string RuleWhere(const ConstrainRule& rule) const {
    return At(rule.line) + "constrain rule for '" + rule.param + "' (expr \"" + rule.expr + "\")";
  }

  // The optimized values, for messages about a candidate.
  std::string Point(const std::vector<double>& x) const {
    std::string out;
    for (std::size_t k = 0; k < x.size() && k < optimized.size(); ++k) {
      out += (out.empty() ? "" : ", ") + optimized[k].param + "=" + FormatDouble(x[k]);
    }
    return out;
  }

  [[noreturn]] void FailParser(const ConstrainRule& rule, const mu::ParserError& e) const {
    std::string message = At(rule.line) + "constrain rule for '" + rule.param +
                          "': error in expression \"" + rule.expr + "\"";
    if (e.GetPos() >= 0) message += " at position " + std::to_string(e.GetPos());
    if (!e.GetToken().empty()) message += " (token \"" + e.GetToken() + "\")";
    std::string reason = e.GetMsg();
    while (!reason.empty() && (reason.back() == '.' || reason.back() == ' ')) reason.pop_back();
    message += ": " + reason;
    // An unknown name is most often a parameter written without brackets
    // or one the robot does not have; say which.
    if (e.GetCode() == mu::ecUNASSIGNABLE_TOKEN && !e.GetToken().empty()) {
      if (index.contains(e.GetToken())) {
        message += "; parameters are functions: write " + e.GetToken() + "()";
      } else if (e.GetToken().find('.') != std::string::npos) {
        message += "; " + WhyUnknown(e.GetToken(), robot);
      }
    }
    Fail(message);
  }

  std::unique_ptr<ParserSet> Compile() const {
    auto set = std::make_unique<ParserSet>();
    set->values = std::make_unique<double[]>(names.size());
    for (const ConstrainRule& rule : constrained) {
      auto parser = std::make_unique<mu::Parser>();
      try {
        parser->DefineNameChars(kNameChars);
        parser->DefineConst("pi", M_PI);
        parser->DefineFun("M2Pi", M2PiCallback);
        for (std::size_t i = 0; i < names.size(); ++i) {
          // Not optimizable: muParser would fold a zero-argument call into
          // the constant it returned when the expression was compiled.
          parser->DefineFunUserData(names[i], ReadSlot, &set->values[i], /*a_bAllowOpt=*/false);
        }
        parser->SetExpr(rule.expr);
      } catch (const mu::ParserError& e) {
        FailParser(rule, e);
      }
      set->parsers.push_back(std::move(parser));
    }
    return set;
  }

  std::unique_ptr<ParserSet> Take() const {
    {
      std::lock_guard<std::mutex> lock(mu);
      if (!free_sets.empty()) {
        std::unique_ptr<ParserSet> set = std::move(free_sets.back());
        free_sets.pop_back();
        return set;
      }
    }
    return Compile();  // outside the lock: compiling takes a while
  }

  void Give(std::unique_ptr<ParserSet> set) const {
    if (set == nullptr) return;
    std::lock_guard<std::mutex> lock(mu);
    free_sets.push_back(std::move(set));
  }

  // Checks x, evaluates the constrain rules in order and returns every named
  // value. `when` ends the messages about values (" at the start point").
  std::vector<std::pair<std::string, double>> Resolve(const std::vector<double>& x,
                                                      const std::string& when) const {
    if (x.size() != optimized.size()) {
      std::string list;
      for (const OptimizeRule& rule : optimized) list += (list.empty() ? "" : ", ") + rule.param;
      Fail(source + ": a candidate has " + std::to_string(x.size()) + " values but " +
           std::to_string(optimized.size()) + " parameters are optimized (" + list + ")" + when);
    }
    for (std::size_t k = 0; k < x.size(); ++k) {
      const OptimizeRule& rule = optimized[k];
      if (!std::isfinite(x[k])) {
        Fail(At(rule.line) + "optimize rule for '" + rule.param + "': value " + FormatDouble(x[k]) +
             " is not finite" + when);
      }
      if (!(x[k] >= rule.min && x[k] <= rule.max)) {
        Fail(At(rule.line) + "optimize rule for '" + rule.param + "': value " + FormatDouble(x[k]) +
             " is outside [" + FormatDouble(rule.min) + ", " + FormatDouble(rule.max) + "]" + when);
      }
    }
    Lease lease(*this);
    ParserSet& set = lease.set();
    double* values = set.values.get();
    std::copy(base.begin(), base.end(), values);
    for (std::size_t k = 0; k < x.size(); ++k) values[optimized_index[k]] = x[k];

    std::vector<std::pair<std::string, double>> out;
    out.reserve(optimized.size() + constrained.size());
    for (std::size_t k = 0; k < x.size(); ++k) out.emplace_back(optimized[k].param, x[k]);
    for (std::size_t k = 0; k < constrained.size(); ++k) {
      const ConstrainRule& rule = constrained[k];
      double value = 0;
      try {
        value = set.parsers[k]->Eval();
      } catch (const mu::ParserError& e) {
        FailParser(rule, e);
      }
      if (!std::isfinite(value)) {
        Fail(RuleWhere(rule) + " evaluates to " + FormatDouble(value) + " for " + Point(x) + when);
      }
      const FieldRange& range = ranges[constrained_index[k]];
      if (!(value >= range.lo && value <= range.hi)) {
        Fail(RuleWhere(rule) + " evaluates to " + FormatDouble(value) +
             ", outside what the modules accept ([" +
             FormatDouble(range.lo) + ", " + FormatDouble(range.hi) + "]), for " + Point(x) + when);
      }
      values[constrained_index[k]] = value;
      out.emplace_back(rule.param, value);
    }
    for (const LimitPair& pair : limit_pairs) {
      if (!(values[pair.min] < values[pair.max])) {
        Fail(At(pair.line) + "a candidate sets " + names[pair.min] + " = " +
             FormatDouble(values[pair.min]) + " not below " + names[pair.max] + " = " +
             FormatDouble(values[pair.max]) + " (a module needs min angle < max angle), for " + Point(x) +
             when);
      }
    }
    return out;
  }
};

namespace {

// A rule as read, before its parameter is checked against the robot.
struct RawRule {
  bool optimize = false;  // else constrain
  std::string param;
  double min = 0;
  double max = 0;
  std::string expr;
  int line = 0;
};

// Reads the rules among the direct children of <yamorconfig>; the robot
// reader has already accepted everything else.
class RuleReader {
 public:
  explicit RuleReader(std::string source) : source_(std::move(source)) {}

  std::vector<RawRule> Read(const std::string& xml) const {
    tinyxml2::XMLDocument document;
    if (document.Parse(xml.data(), xml.size()) != tinyxml2::XML_SUCCESS) {
      Fail(At(document.ErrorLineNum()) + "malformed XML: " + document.ErrorStr());
    }
    const tinyxml2::XMLElement* root = document.RootElement();
    YAMOR_CHECK(root != nullptr, "the robot reader accepted a document without a root");
    std::vector<RawRule> rules;
    for (const tinyxml2::XMLElement* element = root->FirstChildElement(); element != nullptr;
         element = element->NextSiblingElement()) {
      const std::string_view name = element->Name();
      if (name == "optimize" || name == "constrain") rules.push_back(ReadRule(*element));
    }
    return rules;
  }

 private:
  std::string At(int line) const {
    return source_ + ":" + std::to_string(std::max(line, 1)) + ": ";
  }

  RawRule ReadRule(const tinyxml2::XMLElement& element) const {
    const std::string name = element.Name();
    const std::string where = At(element.GetLineNum()) + "<" + name + ">: ";
    for (const tinyxml2::XMLAttribute* a = element.FirstAttribute(); a != nullptr; a = a->Next()) {
      const std::string_view attribute = a->Name();
      const bool known = attribute == "param" || attribute == "expr" ||
                         (name == "optimize" && (attribute == "min" || attribute == "max"));
      if (!known) {
        Fail(At(a->GetLineNum()) + "unknown attribute " + std::string(attribute) + " on <" + name +
             "> (expected param and min/max, or param and expr)");
      }
    }
    for (const tinyxml2::XMLNode* child = element.FirstChild(); child != nullptr;
         child = child->NextSibling()) {
      if (child->ToComment() != nullptr) continue;
      if (child->ToText() != nullptr && Trim(child->Value()).empty()) continue;
      Fail(At(child->GetLineNum()) + "<" + name + "> takes no content (found \"" +
           std::string(Trim(child->Value())) + "\")");
    }
    RawRule rule;
    rule.line = element.GetLineNum();
    const char* param = element.Attribute("param");
    if (param == nullptr) Fail(where + "missing attribute param");
    rule.param = std::string(Trim(param));
    const std::string context = where + "param '" + rule.param + "': ";
    const char* expr = element.Attribute("expr");
    const bool has_bounds =
        element.Attribute("min") != nullptr || element.Attribute("max") != nullptr;
    if (expr != nullptr) {
      // The thesis writes a constrain rule as <optimize param expr>.
      if (has_bounds) {
        Fail(context + "a rule with expr is a constrain rule and takes no min/max");
      }
      rule.optimize = false;
      rule.expr = std::string(Trim(expr));
      if (rule.expr.empty()) Fail(context + "empty expr");
      return rule;
    }
    if (name == "constrain") Fail(context + "missing attribute expr");
    rule.optimize = true;
    rule.min = Bound(element, "min", context);
    rule.max = Bound(element, "max", context);
    if (!(rule.min < rule.max)) {
      Fail(context + "min (" + FormatDouble(rule.min) + ") must be below max (" + FormatDouble(rule.max) + ")");
    }
    return rule;
  }

  double Bound(const tinyxml2::XMLElement& element, const char* name,
               const std::string& context) const {
    const char* raw = element.Attribute(name);
    if (raw == nullptr) {
      Fail(context + "missing attribute " + name + " (an optimize rule needs min and max)");
    }
    std::string_view text = Trim(raw);
    if (text.size() > 1 && text[0] == '+' && text[1] != '-') text.remove_prefix(1);
    double value = 0;
    const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
    const std::string what = context + name + " (\"" + raw + "\")";
    if (text.empty() || end != text.data() + text.size() ||
        (error != std::errc() && error != std::errc::result_out_of_range)) {
      Fail(what + " is not a number");
    }
    if (error == std::errc::result_out_of_range || !std::isfinite(value)) {
      Fail(what + " must be a finite number");
    }
    return value;
  }

  std::string source_;
};

// Whether `expr` calls the parameter function `name` (a warning heuristic:
// the name as a whole token followed by '(').
bool Calls(const std::string& expr, const std::string& name) {
  for (std::size_t at = expr.find(name); at != std::string::npos; at = expr.find(name, at + 1)) {
    if (at > 0 && IsNameChar(expr[at - 1])) continue;
    std::size_t next = at + name.size();
    while (next < expr.size() && (expr[next] == ' ' || expr[next] == '\t')) ++next;
    if (next < expr.size() && expr[next] == '(') return true;
  }
  return false;
}

}  // namespace

OptimizationConfig OptimizationConfig::LoadFile(const std::string& path) {
  return Parse(ReadFile(path), path);
}

OptimizationConfig OptimizationConfig::Parse(const std::string& xml,
                                             const std::string& source_name) {
  OptimizationConfig config;
  config.source_ = source_name;
  config.robot_ = cpg::ParseConfigXmlSkipping(xml, source_name, {"optimize", "constrain"});
  const cpg::RobotConfig& robot = config.robot_;

  auto engine = std::make_shared<Engine>();
  engine->source = source_name;
  engine->robot = robot;
  const auto add = [&](std::string name, double value) {
    engine->index.emplace(name, static_cast<int>(engine->names.size()));
    engine->ranges.push_back(RangeOf(KindOf(name)));
    engine->names.push_back(std::move(name));
    engine->base.push_back(value);
  };
  for (const cpg::ModuleParams& m : robot.modules) {
    const std::string id = std::to_string(m.id);
    add("amplitude." + id, m.amplitude);
    add("offset." + id, m.offset);
    add("speed." + id, m.speed);
    add("minangle." + id, m.min_angle);
    add("maxangle." + id, m.max_angle);
  }
  for (const cpg::Coupling& c : robot.couplings) {
    const std::string ids = std::to_string(c.from) + "." + std::to_string(c.to);
    add("phase." + ids, c.phase);
    add("weight." + ids, c.weight);
  }

  std::map<std::string, const RawRule*> seen;
  const std::vector<RawRule> rules = RuleReader(source_name).Read(xml);
  for (const RawRule& rule : rules) {
    const std::string where = config.At(rule.line);
    const auto found = engine->index.find(rule.param);
    if (found == engine->index.end()) Fail(where + WhyUnknown(rule.param, robot));
    if (const auto it = seen.find(rule.param); it != seen.end()) {
      const RawRule& first = *it->second;
      if (first.optimize != rule.optimize) {
        Fail(where + "parameter '" + rule.param + "' is both optimized and constrained (the " +
             (first.optimize ? "optimize" : "constrain") + " rule is at line " +
             std::to_string(first.line) + ")");
      }
      Fail(where + "parameter '" + rule.param + "' is listed twice (first at line " +
           std::to_string(first.line) + ")");
    }
    seen.emplace(rule.param, &rule);
    if (rule.optimize) {
      const FieldRange range = RangeOf(KindOf(rule.param));
      if (rule.min < range.lo || rule.max > range.hi) {
        Fail(where + "parameter '" + rule.param + "': bounds [" + FormatDouble(rule.min) + ", " +
             FormatDouble(rule.max) + "] exceed what the modules accept for " +
             std::string(KindOf(rule.param)) + " ([" + FormatDouble(range.lo) + ", " + FormatDouble(range.hi) +
             "])");
      }
      config.optimized_.push_back(
          OptimizeRule{.param = rule.param, .min = rule.min, .max = rule.max, .line = rule.line});
      engine->optimized_index.push_back(found->second);
    } else {
      config.constrained_.push_back(
          ConstrainRule{.param = rule.param, .expr = rule.expr, .line = rule.line});
      engine->constrained_index.push_back(found->second);
    }
  }
  if (config.optimized_.empty()) {
    Fail(config.At(robot.master_location.line) +
         "no <optimize param=\"...\" min=\"...\" max=\"...\"/> rule: nothing to optimize");
  }
  engine->optimized = config.optimized_;
  engine->constrained = config.constrained_;
  for (const cpg::ModuleParams& m : robot.modules) {
    const std::string id = std::to_string(m.id);
    const std::string min_name = "minangle." + id;
    const std::string max_name = "maxangle." + id;
    const auto min_rule = seen.find(min_name);
    const auto max_rule = seen.find(max_name);
    if (min_rule != seen.end() || max_rule != seen.end()) {
      engine->limit_pairs.push_back(Engine::LimitPair{
          .min = engine->index.at(min_name),
          .max = engine->index.at(max_name),
          .line = std::max(min_rule != seen.end() ? min_rule->second->line : 0,
                           max_rule != seen.end() ? max_rule->second->line : 0)});
    }
  }

  // A rule calling a parameter constrained by itself or a later rule reads
  // the file's value, not the candidate's: legal, but rarely meant.
  for (std::size_t j = 0; j < config.constrained_.size(); ++j) {
    for (std::size_t k = j; k < config.constrained_.size(); ++k) {
      const ConstrainRule& rule = config.constrained_[j];
      const ConstrainRule& later = config.constrained_[k];
      if (Calls(rule.expr, later.param)) {
        Log().warn("{}constrain rule for '{}' calls {}(), which {} line {}: it reads the "
                   "configuration's value, not this candidate's",
                   config.At(rule.line), rule.param, later.param,
                   k == j ? "this rule sets at" : "is constrained later, at", later.line);
      }
    }
  }

  // Compile and evaluate every expression once now, so that a bad rule is
  // reported at load rather than on the first candidate.
  engine->Give(engine->Compile());
  config.engine_ = std::move(engine);
  const std::vector<double> start = config.ClampedStart(/*log=*/false);
  config.engine().Resolve(start, " (at the start point)");
  config.Apply(start);
  return config;
}

std::string OptimizationConfig::At(int line) const {
  return source_ + ":" + std::to_string(std::max(line, 1)) + ": ";
}

const OptimizationConfig::Engine& OptimizationConfig::engine() const {
  if (engine_ == nullptr) {
    throw Error(StatusCode::kFailedPrecondition,
                "the optimization configuration is empty (none was loaded)");
  }
  return *engine_;
}

std::vector<double> OptimizationConfig::ClampedStart(bool log) const {
  const Engine& tables = engine();
  std::vector<double> start;
  start.reserve(optimized_.size());
  for (std::size_t k = 0; k < optimized_.size(); ++k) {
    const OptimizeRule& rule = optimized_[k];
    const double value = tables.base[tables.optimized_index[k]];
    const double clamped = std::clamp(value, rule.min, rule.max);
    if (log && clamped != value) {
      Log().warn("{}the configuration's {} = {} is outside the optimize bounds [{}, {}]; "
                 "starting from {}",
                 At(rule.line), rule.param, FormatDouble(value), FormatDouble(rule.min), FormatDouble(rule.max),
                 FormatDouble(clamped));
    }
    start.push_back(clamped);
  }
  return start;
}

std::vector<double> OptimizationConfig::StartValues() const { return ClampedStart(/*log=*/true); }

std::vector<std::pair<std::string, double>> OptimizationConfig::Resolve(
    const std::vector<double>& x) const {
  return engine().Resolve(x, "");
}

cpg::RobotConfig OptimizationConfig::Apply(const std::vector<double>& x) const {
  const std::vector<std::pair<std::string, double>> values = Resolve(x);
  cpg::RobotConfig robot = robot_;
  try {
    cpg::ApplyParameters(robot, values);
  } catch (const Error& e) {
    // Resolve checks what the firmware accepts, so this is a gap between
    // the two checks; still a caller-visible error, never an abort.
    Fail(source_ + ": applying the candidate " + engine().Point(x) + ": " + e.what());
  }
  return robot;
}

std::string OptimizationConfig::RobotXml() const {
  engine();  // an empty configuration has no robot to write
  return cpg::WriteConfigXml(robot_);
}

}  // namespace yamor::optimizer
