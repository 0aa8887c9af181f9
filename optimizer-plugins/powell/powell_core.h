// Powell's direction-set method maximizing a function over a box (thesis
// 6.2.2–6.2.5, 6.4), independent of the plugin ABI so that it can be unit
// tested with any evaluation callback (and reused by other plugins).
//
// Points are kept in real coordinates (so the start point is evaluated
// exactly as given); directions are expressed in normalized units, where
// every parameter's range has length 1, so a unit direction along a
// parameter spans its whole range and step sizes are fractions of ranges.
#pragma once

#include <functional>
#include <map>
#include <string>
#include <vector>

namespace yamor::plugins::powell {

/// How a direction's maximum is searched.
enum class LineSearch {
  kBrent,    ///< Golden-section bracketing from a random step, then Brent.
  kInterval  ///< Regular grid over the valid segment, then finer points (6.2.5).
};

/// What a line search sees outside the box (never simulated).
enum class Bounds {
  kConstant,      ///< A constant bad value (thesis Figure 6.4).
  kStadium,       ///< The border value minus a malus growing with distance (6.2.3).
  kEasyDirection  ///< Constant, but a new direction's requests are clamped (6.2.4).
};

/// The order in which each iteration searches its directions.
enum class DirectionOrder {
  kFixed,      ///< Always the set's order.
  kStatistics  ///< Most productive first (6.4), see Powell.
};

/// How a Powell run behaves; the plugin fills it from its fields.
struct Options {
  std::vector<double> lower;  ///< Lower bounds (real units), finite.
  std::vector<double> upper;  ///< Upper bounds (real units), > lower.
  std::vector<double> start;  ///< Start point (real units), inside the box.
  LineSearch line_search = LineSearch::kBrent;     ///< Line search method.
  Bounds bounds = Bounds::kConstant;               ///< Outside-the-box handling.
  DirectionOrder direction_order = DirectionOrder::kFixed;  ///< Direction order.
  bool replace_directions = true;  ///< Apply Powell's replacement rule (false: fixed axes).
  double tolerance = 1e-4;         ///< Converged when a sweep gains <= tolerance·max(1, |f|).
  int max_iterations = 100;        ///< Iteration cap.
  double step = 0.1;               ///< Brent: first bracketing step (normalized), times U[0.5, 1.5).
  double line_tolerance = 1e-3;    ///< Brent: absolute tolerance on the line (normalized).
  int interval_points = 10;        ///< Interval: grid points over the segment (>= 2).
  int refine_points = 5;           ///< Interval: new points per refinement (>= 1).
  int interval_refinements = 1;    ///< Interval: refinement rounds (>= 0).
  double bad_value = -1.0;         ///< Constant/easy: value outside the box.
  double malus = 1.0;              ///< Stadium: value lost per normalized distance outside.
};

/// What one iteration did (for logs and tests).
struct IterationReport {
  int iteration = 0;                ///< 1-based.
  double value = 0.0;               ///< Best value after the iteration.
  double improvement = 0.0;         ///< Gain of the whole iteration (>= 0).
  std::vector<double> point;        ///< Best point after the iteration (real units).
  long long evaluations = 0;        ///< Points submitted so far (cache misses).
  bool direction_replaced = false;  ///< A new direction entered the set.
  bool converged = false;           ///< This iteration met the tolerance.
  std::vector<int> order;           ///< Direction ids in the order searched (< n: axis i).
  std::vector<double> gains;        ///< Gain of each search, same order as `order`.
};

/// How a run ended.
struct Result {
  std::vector<double> point;  ///< Best point (real units).
  double value = 0.0;         ///< Its value.
  int iterations = 0;         ///< Iterations run.
  bool converged = false;     ///< Tolerance met (false: max_iterations reached).
  int directions_replaced = 0;  ///< New directions that entered the set.
  long long evaluations = 0;  ///< Points submitted (cache misses).
};

/// Powell's method, maximizing over a box, with the thesis's bound handling
/// variants. The evaluation callback receives batches of points (real units,
/// all inside the box) and returns one value per point; an exception it
/// throws (e.g. the plugin ABI's Stopped when the budget is spent) ends Run.
/// Identical points are evaluated once (a cache keyed by the exact point).
///
/// Direction statistics (DirectionOrder::kStatistics): each direction keeps
/// a score; after every iteration, each searched direction's score becomes
/// 0.5·score + its gain in that iteration (a new direction starts with the
/// gain of its first search); each iteration searches the directions by
/// decreasing score, ties in the previous order.
///
/// Thread safety: not thread-safe; one object per run, used by one thread.
class Powell {
 public:
  /// Evaluates a batch of points (real units); one value per point.
  using BatchFunction = std::function<std::vector<double>(const std::vector<std::vector<double>>&)>;
  /// A uniform number in [0, 1) from the run's seeded generator.
  using UniformFunction = std::function<double()>;
  /// Called after every iteration.
  using IterationCallback = std::function<void(const IterationReport&)>;
  /// Receives warnings (e.g. bad_value not below the evaluated values).
  using WarningCallback = std::function<void(const std::string&)>;

  /// Checks `options` (std::invalid_argument naming the bad value).
  Powell(Options options, BatchFunction evaluate, UniformFunction uniform);
  ~Powell();
  Powell(const Powell&) = delete;
  Powell& operator=(const Powell&) = delete;

  /// Sets the per-iteration callback.
  void OnIteration(IterationCallback callback) { on_iteration_ = std::move(callback); }
  /// Sets the warning callback.
  void OnWarning(WarningCallback callback) { on_warning_ = std::move(callback); }

  /// Runs to convergence or max_iterations; exceptions of the callbacks pass through.
  Result Run();

 private:
  using Point = std::vector<double>;
  struct Direction {
    std::vector<double> v;  // normalized units, unit length
    int id = 0;
    double score = 0.0;
  };
  struct Found {
    Point point;
    double value = 0.0;
  };
  class LineProbe;

  double Evaluate(const Point& x);
  std::vector<double> EvaluateBatch(const std::vector<Point>& points);
  bool Cached(const Point& x) const { return cache_.count(x) != 0; }
  Found LineMaximum(const Point& p, double fp, const std::vector<double>& d, Bounds mode);
  Found BrentMaximum(const Point& p, double fp, const std::vector<double>& d, Bounds mode);
  Found IntervalMaximum(const Point& p, double fp, const std::vector<double>& d);

  Options options_;
  BatchFunction evaluate_;
  UniformFunction uniform_;
  IterationCallback on_iteration_;
  WarningCallback on_warning_;
  std::size_t n_ = 0;
  std::vector<double> range_;          // upper - lower
  std::map<Point, double> cache_;      // every evaluated point and its value
  long long evaluations_ = 0;
  bool warned_bad_value_ = false;
};

/// The start point from the `start` field: empty (or blank) text gives
/// `fallback`; otherwise comma-separated numbers, one per parameter, inside
/// [lower, upper]. Throws std::invalid_argument naming the bad value.
std::vector<double> ParseStart(const std::string& text, const std::vector<double>& lower,
                               const std::vector<double>& upper,
                               const std::vector<std::string>& names,
                               const std::vector<double>& fallback);

/// "brent" or "interval"; std::invalid_argument otherwise.
LineSearch ParseLineSearch(const std::string& text);
/// "constant", "stadium" or "easy-direction"; std::invalid_argument otherwise.
Bounds ParseBounds(const std::string& text);
/// "fixed" or "statistics"; std::invalid_argument otherwise.
DirectionOrder ParseDirectionOrder(const std::string& text);

}  // namespace yamor::plugins::powell
