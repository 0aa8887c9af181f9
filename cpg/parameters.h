// Checked edits of a robot configuration: the module and coupling setters of
// the API and the named parameters of optimizers (DESIGN.md: amplitude.3,
// offset.3, speed.3, minangle.3, maxangle.3, phase.2.5, weight.2.5).
//
// The bounds are those the module firmware accepts, so a value that passes
// here is never refused by a module.
#pragma once

#include <cmath>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "cpg/robot_config.h"

namespace yamor::cpg {

/// Largest oscillator amplitude and |offset| [rad].
inline constexpr double kMaxAmplitude = 2.0 * M_PI;
/// Largest |min angle| and |max angle| [rad].
inline constexpr double kMaxLimitAngle = 2.0 * M_PI;
/// Largest oscillator frequency [Hz] (a servo cannot follow faster).
inline constexpr double kMaxSpeedHz = 10.0;
/// Largest |coupling weight|.
inline constexpr double kMaxCouplingWeight = 1000.0;
/// Largest |coupling phase| [rad].
inline constexpr double kMaxCouplingPhase = 4.0 * M_PI;

/// A per-module parameter.
enum class ModuleField { kAmplitude, kOffset, kSpeed, kMinAngle, kMaxAngle };
/// A per-coupling parameter.
enum class CouplingField { kPhase, kWeight };

/// "amplitude", "offset", "speed", "minangle", "maxangle".
std::string_view FieldName(ModuleField field);
/// "phase", "weight".
std::string_view FieldName(CouplingField field);

/// The value of `field` of module `id`; NOT_FOUND for an unknown module.
double GetModuleField(const cpg::RobotConfig& config, int id, ModuleField field);
/// Sets `field` of module `id`: NOT_FOUND unknown module, INVALID_ARGUMENT
/// NaN/inf, OUT_OF_RANGE outside its bounds (amplitude in [0, 2π], |offset|
/// <= 2π, speed in [0, 10] Hz, |angles| <= 2π and min < max unless
/// `check_order` is false).
void SetModuleField(cpg::RobotConfig& config, int id, ModuleField field, double value,
                    bool check_order = true);

/// The value of `field` of coupling from -> to; NOT_FOUND when absent.
double GetCouplingField(const cpg::RobotConfig& config, int from, int to, CouplingField field);
/// Sets `field` of the existing coupling from -> to (NOT_FOUND when absent;
/// INVALID_ARGUMENT NaN/inf; OUT_OF_RANGE |phase| > 4π or |weight| > 1000).
void SetCouplingField(cpg::RobotConfig& config, int from, int to, CouplingField field,
                      double value);
/// Adds or replaces the coupling from -> to: NOT_FOUND unknown module,
/// INVALID_ARGUMENT self-coupling or NaN/inf, OUT_OF_RANGE as above.
void AddCoupling(cpg::RobotConfig& config, int from, int to, double phase, double weight);

/// A parsed parameter name (DESIGN.md): a module field or a coupling field.
struct ParameterName {
  bool coupling = false;  ///< phase/weight of a coupling rather than a module field.
  ModuleField module_field = ModuleField::kAmplitude;    ///< The field, when !coupling.
  CouplingField coupling_field = CouplingField::kPhase;  ///< The field, when coupling.
  int id = 0;    ///< The module, when !coupling.
  int from = 0;  ///< The coupling's module whose equation holds the term, when coupling.
  int to = 0;    ///< The coupling's driving module, when coupling.
};

/// Parses "amplitude.3", "offset.3", "speed.3", "minangle.3", "maxangle.3",
/// "phase.2.5" or "weight.2.5" (ids 0..254). Throws INVALID_ARGUMENT saying
/// what was expected (the caller names the parameter). Pure.
ParameterName ParseParameterName(std::string_view name);

/// Applies named parameter values in order (min < max is checked after all
/// of them). Errors name the parameter: INVALID_ARGUMENT for a malformed or
/// unknown name ("unknown parameter 'foo.3'") or NaN/inf, NOT_FOUND for an
/// unknown module or coupling, OUT_OF_RANGE outside the bounds.
void ApplyParameters(cpg::RobotConfig& config,
                     const std::vector<std::pair<std::string, double>>& parameters);

}  // namespace yamor::cpg
