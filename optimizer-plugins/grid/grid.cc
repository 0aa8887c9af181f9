// grid: brute force over chosen parameters at a fixed resolution, the other
// parameters held at their start values — the thesis's landscape of Figure
// 6.3 (64 × 64 points over two parameters, the five others fixed at a
// previously learned gait).
//
// Each swept parameter takes `resolution` regular values from its lower to
// its upper bound, both included. Points are enumerated in a deterministic
// order: the first swept parameter varies slowest, the last fastest (nested
// loops in the order the `parameters` field lists them, or problem order when
// it is empty), and are submitted in batches of `batch` points.
//
// For exactly two swept parameters, `landscape_csv` names a file that
// receives the landscape once the whole grid is evaluated:
//   <first name>,<second name>,value
//   x,y,value            (one row per grid point, in grid order)
// tools/plot/plot_landscape.py draws it as a heatmap.
#include <algorithm>
#include <charconv>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "yamor/optimizer_plugin.hpp"

namespace yamor::plugins::grid {
namespace {

std::string Number(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.6g", v);
  return buffer;
}

// Shortest text that reads back to exactly `v` (the CSV must round-trip).
std::string Exact(double v) {
  char buffer[64];
  auto [end, ec] = std::to_chars(buffer, buffer + sizeof(buffer), v);
  if (ec != std::errc()) return Number(v);
  return std::string(buffer, end);
}

std::string Trim(const std::string& s) {
  const auto first = s.find_first_not_of(" \t");
  if (first == std::string::npos) return "";
  return s.substr(first, s.find_last_not_of(" \t") - first + 1);
}

std::string CsvCell(const std::string& text) {
  if (text.find_first_of(",\"\n") == std::string::npos) return text;
  std::string out = "\"";
  for (char c : text) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + "\"";
}

class Grid : public yamor::plugin::Optimizer {
 public:
  void Run(yamor::plugin::Context& context) override {
    const std::vector<double> lower = context.Lower(), upper = context.Upper();
    const std::vector<std::size_t> swept = SweptParameters(context);
    const auto resolution = static_cast<std::size_t>(context.IntField("resolution"));
    const auto batch_size = static_cast<std::size_t>(context.IntField("batch"));
    const std::string landscape = context.Field("landscape_csv");
    if (!landscape.empty() && swept.size() != 2) {
      throw std::invalid_argument("landscape_csv needs exactly two swept parameters, 'parameters' names " +
                                  std::to_string(swept.size()));
    }

    // Total points, saturating (the budget ends a sweep too large to finish).
    constexpr unsigned long long kHuge = 1ULL << 62;
    unsigned long long total = 1;
    for (std::size_t k = 0; k < swept.size(); ++k) {
      total = total > kHuge / resolution ? kHuge : total * resolution;
    }
    const long long budget = context.IntField("max_evaluations");
    if (total > static_cast<unsigned long long>(budget)) {
      context.Log(YAMOR_LOG_WARNING, "grid: " + std::to_string(total) + " points but max_evaluations is " +
                                         std::to_string(budget) + ": only the first " +
                                         std::to_string(budget) + " will be evaluated");
    }

    // Grid values per swept parameter; the last one exactly the upper bound.
    std::vector<std::vector<double>> axis(swept.size());
    for (std::size_t k = 0; k < swept.size(); ++k) {
      const std::size_t i = swept[k];
      for (std::size_t j = 0; j < resolution; ++j) {
        const double v = j + 1 == resolution
                             ? upper[i]
                             : lower[i] + (upper[i] - lower[i]) * static_cast<double>(j) /
                                              static_cast<double>(resolution - 1);
        axis[k].push_back(std::clamp(v, lower[i], upper[i]));
      }
    }

    const std::vector<double> start = context.Start();
    std::vector<std::size_t> digits(swept.size(), 0);  // mixed-radix counter
    std::vector<double> landscape_values;
    std::vector<std::vector<double>> landscape_points;
    unsigned long long done = 0;
    bool has_best = false;
    double best_value = 0.0;
    std::vector<double> best;
    try {
      while (done < total) {
        // Never more than the budget allows: a huge grid with batch 0 must
        // not allocate points that will not be evaluated.
        const unsigned long long allowed =
            done < static_cast<unsigned long long>(budget) ? static_cast<unsigned long long>(budget) - done : 1;
        const unsigned long long count = std::min<unsigned long long>(
            {batch_size == 0 ? total : batch_size, total - done, allowed});
        std::vector<std::vector<double>> batch;
        batch.reserve(static_cast<std::size_t>(count));
        for (unsigned long long c = 0; c < count; ++c) {
          std::vector<double> point = start;
          for (std::size_t k = 0; k < swept.size(); ++k) point[swept[k]] = axis[k][digits[k]];
          batch.push_back(std::move(point));
          for (std::size_t k = swept.size(); k-- > 0;) {  // last varies fastest
            if (++digits[k] < resolution) break;
            digits[k] = 0;
          }
        }
        const std::vector<double> values = context.Evaluate(batch);
        for (std::size_t c = 0; c < values.size(); ++c) {
          if (!has_best || values[c] > best_value) {
            has_best = true;
            best_value = values[c];
            best = batch[c];
          }
          if (!landscape.empty()) {
            landscape_points.push_back({batch[c][swept[0]], batch[c][swept[1]]});
            landscape_values.push_back(values[c]);
          }
        }
        done += count;
        context.Progress(static_cast<double>(done) / static_cast<double>(total),
                         std::to_string(done) + "/" + std::to_string(total) + " points, best " +
                             Number(best_value));
      }
    } catch (const yamor::plugin::Stopped&) {
      if (!landscape.empty()) {
        context.Log(YAMOR_LOG_WARNING, "grid: stopped after " + std::to_string(done) + " of " +
                                           std::to_string(total) + " points; " + landscape +
                                           " not written");
      }
      Summary(context, done, total, has_best, best_value, best);
      throw;
    }
    if (!landscape.empty()) {
      WriteLandscape(landscape, context.Parameter(swept[0]).name, context.Parameter(swept[1]).name,
                     landscape_points, landscape_values);
    }
    Summary(context, done, total, has_best, best_value, best);
  }

 private:
  // The parameters the `parameters` field names (all when empty), in the
  // order given.
  static std::vector<std::size_t> SweptParameters(yamor::plugin::Context& context) {
    const std::string text = context.Field("parameters");
    std::vector<std::size_t> swept;
    if (Trim(text).empty()) {
      for (std::size_t i = 0; i < context.Dimension(); ++i) swept.push_back(i);
      return swept;
    }
    std::size_t from = 0;
    while (from <= text.size()) {
      const std::size_t comma = std::min(text.find(',', from), text.size());
      const std::string name = Trim(text.substr(from, comma - from));
      from = comma + 1;
      if (name.empty()) {
        throw std::invalid_argument("parameters '" + text + "' has an empty name");
      }
      std::size_t found = context.Dimension();
      for (std::size_t i = 0; i < context.Dimension(); ++i) {
        if (name == context.Parameter(i).name) found = i;
      }
      if (found == context.Dimension()) {
        std::string known;
        for (std::size_t i = 0; i < context.Dimension(); ++i) {
          known += std::string(i == 0 ? "" : ", ") + context.Parameter(i).name;
        }
        throw std::invalid_argument("parameters names '" + name +
                                    "', which is not an optimized parameter (they are: " + known + ")");
      }
      if (std::find(swept.begin(), swept.end(), found) != swept.end()) {
        throw std::invalid_argument("parameters names '" + name + "' twice");
      }
      swept.push_back(found);
    }
    return swept;
  }

  static void WriteLandscape(const std::string& path, const std::string& x_name, const std::string& y_name,
                             const std::vector<std::vector<double>>& points,
                             const std::vector<double>& values) {
    const std::filesystem::path target(path);
    if (target.has_parent_path()) {
      std::error_code ec;
      std::filesystem::create_directories(target.parent_path(), ec);
    }
    // Written beside the target and renamed: a reader never sees half a file.
    const std::string temporary = path + ".tmp";
    {
      std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
      out << CsvCell(x_name) << ',' << CsvCell(y_name) << ",value\n";
      for (std::size_t k = 0; k < values.size(); ++k) {
        out << Exact(points[k][0]) << ',' << Exact(points[k][1]) << ',' << Exact(values[k]) << '\n';
      }
      out.flush();
      if (!out) throw std::runtime_error("landscape_csv: cannot write " + temporary);
    }
    std::error_code ec;
    std::filesystem::rename(temporary, target, ec);
    if (ec) throw std::runtime_error("landscape_csv: cannot rename " + temporary + " to " + path + ": " +
                                     ec.message());
  }

  static void Summary(yamor::plugin::Context& context, unsigned long long done, unsigned long long total,
                      bool has_best, double best_value, const std::vector<double>& best) {
    // A batch cut short by the budget never reaches the plugin: `done` and
    // the best count complete batches.
    std::string text = "grid: " + std::to_string(done) + " of " + std::to_string(total) +
                       " points in complete batches";
    if (has_best) {
      text += ", best " + Number(best_value) + " at";
      for (std::size_t i = 0; i < best.size(); ++i) {
        text += std::string(i == 0 ? " " : ", ") + context.Parameter(i).name + "=" + Number(best[i]);
      }
    }
    context.Info(text);
  }
};

const YamorField kFields[] = {
    {"parameters", "comma-separated parameter names to sweep (empty: all); others stay at their start",
     YAMOR_FIELD_TEXT, 0, 0, "", nullptr},
    {"resolution", "grid points per swept parameter, bounds included", YAMOR_FIELD_INTEGER, 2, 100000, "8",
     nullptr},
    {"batch", "points per parallel batch (0: the whole grid at once)", YAMOR_FIELD_INTEGER, 0, 1e9, "256",
     nullptr},
    {"landscape_csv", "two swept parameters: write x,y,value rows here (empty: do not)", YAMOR_FIELD_FILE, 0,
     0, "", nullptr},
};

}  // namespace
}  // namespace yamor::plugins::grid

YAMOR_OPTIMIZER_PLUGIN(yamor::plugins::grid::Grid, "grid", "1.0.0", "yamor",
                       "brute force over chosen parameters at a resolution; landscape CSV for two",
                       yamor::plugins::grid::kFields)
