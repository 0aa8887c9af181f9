// The general optimization configuration of the thesis (5.7.2): a robot
// configuration (C.4 schema) plus rules, as direct children of
// <yamorconfig>, naming the parameters an optimizer varies and those whose
// values follow from others:
//
//   <optimize  param="amplitude.0" min="0" max="0.785398163397448"/>
//   <constrain param="amplitude.1" expr="amplitude.0()"/>
//
// (the thesis spells a constrain rule `<optimize param expr>`; both are
// read). Expressions are muParser expressions (the thesis's MathEval, 5.6)
// in which every parameter of the robot configuration is a zero-argument
// function, `phase.0.1()`, beside M2Pi(x), `pi` and muParser's built-ins.
#pragma once

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "cpg/robot_config.h"

namespace yamor::optimizer {

/// An `<optimize param min max>` rule: a free parameter and its bounds.
struct OptimizeRule {
  std::string param;  ///< Canonical parameter name, e.g. "amplitude.3".
  double min = 0;     ///< Lower bound (inclusive).
  double max = 0;     ///< Upper bound (inclusive), > min.
  int line = 0;       ///< Source line of the rule.
};

/// A `<constrain param expr>` rule: a parameter computed from others.
struct ConstrainRule {
  std::string param;  ///< Canonical parameter name, e.g. "phase.3.0".
  std::string expr;   ///< muParser expression, e.g. "M2Pi(phase.0.1()+phase.1.2())".
  int line = 0;       ///< Source line of the rule.
};

/// The angle to add to `x` to reach a multiple of 2π: the value in [0, 2π)
/// with x + M2Pi(x) ≡ 0 (mod 2π). Results within rounding noise of 0 or 2π
/// (1e-9·max(1, |x|)) are 0. NaN for a non-finite `x`.
double M2Pi(double x);

/// A loaded optimization configuration: the validated robot, its optimize
/// rules and constrain rules, and the machinery to turn a point of the
/// optimized parameters into every named value a candidate sets.
///
/// Every expression is evaluated once at load, at the start point, so a bad
/// rule is reported before any evaluation. Constrain rules run in file order
/// on each candidate; a rule sees the optimized values, the results of the
/// rules above it and the configuration's value of every other parameter.
///
/// Thread safety: immutable after load; Resolve/Apply are const and safe to
/// call concurrently. muParser parsers are not thread-safe, so each Resolve
/// borrows a private set of compiled parsers from a pool shared by the copies
/// of this object (a new set is compiled when every set is busy), and calls
/// never wait on each other beyond the pool's short lock. Copying is cheap
/// and copies share the pool.
class OptimizationConfig {
 public:
  /// An empty configuration, to be assigned a loaded one: no robot and no
  /// rules; StartValues, Resolve, Apply and RobotXml throw yamor::Error
  /// kFailedPrecondition.
  OptimizationConfig() = default;

  /// Reads the file at `path`; errors name the file and line. Throws
  /// yamor::Error kNotFound when unreadable, kInvalidArgument when malformed.
  static OptimizationConfig LoadFile(const std::string& path);
  /// Parses XML text; `source_name` stands for the file in error messages.
  /// Throws yamor::Error kInvalidArgument naming source:line, the parameter
  /// and, for expression errors, the expression and the position.
  static OptimizationConfig Parse(const std::string& xml, const std::string& source_name);

  /// The robot configuration (rules removed), validated, values as in the file.
  const cpg::RobotConfig& robot() const { return robot_; }
  /// The optimize rules in file order (the order of x).
  const std::vector<OptimizeRule>& optimized() const { return optimized_; }
  /// The constrain rules in file order (the order they are evaluated in).
  const std::vector<ConstrainRule>& constrained() const { return constrained_; }

  /// The configuration's value of each optimized parameter, clamped into its
  /// [min, max] (a clamp is logged as a warning).
  std::vector<double> StartValues() const;

  /// Every named value a candidate sets: the optimized ones (x, in rule
  /// order) then each constrained one (in rule order). Throws yamor::Error
  /// kInvalidArgument when x has the wrong size or a value is non-finite or
  /// outside its bounds, and when a constraint gives NaN/inf or a value the
  /// modules refuse (naming the rule and the optimized values).
  std::vector<std::pair<std::string, double>> Resolve(const std::vector<double>& x) const;

  /// robot() with Resolve(x) applied via cpg::ApplyParameters; errors as
  /// Resolve's.
  cpg::RobotConfig Apply(const std::vector<double>& x) const;

  /// The canonical robot XML (no rules): what the daemons get as config_xml.
  std::string RobotXml() const;

  /// The file name or source name the configuration was read from.
  std::string source() const { return source_; }

 private:
  struct Engine;  // compiled expressions; defined in the .cc

  std::string At(int line) const;
  const Engine& engine() const;  // throws kFailedPrecondition when empty
  std::vector<double> ClampedStart(bool log) const;

  std::string source_;
  cpg::RobotConfig robot_;
  std::vector<OptimizeRule> optimized_;
  std::vector<ConstrainRule> constrained_;
  std::shared_ptr<Engine> engine_;  // immutable tables + its own locked pool
};

}  // namespace yamor::optimizer
