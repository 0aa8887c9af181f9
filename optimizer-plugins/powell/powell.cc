// The `powell` optimizer plugin: Powell's direction-set method over the
// parameter box with the thesis's bound handling variants (6.2.2–6.2.5) and
// statistics-based direction ordering (6.4). The algorithm lives in
// powell_core.h; this file maps the plugin's fields and context onto it.
#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "optimizer-plugins/powell/powell_core.h"
#include "yamor/optimizer_plugin.hpp"

namespace yamor::plugins::powell {
namespace {

std::string Short(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.6g", v);
  return buffer;
}

class PowellOptimizer : public yamor::plugin::Optimizer {
 public:
  void Run(yamor::plugin::Context& context) override {
    const std::size_t n = context.Dimension();
    std::vector<std::string> names;
    for (std::size_t i = 0; i < n; ++i) names.emplace_back(context.Parameter(i).name);

    Options options;
    options.lower = context.Lower();
    options.upper = context.Upper();
    options.start = ParseStart(context.Field("start"), options.lower, options.upper, names, context.Start());
    options.line_search = ParseLineSearch(context.Field("line_search"));
    options.bounds = ParseBounds(context.Field("bounds"));
    options.direction_order = ParseDirectionOrder(context.Field("direction_order"));
    options.replace_directions = context.BoolField("replace_directions");
    options.tolerance = context.RealField("tolerance");
    options.max_iterations = static_cast<int>(context.IntField("max_iterations"));
    options.step = context.RealField("step");
    options.line_tolerance = context.RealField("line_tolerance");
    options.interval_points = static_cast<int>(context.IntField("interval_points"));
    options.refine_points = static_cast<int>(context.IntField("refine_points"));
    options.interval_refinements = static_cast<int>(context.IntField("interval_refinements"));
    options.bad_value = context.RealField("bad_value");
    options.malus = context.RealField("malus");

    const long long budget = std::max(1LL, context.IntField("max_evaluations"));
    long long used = 0;
    int iteration = 1;
    auto evaluate = [&](const std::vector<std::vector<double>>& points) {
      std::vector<double> values = context.Evaluate(points);  // throws Stopped: let it pass
      used += static_cast<long long>(points.size());
      context.Progress(std::min(1.0, static_cast<double>(used) / static_cast<double>(budget)),
                       "iteration " + std::to_string(iteration));
      return values;
    };
    Powell powell(options, evaluate, [&context] { return context.Uniform(); });

    // Axis directions carry their parameter's name, new ones "d<id>".
    // (Appends, not "literal" + string: g++ 12 -Wrestrict false positive.)
    auto direction_name = [&](int id) {
      if (id < static_cast<int>(n)) return names[static_cast<std::size_t>(id)];
      std::string name = "d";
      name += std::to_string(id);
      return name;
    };
    powell.OnIteration([&](const IterationReport& r) {
      std::string text = "iteration ";
      text += std::to_string(r.iteration);
      text += ": best ";
      text += Short(r.value);
      text += " (+";
      text += Short(r.improvement);
      text += ") at ";
      for (std::size_t i = 0; i < n; ++i) {
        if (i > 0) text += ", ";
        text += names[i];
        text += '=';
        text += Short(r.point[i]);
      }
      text += "; ";
      text += std::to_string(r.evaluations);
      text += " evaluations; directions";
      for (std::size_t k = 0; k < r.order.size(); ++k) {
        text += ' ';
        text += direction_name(r.order[k]);
        text += "(+";
        text += Short(r.gains[k]);
        text += ')';
      }
      if (r.direction_replaced) {
        text += "; new direction ";
        text += direction_name(r.order.back());
        text += " entered the set";
      }
      if (r.converged) text += "; converged";
      context.Info(text);
      iteration = r.iteration + 1;
    });
    powell.OnWarning([&context](const std::string& message) { context.Log(YAMOR_LOG_WARNING, message); });

    const Result result = powell.Run();
    context.Progress(1.0, result.converged ? "converged" : "max_iterations reached");
    context.Info(std::string(result.converged ? "converged" : "max_iterations reached") + " after " +
                 std::to_string(result.iterations) + " iterations and " +
                 std::to_string(result.evaluations) + " evaluations: best " + Short(result.value) +
                 ", " + std::to_string(result.directions_replaced) + " direction(s) replaced");
  }
};

const YamorField kFields[] = {
    {"start", "start point: comma-separated values in parameter order (empty: the configuration's values)",
     YAMOR_FIELD_TEXT, 0, 0, "", nullptr},
    {"line_search", "brent: bracketing + Brent; interval: regular grid then finer points (thesis 6.2.5)",
     YAMOR_FIELD_CHOICE, 0, 0, "brent", "brent|interval"},
    {"bounds", "outside the box: constant bad value, stadium slope (6.2.3), or easy-direction (6.2.4)",
     YAMOR_FIELD_CHOICE, 0, 0, "constant", "constant|stadium|easy-direction"},
    {"bad_value", "constant/easy-direction: value of points outside the box (below any real value)",
     YAMOR_FIELD_REAL, -1e12, 1e12, "-1", nullptr},
    {"malus", "stadium: value lost per normalized unit of distance outside the box", YAMOR_FIELD_REAL,
     1e-9, 1e12, "1", nullptr},
    {"direction_order", "fixed: the set's order; statistics: most productive directions first (6.4)",
     YAMOR_FIELD_CHOICE, 0, 0, "fixed", "fixed|statistics"},
    {"replace_directions", "apply Powell's direction replacement (false: search the axes only)",
     YAMOR_FIELD_BOOLEAN, 0, 0, "true", nullptr},
    {"tolerance", "converged when an iteration's directions gain <= tolerance * max(1, |value|)",
     YAMOR_FIELD_REAL, 0.0, 1e6, "0.0001", nullptr},
    {"max_iterations", "iteration cap", YAMOR_FIELD_INTEGER, 1, 1000000, "100", nullptr},
    {"step", "brent: first bracketing step as a fraction of the range, times a random 0.5..1.5",
     YAMOR_FIELD_REAL, 1e-6, 1.0, "0.1", nullptr},
    {"line_tolerance", "brent: accuracy of a line search as a fraction of the range", YAMOR_FIELD_REAL,
     1e-9, 0.5, "0.001", nullptr},
    {"interval_points", "interval: points of the first grid over the whole line (one batch)",
     YAMOR_FIELD_INTEGER, 2, 10000, "10", nullptr},
    {"refine_points", "interval: new points per refinement around the best (one batch)",
     YAMOR_FIELD_INTEGER, 1, 10000, "5", nullptr},
    {"interval_refinements", "interval: refinement rounds, each at a smaller interval",
     YAMOR_FIELD_INTEGER, 0, 1000, "1", nullptr},
};

}  // namespace
}  // namespace yamor::plugins::powell

YAMOR_OPTIMIZER_PLUGIN(yamor::plugins::powell::PowellOptimizer, "powell", "1.0.0", "yamor",
                       "Powell's direction-set method with bounded variants (thesis 6.2)",
                       yamor::plugins::powell::kFields)
