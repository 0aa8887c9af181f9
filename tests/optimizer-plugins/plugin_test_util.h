// Shared helpers for plugin tests: run a built plugin (from the build tree's
// plugin folder) on an analytic function through the real framework session
// and the in-process FunctionEvaluator.
#pragma once

#include <cmath>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "optimizer-plugins/framework/evaluator.h"
#include "optimizer-plugins/framework/plugin_loader.h"
#include "optimizer-plugins/framework/session.h"

namespace yamor::optimizer::testing {

/// The built plugin NAME.so (tests link with YAMOR_PLUGIN_DIR defined).
inline LoadedPlugin LoadBuiltPlugin(const std::string& name) {
  return LoadedPlugin::Load(std::string(YAMOR_PLUGIN_DIR) + "/" + name + ".so");
}

/// An analytic function of the point, in parameter order.
using PointFunction = std::function<double(const std::vector<double>&)>;

/// What a test run produced.
struct PluginRun {
  SessionResult result;                  ///< The session's end.
  std::vector<EvaluationRecord> records; ///< Every evaluation, in order.
};

/// Runs `plugin` on `f` over `parameters` with --set values `set` and `seed`.
inline PluginRun RunPlugin(const LoadedPlugin& plugin, std::vector<ProblemParameter> parameters,
                           const PointFunction& f, std::map<std::string, std::string> set = {},
                           std::uint64_t seed = 1) {
  Problem problem = PlainProblem(std::move(parameters));
  FunctionEvaluator evaluator([&](const std::vector<std::pair<std::string, double>>& named) {
    std::vector<double> x;
    for (const auto& [name, value] : named) x.push_back(value);
    return f(x);
  });
  Session session(plugin, problem, evaluator, {.seed = seed, .set = std::move(set)});
  PluginRun run;
  run.result = session.Run();
  run.records = session.Records();
  return run;
}

/// Negated sphere centred at `centre`: maximum 0 there.
inline PointFunction Sphere(std::vector<double> centre) {
  return [centre](const std::vector<double>& x) {
    double s = 0.0;
    for (std::size_t i = 0; i < x.size(); ++i) s -= (x[i] - centre[i]) * (x[i] - centre[i]);
    return s;
  };
}

/// Negated Rosenbrock (banana valley): maximum 0 at (1, ..., 1).
inline double NegRosenbrock(const std::vector<double>& x) {
  double s = 0.0;
  for (std::size_t i = 0; i + 1 < x.size(); ++i) {
    s -= 100.0 * std::pow(x[i + 1] - x[i] * x[i], 2) + std::pow(1.0 - x[i], 2);
  }
  return s;
}

/// Negated Rastrigin (many local maxima): global maximum 0 at the origin.
inline double NegRastrigin(const std::vector<double>& x) {
  double s = -10.0 * static_cast<double>(x.size());
  for (double v : x) s -= v * v - 10.0 * std::cos(2.0 * M_PI * v);
  return s;
}

}  // namespace yamor::optimizer::testing
