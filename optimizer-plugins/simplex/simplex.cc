// simplex: bounded Nelder–Mead through NLopt (NLOPT_LN_NELDERMEAD, Debian's
// libnlopt), maximizing. NLopt asks for one point at a time, so this plugin
// is sequential: every evaluation is a batch of one (the thesis, 6.2, tried
// simplex and found it behind Powell; it is here for comparison).
//
// NLopt works on the parameter values themselves (so the start is evaluated
// exactly); initial_step and xtol are fractions of each parameter's range,
// handed to NLopt per parameter. Points NLopt proposes are clamped into the
// box before evaluation: NLopt keeps its simplex inside the bounds, but a
// reflection or contraction step could round a hair past one.
//
// The budget: when Context::Evaluate throws Stopped inside the objective,
// the objective forces NLopt to stop (nlopt_force_stop; exceptions must not
// cross NLopt's C frames) and Stopped is rethrown once nlopt_optimize has
// returned. Other errors travel the same way.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlopt.h>

#include "yamor/optimizer_plugin.hpp"

namespace yamor::plugins::simplex {
namespace {

std::string Number(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.6g", v);
  return buffer;
}

// What the objective callback needs; lives on Run's stack.
struct Objective {
  yamor::plugin::Context* context = nullptr;
  nlopt_opt opt = nullptr;
  std::vector<double> lower, upper;
  long long budget = 1;
  long long evaluations = 0;
  bool stopped = false;
  std::exception_ptr error;
  bool has_best = false;
  double best_value = 0.0;
  std::vector<double> best;

  // NLopt's point, clamped into the bounds.
  std::vector<double> Inside(const double* u) const {
    std::vector<double> x(lower.size());
    for (std::size_t i = 0; i < x.size(); ++i) {
      if (!std::isfinite(u[i])) throw std::runtime_error("NLopt proposed a non-finite point");
      x[i] = std::clamp(u[i], lower[i], upper[i]);
    }
    return x;
  }

  static double Call(unsigned n, const double* u, double* gradient, void* data) {
    auto& self = *static_cast<Objective*>(data);
    (void)n;
    (void)gradient;  // derivative-free: NLopt passes NULL
    if (self.stopped || self.error) {
      nlopt_force_stop(self.opt);
      return -HUGE_VAL;
    }
    try {
      const std::vector<double> x = self.Inside(u);
      const double value = self.context->Evaluate(x);
      ++self.evaluations;
      if (!self.has_best || value > self.best_value) {
        self.has_best = true;
        self.best_value = value;
        self.best = x;
      }
      self.context->Progress(
          std::min(1.0, static_cast<double>(self.evaluations) / static_cast<double>(self.budget)),
          "evaluation " + std::to_string(self.evaluations) + ", best " + Number(self.best_value));
      return value;
    } catch (const yamor::plugin::Stopped&) {
      self.stopped = true;
    } catch (...) {
      self.error = std::current_exception();
    }
    nlopt_force_stop(self.opt);
    return -HUGE_VAL;
  }
};

class Simplex : public yamor::plugin::Optimizer {
 public:
  void Run(yamor::plugin::Context& context) override {
    const auto n = static_cast<unsigned>(context.Dimension());
    Objective objective;
    objective.context = &context;
    objective.lower = context.Lower();
    objective.upper = context.Upper();
    objective.budget = context.IntField("max_evaluations");

    std::unique_ptr<nlopt_opt_s, decltype(&nlopt_destroy)> opt(nlopt_create(NLOPT_LN_NELDERMEAD, n),
                                                               &nlopt_destroy);
    if (!opt) throw std::runtime_error("nlopt_create failed (out of memory)");
    objective.opt = opt.get();
    std::vector<double> step(n), xtol(n);
    for (unsigned i = 0; i < n; ++i) {
      const double range = objective.upper[i] - objective.lower[i];
      step[i] = context.RealField("initial_step") * range;
      xtol[i] = context.RealField("xtol") * range;
    }
    Check(nlopt_set_lower_bounds(opt.get(), objective.lower.data()), "lower bounds");
    Check(nlopt_set_upper_bounds(opt.get(), objective.upper.data()), "upper bounds");
    Check(nlopt_set_max_objective(opt.get(), &Objective::Call, &objective), "objective");
    Check(nlopt_set_initial_step(opt.get(), step.data()), "initial_step");
    Check(nlopt_set_xtol_abs(opt.get(), xtol.data()), "xtol");
    Check(nlopt_set_ftol_abs(opt.get(), context.RealField("ftol")), "ftol");

    std::vector<double> x = context.Start();
    double value = 0.0;
    const nlopt_result result = nlopt_optimize(opt.get(), x.data(), &value);

    const std::string how = objective.stopped ? "budget or stop" : nlopt_result_to_string(result);
    std::string text = "simplex: " + std::to_string(objective.evaluations) + " evaluations, nlopt " + how;
    if (objective.has_best) {
      text += ", best " + Number(objective.best_value) + " at";
      for (unsigned i = 0; i < n; ++i) {
        text += std::string(i == 0 ? " " : ", ") + context.Parameter(i).name + "=" + Number(objective.best[i]);
      }
    }
    context.Info(text);
    if (objective.error) std::rethrow_exception(objective.error);
    if (objective.stopped) throw yamor::plugin::Stopped();
    if (result == NLOPT_ROUNDOFF_LIMITED) {
      context.Log(YAMOR_LOG_WARNING, "simplex: NLopt stopped on round-off; the best point is kept");
    } else if (result < 0) {
      throw std::runtime_error(std::string("NLopt Nelder-Mead failed: ") + nlopt_result_to_string(result));
    }
  }

 private:
  static void Check(nlopt_result result, const char* what) {
    if (result < 0) {
      throw std::invalid_argument(std::string("NLopt refused ") + what + ": " + nlopt_result_to_string(result));
    }
  }
};

const YamorField kFields[] = {
    {"initial_step", "initial simplex edge, as a fraction of each parameter's range", YAMOR_FIELD_REAL, 1e-6,
     1.0, "0.1", nullptr},
    {"xtol", "stop when a step moves every parameter less than this (fraction of range; 0: never)",
     YAMOR_FIELD_REAL, 0.0, 1.0, "1e-4", nullptr},
    {"ftol", "stop when a step changes the value less than this (absolute; 0: never)", YAMOR_FIELD_REAL, 0.0,
     1e9, "1e-8", nullptr},
};

}  // namespace
}  // namespace yamor::plugins::simplex

YAMOR_OPTIMIZER_PLUGIN(yamor::plugins::simplex::Simplex, "simplex", "1.0.0", "yamor",
                       "bounded Nelder-Mead through NLopt; sequential, one point per evaluation",
                       yamor::plugins::simplex::kFields)
