// A small but real test optimizer: compass search. Each iteration evaluates
// the 2·n neighbours of the best point at the current step as one batch,
// moves to the best improvement, or halves the step. Used to test the
// framework end to end (fields, batches, budget, random, progress).
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "yamor/optimizer_plugin.hpp"

namespace {

class CompassSearch : public yamor::plugin::Optimizer {
 public:
  void Run(yamor::plugin::Context& context) override {
    const std::size_t n = context.Dimension();
    const std::vector<double> lower = context.Lower(), upper = context.Upper();
    std::vector<double> x = context.Start();
    if (context.BoolField("random_start")) {
      for (std::size_t i = 0; i < n; ++i) x[i] = lower[i] + context.Uniform() * (upper[i] - lower[i]);
    }
    double step = context.RealField("step");
    const double tolerance = context.RealField("tolerance");
    double best = context.Evaluate(x);
    while (step > tolerance) {
      std::vector<std::vector<double>> batch;
      for (std::size_t i = 0; i < n; ++i) {
        for (double sign : {-1.0, 1.0}) {
          std::vector<double> y = x;
          y[i] = std::clamp(y[i] + sign * step * (upper[i] - lower[i]), lower[i], upper[i]);
          batch.push_back(y);
        }
      }
      const std::vector<double> values = context.Evaluate(batch);
      const auto it = std::max_element(values.begin(), values.end());
      if (*it > best) {
        best = *it;
        x = batch[static_cast<std::size_t>(it - values.begin())];
      } else {
        step /= 2.0;
      }
      context.Progress(-1.0, "step " + std::to_string(step));
    }
    context.Info("converged at " + std::to_string(best));
  }
};

const YamorField kFields[] = {
    {"step", "initial step, as a fraction of each range", YAMOR_FIELD_REAL, 1e-6, 1.0, "0.25", nullptr},
    {"tolerance", "stop when the step falls below", YAMOR_FIELD_REAL, 1e-12, 1.0, "0.001", nullptr},
    {"random_start", "start at a random point instead of the start values", YAMOR_FIELD_BOOLEAN, 0, 0,
     "false", nullptr},
    {"mode", "unused choice (tests)", YAMOR_FIELD_CHOICE, 0, 0, "a", "a|b|c"},
};

}  // namespace

YAMOR_OPTIMIZER_PLUGIN(CompassSearch, "compass", "1.0.0", "yamor tests", "compass search (test plugin)",
                       kFields)
