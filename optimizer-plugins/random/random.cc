// The example plugin: random search. Start here to write your own optimizer
// (docs/optimizers.md, "Writing a plugin").
//
// Each iteration draws `batch` points uniformly inside the bounds and
// evaluates them as one batch, so they run in parallel over every host of the
// pool. With `shrink` < 1 the later draws concentrate around the best point
// so far (a box that shrinks by that factor per iteration, never leaving the
// bounds). The run ends when the budget (max_evaluations, a field every
// plugin has) is spent: Context::Evaluate then throws Stopped, which we let
// propagate.
//
// Build it outside the yamor tree with nothing but the header:
//   g++ -std=c++17 -O2 -shared -fPIC -fvisibility=hidden
//       -I<yamor>/optimizer-plugins/include random.cc -o random.so
//   yamor-optimize --plugin ./random.so --list-plugins
#include <algorithm>
#include <cstddef>
#include <string>
#include <vector>

#include "yamor/optimizer_plugin.hpp"

namespace {

// An ordinary C++ class; the framework creates one per run.
class RandomSearch : public yamor::plugin::Optimizer {
 public:
  void Run(yamor::plugin::Context& context) override {
    const std::size_t n = context.Dimension();
    const std::vector<double> lower = context.Lower(), upper = context.Upper();
    const auto batch_size = static_cast<std::size_t>(context.IntField("batch"));
    const double shrink = context.RealField("shrink");

    // The configuration's own values are a candidate too.
    std::vector<double> best_point = context.Start();
    double best = context.Evaluate(best_point);
    double radius = 1.0;  // half-width of the sampling box, as a share of each range

    for (int iteration = 1;; ++iteration) {
      std::vector<std::vector<double>> points(batch_size, std::vector<double>(n));
      for (auto& p : points) {
        for (std::size_t i = 0; i < n; ++i) {
          const double range = upper[i] - lower[i];
          const double lo = std::max(lower[i], best_point[i] - radius * range);
          const double hi = std::min(upper[i], best_point[i] + radius * range);
          p[i] = lo + context.Uniform() * (hi - lo);  // seeded: runs are repeatable
        }
      }
      const std::vector<double> values = context.Evaluate(points);  // one parallel batch
      for (std::size_t k = 0; k < values.size(); ++k) {
        if (values[k] > best) {
          best = values[k];
          best_point = points[k];
        }
      }
      radius *= shrink;
      context.Progress(-1.0, "iteration " + std::to_string(iteration));
      context.Info("iteration " + std::to_string(iteration) + ": best " + std::to_string(best));
    }
  }
};

// The fields users set with --set KEY=VALUE (kind, bounds, default).
const YamorField kFields[] = {
    {"batch", "points per iteration, evaluated in parallel", YAMOR_FIELD_INTEGER, 1, 10000, "16",
     nullptr},
    {"shrink", "sampling box factor per iteration (1: pure random search)", YAMOR_FIELD_REAL, 0.05,
     1.0, "1.0", nullptr},
};

}  // namespace

// Exports the one entry symbol yamor-optimize looks for.
YAMOR_OPTIMIZER_PLUGIN(RandomSearch, "random", "1.0.0", "yamor",
                       "random search in the bounds (the example plugin)", kFields)
