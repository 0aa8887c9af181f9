// bayesopt: Bayesian optimization for evaluation budgets of tens, where
// every evaluation is a walk (thesis 6.3: a real robot allows few trials).
// A Gaussian process (optimizer-plugins/gp: Matérn 5/2 with one length scale
// per parameter, MAP hyper-parameters refitted after every batch) models the
// velocity over the box; each next point maximizes log expected improvement
// (or UCB); `batch` > 1 picks that many by the Kriging believer so a pool
// evaluates them at once.
//
// The run: the initial design (the configuration's values, then a seeded
// maximin Latin hypercube in the first trust region around them) as one
// batch, then proposals from the trust region around the best point until
// the budget; phases over a whole turn wrap around in the model. Both were
// measured on the quadruped (docs/optimizers.md): without them the global
// model, fitted to tens of walks in 7 dimensions, trailed simplex (4.30
// against 7.26 cm/s after 25 walks).
// The search runs in normalized coordinates (each range mapped to [0, 1]).
// Constrained parameters never reach a plugin: the framework applies the
// configuration's <constrain> rules to every candidate. A non-finite value
// (which the framework does not pass on today, but the ABI allows) counts as
// the worst value seen. The generator is seeded from the context's.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "optimizer-plugins/gp/bayes_optimizer.h"
#include "yamor/optimizer_plugin.hpp"

namespace yamor::plugins::bayesopt {
namespace {

std::string Number(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.6g", v);
  return buffer;
}

class BayesOpt : public yamor::plugin::Optimizer {
 public:
  void Run(yamor::plugin::Context& context) override {
    n_ = context.Dimension();
    lower_ = context.Lower();
    upper_ = context.Upper();
    const long long budget = context.IntField("max_evaluations");
    const long long batch = context.IntField("batch");
    long long initial = context.IntField("initial_points");
    if (initial == 0) initial = std::max<long long>(static_cast<long long>(n_) + 1, 5);
    initial = std::min(initial, budget);

    gp::BayesOptions options;
    options.dimension = static_cast<int>(n_);
    options.acquisition = context.Field("acquisition") == "ucb" ? gp::Acquisition::kUpperConfidenceBound
                                                                : gp::Acquisition::kExpectedImprovement;
    options.kappa = context.RealField("kappa");
    options.fit_restarts = static_cast<int>(context.IntField("fit_restarts"));
    options.priors.noise_floor = context.RealField("noise_floor");
    options.max_model_points = static_cast<int>(context.IntField("max_model_points"));
    options.trust_region = context.RealField("trust_region");
    if (context.BoolField("periodic_phases")) {
      // A phase lag over exactly one turn: its two ends are the same gait.
      for (std::size_t i = 0; i < n_; ++i) {
        const bool phase = std::string(context.Parameter(i).name).rfind("phase.", 0) == 0;
        const double range = upper_[i] - lower_[i];
        options.periodic.push_back(phase && std::abs(range - 2.0 * M_PI) < 1e-9 * 2.0 * M_PI);
      }
    }
    gp::BayesianOptimizer bo(options, context.Random());

    std::vector<Eigen::VectorXd> design;
    const bool include_start = context.BoolField("include_start") && initial > 0;
    if (include_start) {
      const std::vector<double> start = context.Start();
      Eigen::VectorXd u(static_cast<Eigen::Index>(n_));
      for (std::size_t i = 0; i < n_; ++i) {
        u[static_cast<Eigen::Index>(i)] = std::clamp((start[i] - lower_[i]) / (upper_[i] - lower_[i]), 0.0, 1.0);
      }
      design.push_back(u);
    }
    if (initial > static_cast<long long>(design.size())) {
      const int more = static_cast<int>(initial) - static_cast<int>(design.size());
      // With a trust region, the design explores the start's neighbourhood.
      for (const Eigen::VectorXd& u : include_start ? bo.InitialDesign(more, design.front()) : bo.InitialDesign(more)) {
        design.push_back(u);
      }
    }
    try {
      if (!design.empty()) EvaluateAndTell(context, bo, design);
      while (true) {
        const long long remaining = budget - bo.observations();
        // The run's status is "budget" when the evaluations reached it.
        if (remaining <= 0) throw yamor::plugin::Stopped();
        const std::vector<Eigen::VectorXd> next = bo.Ask(static_cast<int>(std::min(batch, remaining)));
        fit_seconds_.push_back(bo.last_fit_seconds());
        ask_seconds_.push_back(bo.last_ask_seconds());
        EvaluateAndTell(context, bo, next);
        context.Progress(std::min(1.0, static_cast<double>(bo.observations()) / static_cast<double>(budget)),
                         std::to_string(bo.observations()) + " evaluations, best " + Number(best_value_) +
                             ", fit " + Number(1e3 * bo.last_fit_seconds()) + " ms");
      }
    } catch (const yamor::plugin::Stopped&) {
      Summary(context, bo);
      throw;
    }
  }

 private:
  void EvaluateAndTell(yamor::plugin::Context& context, gp::BayesianOptimizer& bo,
                       const std::vector<Eigen::VectorXd>& units) {
    std::vector<std::vector<double>> points;
    for (const Eigen::VectorXd& u : units) {
      std::vector<double> p(n_);
      for (std::size_t i = 0; i < n_; ++i) p[i] = ToReal(u[static_cast<Eigen::Index>(i)], lower_[i], upper_[i]);
      points.push_back(p);
    }
    const std::vector<double> values = context.Evaluate(points);
    for (std::size_t k = 0; k < units.size(); ++k) {
      bo.Tell(units[k], values[k]);
      if (std::isfinite(values[k]) && (!has_best_ || values[k] > best_value_)) {
        has_best_ = true;
        best_value_ = values[k];
        best_ = points[k];
      }
    }
  }

  // Normalized u in [0, 1] to the parameter's value, never outside [lo, hi].
  static double ToReal(double u, double lo, double hi) {
    if (u >= 1.0) return hi;
    if (u <= 0.0) return lo;
    return std::clamp(lo + u * (hi - lo), lo, hi);
  }

  static double Median(std::vector<double> v) {
    if (v.empty()) return 0.0;
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  }

  void Summary(yamor::plugin::Context& context, const gp::BayesianOptimizer& bo) const {
    std::string text = "bayesopt: " + std::to_string(bo.observations()) + " evaluations (" +
                       std::to_string(bo.failures()) + " failed), " + std::to_string(fit_seconds_.size()) +
                       " proposals; GP fit median " + Number(1e3 * Median(fit_seconds_)) + " ms, max " +
                       Number(1e3 * (fit_seconds_.empty() ? 0.0 : *std::max_element(fit_seconds_.begin(), fit_seconds_.end()))) +
                       " ms; proposal median " + Number(1e3 * Median(ask_seconds_)) + " ms";
    const Eigen::VectorXd l = bo.model().hyperparameters().log_lengthscales.array().exp();
    text += "; length scales (fraction of range)";
    for (std::size_t i = 0; i < n_; ++i) {
      text += std::string(i == 0 ? " " : ", ") + context.Parameter(i).name + "=" + Number(l[static_cast<Eigen::Index>(i)]);
    }
    if (has_best_) {
      text += "; best " + Number(best_value_) + " at";
      for (std::size_t i = 0; i < best_.size(); ++i) {
        text += std::string(i == 0 ? " " : ", ") + context.Parameter(i).name + "=" + Number(best_[i]);
      }
    }
    context.Info(text);
  }

  std::size_t n_ = 0;
  std::vector<double> lower_, upper_;
  std::vector<double> best_;
  double best_value_ = 0.0;
  bool has_best_ = false;
  std::vector<double> fit_seconds_, ask_seconds_;
};

const YamorField kFields[] = {
    {"initial_points", "initial design size, the start included, one batch (0: max(n + 1, 5))",
     YAMOR_FIELD_INTEGER, 0, 100000, "0", nullptr},
    {"include_start", "the configuration's values are the first point of the initial design", YAMOR_FIELD_BOOLEAN,
     0, 0, "true", nullptr},
    {"acquisition", "what each proposal maximizes: log expected improvement or upper confidence bound",
     YAMOR_FIELD_CHOICE, 0, 0, "ei", "ei|ucb"},
    {"kappa", "ucb: mean + kappa * sd", YAMOR_FIELD_REAL, 0.0, 100.0, "2", nullptr},
    {"batch", "points per proposal, one parallel batch (Kriging believer)", YAMOR_FIELD_INTEGER, 1, 1000, "1",
     nullptr},
    {"fit_restarts", "random starts of the hyper-parameter fit besides the previous fit and the prior's mode",
     YAMOR_FIELD_INTEGER, 0, 100, "2", nullptr},
    {"noise_floor", "smallest noise variance, as a fraction of the values' variance", YAMOR_FIELD_REAL, 1e-12, 1.0,
     "1e-6", nullptr},
    {"trust_region", "initial side of the trust region around the best point, fraction of each range (0: none)",
     YAMOR_FIELD_REAL, 0.0, 1.0, "0.2", nullptr},
    {"periodic_phases", "a phase.* parameter ranging over exactly 2 pi wraps around in the model",
     YAMOR_FIELD_BOOLEAN, 0, 0, "true", nullptr},
    {"max_model_points", "most evaluations in the model: the best half and the most recent (0: all; a fit costs n^3)",
     YAMOR_FIELD_INTEGER, 0, 100000, "300", nullptr},
};

}  // namespace
}  // namespace yamor::plugins::bayesopt

YAMOR_OPTIMIZER_PLUGIN(yamor::plugins::bayesopt::BayesOpt, "bayesopt", "1.0.0", "yamor",
                       "Bayesian optimization: Gaussian process (Matern 5/2, ARD, MAP), log EI or UCB, "
                       "Kriging-believer batches; for budgets of tens of evaluations",
                       yamor::plugins::bayesopt::kFields)
