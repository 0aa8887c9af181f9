// pso: particle swarm optimization (global-best topology) inside the
// problem's box. The thesis (6.2) found PSO slower than Powell but "highly
// parallelizable because all the particles can be computed in parallel":
// each iteration's swarm is submitted as ONE batch, so a host pool of at
// least swarm_size workers evaluates an iteration in the time of one walk.
//
// Velocity update (synchronous, per dimension, r1 and r2 uniform in [0, 1)):
//   v <- inertia*v + cognitive*r1*(personal best - x) + social*r2*(swarm best - x)
// then |v_i| <= max_velocity * (range of parameter i) (one field fits
// parameters of different units), x <- x + v, and a particle leaving the box
// is clamped onto its face (velocity component zeroed) or reflected back
// into it (velocity component reversed), as the `boundary` field says.
// Clamping is the default: it samples the faces exactly, where gait optima
// often lie (largest amplitudes), and found a boundary optimum in 1000
// evaluations where reflection needed 4000, with the same success on 2-D
// Rastrigin (40 seeds each; docs/optimizers.md).
// Positions stay in parameter units, so the start particle is the start
// exactly.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "yamor/optimizer_plugin.hpp"

namespace yamor::plugins::pso {
namespace {

using Point = std::vector<double>;

std::string Number(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.6g", v);
  return buffer;
}

class ParticleSwarm : public yamor::plugin::Optimizer {
 public:
  void Run(yamor::plugin::Context& context) override {
    const std::size_t n = context.Dimension();
    lower_ = context.Lower();
    upper_ = context.Upper();
    const std::size_t swarm = static_cast<std::size_t>(context.IntField("swarm_size"));
    const double inertia = context.RealField("inertia");
    const double cognitive = context.RealField("cognitive");
    const double social = context.RealField("social");
    std::vector<double> vmax(n);
    for (std::size_t i = 0; i < n; ++i) {
      vmax[i] = context.RealField("max_velocity") * (upper_[i] - lower_[i]);
    }
    const bool reflect = context.Field("boundary") == "reflect";
    const long long max_iterations = context.IntField("max_iterations");
    const long long budget = context.IntField("max_evaluations");

    // Initial swarm: uniform in the box, particle 0 optionally at the
    // configuration's start (a previously learned gait is a good particle).
    std::vector<Point> x(swarm, Point(n)), v(swarm, Point(n));
    const Point start = context.Start();
    const bool include_start = context.BoolField("include_start");
    for (std::size_t k = 0; k < swarm; ++k) {
      for (std::size_t i = 0; i < n; ++i) x[k][i] = (k == 0 && include_start) ? start[i] : Draw(context, i);
    }
    // Half the way to another random point: first moves on the box's scale.
    for (std::size_t k = 0; k < swarm; ++k) {
      for (std::size_t i = 0; i < n; ++i) {
        v[k][i] = std::clamp((Draw(context, i) - x[k][i]) / 2.0, -vmax[i], vmax[i]);
      }
    }

    std::vector<Point> personal = x;
    std::vector<double> personal_value(swarm, 0.0);
    long long iteration = 0;
    try {
      while (true) {
        const std::vector<double> values = context.Evaluate(x);
        ++iteration;
        for (std::size_t k = 0; k < swarm; ++k) {
          if (iteration == 1 || values[k] > personal_value[k]) {
            personal_value[k] = values[k];
            personal[k] = x[k];
          }
          if (!has_best_ || values[k] > best_value_) {
            has_best_ = true;
            best_value_ = values[k];
            best_ = x[k];
          }
        }
        const double fraction =
            max_iterations > 0
                ? static_cast<double>(iteration) / static_cast<double>(max_iterations)
                : static_cast<double>(iteration) * static_cast<double>(swarm) / static_cast<double>(budget);
        context.Progress(std::min(fraction, 1.0),
                         "iteration " + std::to_string(iteration) + ", best " + Number(best_value_));
        if (max_iterations > 0 && iteration >= max_iterations) break;

        for (std::size_t k = 0; k < swarm; ++k) {
          for (std::size_t i = 0; i < n; ++i) {
            const double r1 = context.Uniform(), r2 = context.Uniform();
            double vi = inertia * v[k][i] + cognitive * r1 * (personal[k][i] - x[k][i]) +
                        social * r2 * (best_[i] - x[k][i]);
            vi = std::clamp(vi, -vmax[i], vmax[i]);
            const double lo = lower_[i], hi = upper_[i];
            double xi = x[k][i] + vi;
            if (xi < lo || xi > hi) {
              if (reflect) {
                // |v| <= the range, so one mirror image lands inside; the
                // clamp only guards against rounding.
                xi = xi < lo ? lo + (lo - xi) : hi - (xi - hi);
                vi = -vi;
              } else {
                vi = 0.0;
              }
              xi = std::clamp(xi, lo, hi);
            }
            x[k][i] = xi;
            v[k][i] = vi;
          }
        }
      }
    } catch (const yamor::plugin::Stopped&) {
      Summary(context, iteration, swarm, true);
      throw;
    }
    Summary(context, iteration, swarm, false);
  }

 private:
  // Uniform in parameter i's range.
  double Draw(yamor::plugin::Context& context, std::size_t i) const {
    return std::clamp(lower_[i] + context.Uniform() * (upper_[i] - lower_[i]), lower_[i], upper_[i]);
  }

  // `stopped`: the budget may have cut a last batch short; its values never
  // reach the plugin, so the best named here is that of complete iterations.
  void Summary(yamor::plugin::Context& context, long long iterations, std::size_t swarm, bool stopped) const {
    std::string text = "pso: " + std::to_string(iterations) + " complete iterations of " +
                       std::to_string(swarm) + " particles";
    if (has_best_) {
      text += std::string(stopped ? ", best of those " : ", best ") + Number(best_value_) + " at";
      for (std::size_t i = 0; i < best_.size(); ++i) {
        text += std::string(i == 0 ? " " : ", ") + context.Parameter(i).name + "=" + Number(best_[i]);
      }
    }
    context.Info(text);
  }

  Point lower_, upper_;
  Point best_;
  double best_value_ = 0.0;
  bool has_best_ = false;
};

const YamorField kFields[] = {
    {"swarm_size", "particles per iteration (one parallel batch)", YAMOR_FIELD_INTEGER, 2, 10000, "20",
     nullptr},
    {"inertia", "inertia weight w of the velocity", YAMOR_FIELD_REAL, 0.0, 1.5, "0.7298", nullptr},
    {"cognitive", "attraction c1 to the particle's own best", YAMOR_FIELD_REAL, 0.0, 4.0, "1.49618",
     nullptr},
    {"social", "attraction c2 to the swarm's best", YAMOR_FIELD_REAL, 0.0, 4.0, "1.49618", nullptr},
    {"max_velocity", "velocity clamp per step, as a fraction of each parameter's range",
     YAMOR_FIELD_REAL, 0.001, 1.0, "0.2", nullptr},
    {"boundary", "a particle leaving the box is clamped onto it or reflected back", YAMOR_FIELD_CHOICE,
     0, 0, "clamp", "clamp|reflect"},
    {"include_start", "particle 0 starts at the configuration's values", YAMOR_FIELD_BOOLEAN, 0, 0,
     "true", nullptr},
    {"max_iterations", "stop after this many iterations (0: run until the budget)",
     YAMOR_FIELD_INTEGER, 0, 1e9, "0", nullptr},
};

}  // namespace
}  // namespace yamor::plugins::pso

YAMOR_OPTIMIZER_PLUGIN(yamor::plugins::pso::ParticleSwarm, "pso", "1.0.0", "yamor",
                       "particle swarm with bounds; each iteration's particles are one parallel batch",
                       yamor::plugins::pso::kFields)
