#include "optimizer-plugins/powell/powell_core.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>

namespace yamor::plugins::powell {
namespace {

// Golden ratio: each bracketing expansion grows the step by it.
constexpr double kGolden = 1.618033988749895;
// 2 - golden ratio: Brent's golden-section step as a fraction of the larger part.
constexpr double kGoldenFraction = 0.3819660112501051;
// Bracketing gives up after this many expansions (e.g. a bad_value above
// every real value makes the outside look like an endless ascent).
constexpr int kMaxExpansions = 60;
// Brent's iteration cap per line (it normally stops at line_tolerance).
constexpr int kMaxBrentIterations = 100;
// Lengths (normalized units) below this are zero: a direction or segment
// this short has no meaningful line to search, and dividing by it would
// produce the NaN the thesis's implementation suffered from.
constexpr double kTinyLength = 1e-12;

std::string Num(double v) {
  char buffer[64];
  auto [end, ec] = std::to_chars(buffer, buffer + sizeof(buffer), v);
  return ec == std::errc() ? std::string(buffer, end) : std::string("?");
}

std::string Trim(const std::string& s) {
  const auto first = s.find_first_not_of(" \t\r\n");
  if (first == std::string::npos) return "";
  const auto last = s.find_last_not_of(" \t\r\n");
  return s.substr(first, last - first + 1);
}

double Norm(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v) s += x * x;
  return std::sqrt(s);
}

// Zeroes components negligible against the largest, so that a direction
// that is in effect an axis does not get a one-sided segment from a
// rounding-sized component at a bound. False when the vector is too short
// to be a direction.
bool Clean(std::vector<double>& v) {
  double largest = 0.0;
  for (double x : v) largest = std::max(largest, std::abs(x));
  if (!(largest > kTinyLength)) return false;
  for (double& x : v) {
    if (std::abs(x) < 1e-12 * largest) x = 0.0;
  }
  return true;
}

// Clean, then scaled to unit length; false when too short.
bool MakeUnit(std::vector<double>& v) {
  if (!Clean(v)) return false;
  const double norm = Norm(v);
  if (!(norm > kTinyLength)) return false;
  for (double& x : v) x /= norm;
  return true;
}

// Powell's test whether the direction from the iteration's start to its
// end should replace the direction of largest gain, written for
// maximization: f0 at the start, f1 at the end, fe at the extrapolated
// point 2·end - start, `largest` the largest single-direction gain. In
// terms of the minimized -f it is the classic condition
// 2(F0 - 2F1 + Fe)(F0 - F1 - Δ)² < Δ(F0 - Fe)² with Fe < F0. No division:
// nothing can become NaN from finite inputs.
bool ReplacementCriterion(double f0, double f1, double fe, double largest) {
  if (!(fe > f0) || !(largest > 0.0)) return false;
  const double F0 = -f0, F1 = -f1, Fe = -fe;
  const double a = F0 - F1 - largest;
  const double b = F0 - Fe;
  return 2.0 * (F0 - 2.0 * F1 + Fe) * a * a < largest * b * b;
}

}  // namespace

// The function along one line x(t) = origin + t·d (d in normalized units)
// as a line search sees it: real evaluations inside the box, the bound
// handling outside; remembers the best real point seen (the origin first),
// which is what the search returns, so a line search never leaves the box
// nor returns anything worse than where it started.
class Powell::LineProbe {
 public:
  LineProbe(Powell& owner, const Point& origin, double f_origin, const std::vector<double>& d,
            Bounds mode)
      : owner_(owner), origin_(origin), d_(d), mode_(mode), best_{origin, f_origin} {
    double lo = -std::numeric_limits<double>::infinity();
    double hi = std::numeric_limits<double>::infinity();
    bool moves = false;
    for (std::size_t i = 0; i < origin_.size(); ++i) {
      const double step = d_[i] * owner_.range_[i];
      if (step == 0.0) continue;
      moves = true;
      double a = (owner_.options_.lower[i] - origin_[i]) / step;
      double b = (owner_.options_.upper[i] - origin_[i]) / step;
      if (a > b) std::swap(a, b);
      lo = std::max(lo, a);
      hi = std::min(hi, b);
    }
    if (!moves) lo = hi = 0.0;
    // The origin is inside the box, so the segment contains t = 0; the
    // min/max only absorb rounding.
    tmin_ = std::min(lo, 0.0);
    tmax_ = std::max(hi, 0.0);
    d_norm_ = Norm(d_);
  }

  // No line worth searching: a zero direction or a segment of no length.
  bool Degenerate() const { return !(d_norm_ > kTinyLength) || !(tmax_ - tmin_ > kTinyLength); }
  double tmin() const { return tmin_; }
  double tmax() const { return tmax_; }

  // The point at t, clamped to the segment and to the box (rounding).
  Point At(double t) const {
    t = std::clamp(t, tmin_, tmax_);
    Point x(origin_.size());
    for (std::size_t i = 0; i < x.size(); ++i) {
      x[i] = std::clamp(origin_[i] + t * d_[i] * owner_.range_[i], owner_.options_.lower[i],
                        owner_.options_.upper[i]);
    }
    return x;
  }

  // The line function at any t.
  double operator()(double t) {
    if (t >= tmin_ && t <= tmax_) return Real(t);
    const double border = t > tmax_ ? tmax_ : tmin_;
    switch (mode_) {
      case Bounds::kConstant:
        return owner_.options_.bad_value;
      case Bounds::kEasyDirection:
        // The request is moved to the nearest valid point of the line.
        return Real(border);
      case Bounds::kStadium:
        return Real(border) - owner_.options_.malus * std::abs(t - border) * d_norm_;
    }
    return owner_.options_.bad_value;
  }

  // Values at points inside the segment, evaluated as one batch.
  std::vector<double> Batch(const std::vector<double>& ts) {
    std::vector<Point> points;
    points.reserve(ts.size());
    for (double t : ts) points.push_back(At(t));
    std::vector<double> values = owner_.EvaluateBatch(points);
    for (std::size_t k = 0; k < points.size(); ++k) Consider(points[k], values[k]);
    return values;
  }

  const Found& best() const { return best_; }

 private:
  double Real(double t) {
    Point x = At(t);
    const double f = owner_.Evaluate(x);
    Consider(x, f);
    return f;
  }
  void Consider(const Point& x, double f) {
    if (f > best_.value) best_ = {x, f};
  }

  Powell& owner_;
  const Point origin_;
  const std::vector<double> d_;
  const Bounds mode_;
  Found best_;
  double tmin_ = 0.0, tmax_ = 0.0, d_norm_ = 0.0;
};

Powell::Powell(Options options, BatchFunction evaluate, UniformFunction uniform)
    : options_(std::move(options)), evaluate_(std::move(evaluate)), uniform_(std::move(uniform)) {
  n_ = options_.lower.size();
  if (n_ == 0) throw std::invalid_argument("powell: the problem has no parameter");
  if (options_.upper.size() != n_ || options_.start.size() != n_) {
    throw std::invalid_argument("powell: lower, upper and start have different sizes");
  }
  range_.resize(n_);
  for (std::size_t i = 0; i < n_; ++i) {
    const double lo = options_.lower[i], hi = options_.upper[i], s = options_.start[i];
    if (!(std::isfinite(lo) && std::isfinite(hi) && lo < hi)) {
      throw std::invalid_argument("powell: parameter " + std::to_string(i) + " has invalid bounds [" +
                                  Num(lo) + ", " + Num(hi) + "]");
    }
    if (!(s >= lo && s <= hi)) {
      throw std::invalid_argument("powell: start value " + Num(s) + " of parameter " +
                                  std::to_string(i) + " is outside [" + Num(lo) + ", " + Num(hi) + "]");
    }
    range_[i] = hi - lo;
  }
  auto check = [](bool ok, const std::string& what) {
    if (!ok) throw std::invalid_argument("powell: " + what);
  };
  check(std::isfinite(options_.tolerance) && options_.tolerance >= 0.0,
        "tolerance must be finite and >= 0, got " + Num(options_.tolerance));
  check(options_.max_iterations >= 1, "max_iterations must be >= 1");
  check(std::isfinite(options_.step) && options_.step > 0.0, "step must be > 0, got " + Num(options_.step));
  check(std::isfinite(options_.line_tolerance) && options_.line_tolerance > 0.0,
        "line_tolerance must be > 0, got " + Num(options_.line_tolerance));
  check(options_.interval_points >= 2, "interval_points must be >= 2");
  check(options_.refine_points >= 1, "refine_points must be >= 1");
  check(options_.interval_refinements >= 0, "interval_refinements must be >= 0");
  check(std::isfinite(options_.bad_value), "bad_value must be finite");
  check(std::isfinite(options_.malus) && options_.malus > 0.0,
        "malus must be > 0, got " + Num(options_.malus));
  if (!evaluate_) throw std::invalid_argument("powell: no evaluation function");
  if (!uniform_) throw std::invalid_argument("powell: no random source");
}

Powell::~Powell() = default;

double Powell::Evaluate(const Point& x) { return EvaluateBatch({x}).front(); }

std::vector<double> Powell::EvaluateBatch(const std::vector<Point>& points) {
  std::vector<Point> missing;
  for (const Point& x : points) {
    if (!Cached(x) && std::find(missing.begin(), missing.end(), x) == missing.end()) {
      missing.push_back(x);
    }
  }
  if (!missing.empty()) {
    const std::vector<double> values = evaluate_(missing);
    if (values.size() != missing.size()) {
      throw std::runtime_error("powell: the evaluator returned " + std::to_string(values.size()) +
                               " values for " + std::to_string(missing.size()) + " points");
    }
    evaluations_ += static_cast<long long>(missing.size());
    for (std::size_t k = 0; k < missing.size(); ++k) {
      if (!std::isfinite(values[k])) {
        throw std::runtime_error("powell: the evaluator returned a non-finite value");
      }
      cache_[missing[k]] = values[k];
      if (!warned_bad_value_ && options_.bounds != Bounds::kStadium &&
          values[k] <= options_.bad_value) {
        warned_bad_value_ = true;
        if (on_warning_) {
          on_warning_("bad_value " + Num(options_.bad_value) + " is not below the evaluated value " +
                      Num(values[k]) +
                      ": outside the box may look better than inside; set bad_value lower");
        }
      }
    }
  }
  std::vector<double> out;
  out.reserve(points.size());
  for (const Point& x : points) out.push_back(cache_.at(x));
  return out;
}

Powell::Found Powell::LineMaximum(const Point& p, double fp, const std::vector<double>& d,
                                  Bounds mode) {
  return options_.line_search == LineSearch::kInterval ? IntervalMaximum(p, fp, d)
                                                       : BrentMaximum(p, fp, d, mode);
}

Powell::Found Powell::BrentMaximum(const Point& p, double fp, const std::vector<double>& d,
                                   Bounds mode) {
  LineProbe line(*this, p, fp, d, mode);
  if (line.Degenerate()) return line.best();

  // Bracket: a first step of random size (thesis 6.2.2: the bracketing's
  // random factor), uphill, then golden-ratio expansions while it climbs.
  const double s = options_.step * (0.5 + uniform_());
  double a = 0.0, fa = fp;
  double b = s, fb = line(b);
  if (fb <= fa) {
    std::swap(a, b);
    std::swap(fa, fb);
  }
  double c = b + kGolden * (b - a);
  double fc = line(c);
  for (int expansions = 0; fc > fb; ++expansions) {
    if (expansions >= kMaxExpansions) return line.best();
    a = b;
    fa = fb;
    b = c;
    fb = fc;
    c = b + kGolden * (b - a);
    fc = line(c);
  }

  // Brent's method on the bracket (a, b, c), f(b) >= f(a), f(c): parabolic
  // steps through the three best points when they behave, golden-section
  // steps otherwise. Written on g = -f, the minimized function.
  double lo = std::min(a, c), hi = std::max(a, c);
  double x = b, w = b, v = b;
  double gx = -fb, gw = gx, gv = gx;
  double step = 0.0, previous = 0.0;  // the last step, and the one before
  const double tol = options_.line_tolerance;
  for (int iteration = 0; iteration < kMaxBrentIterations; ++iteration) {
    const double mid = 0.5 * (lo + hi);
    if (std::abs(x - mid) <= 2.0 * tol - 0.5 * (hi - lo)) break;
    bool parabolic = false;
    if (std::abs(previous) > tol) {
      const double r = (x - w) * (gx - gv);
      double q = (x - v) * (gx - gw);
      double num = (x - v) * q - (x - w) * r;
      q = 2.0 * (q - r);
      if (q > 0.0) num = -num;
      q = std::abs(q);
      // Accept the parabola's vertex only inside the bracket and when the
      // step is less than half the step before last (else it oscillates).
      if (std::abs(num) < std::abs(0.5 * q * previous) && num > q * (lo - x) && num < q * (hi - x)) {
        previous = step;
        step = num / q;
        parabolic = true;
        const double u = x + step;
        if (u - lo < 2.0 * tol || hi - u < 2.0 * tol) step = mid >= x ? tol : -tol;
      }
    }
    if (!parabolic) {
      previous = x >= mid ? lo - x : hi - x;
      step = kGoldenFraction * previous;
    }
    const double u = std::abs(step) >= tol ? x + step : x + (step >= 0.0 ? tol : -tol);
    const double gu = -line(u);
    if (gu <= gx) {
      if (u >= x) {
        lo = x;
      } else {
        hi = x;
      }
      v = w;
      gv = gw;
      w = x;
      gw = gx;
      x = u;
      gx = gu;
    } else {
      if (u < x) {
        lo = u;
      } else {
        hi = u;
      }
      if (gu <= gw || w == x) {
        v = w;
        gv = gw;
        w = u;
        gw = gu;
      } else if (gu <= gv || v == x || v == w) {
        v = u;
        gv = gu;
      }
    }
  }
  return line.best();
}

Powell::Found Powell::IntervalMaximum(const Point& p, double fp, const std::vector<double>& d) {
  LineProbe line(*this, p, fp, d, Bounds::kConstant);  // never leaves the segment
  if (line.Degenerate()) return line.best();
  const double tmin = line.tmin(), tmax = line.tmax();

  // Regular grid over the whole valid segment, ends included: one batch.
  const int grid = options_.interval_points;
  double half = (tmax - tmin) / (grid - 1);  // grid spacing: the best's neighbours are this far
  std::vector<double> ts;
  for (int k = 0; k < grid; ++k) ts.push_back(k == grid - 1 ? tmax : tmin + k * half);
  std::vector<double> values = line.Batch(ts);
  std::vector<std::pair<double, double>> known = {{0.0, fp}};  // (t, f) on this line
  for (std::size_t k = 0; k < ts.size(); ++k) known.emplace_back(ts[k], values[k]);

  // Refinements: `refine_points` new points around the best at a smaller
  // interval, one batch each; the next round's interval is this one's.
  const int m = options_.refine_points;
  for (int round = 0; round < options_.interval_refinements; ++round) {
    auto best = known.begin();
    for (auto it = known.begin(); it != known.end(); ++it) {
      if (it->second > best->second) best = it;
    }
    const double c = best->first;
    double left_f = -std::numeric_limits<double>::infinity(), left_t = tmin - 1.0;
    double right_f = -std::numeric_limits<double>::infinity(), right_t = tmax + 1.0;
    for (const auto& [t, f] : known) {
      if (t < c && t > left_t) {
        left_t = t;
        left_f = f;
      }
      if (t > c && t < right_t) {
        right_t = t;
        right_f = f;
      }
    }
    const bool left_ok = c - tmin > kTinyLength, right_ok = tmax - c > kTinyLength;
    if (!left_ok && !right_ok) break;
    // Two-sided: offsets ±(k + 1/2)·δ with δ = 2·half/(m + 1) — none hits
    // the best or its grid neighbours, and the m nearest lie within ±half.
    // One-sided (the best is a segment end): m points within half.
    const double delta = left_ok && right_ok ? 2.0 * half / (m + 1) : half / m;
    double first = right_f >= left_f ? 1.0 : -1.0;  // the better neighbour's side first
    if (!left_ok) first = 1.0;
    if (!right_ok) first = -1.0;
    std::vector<double> fine;
    std::vector<Point> chosen;
    for (int k = 0; k <= 2 * m && static_cast<int>(fine.size()) < m; ++k) {
      for (double side : {first, -first}) {
        if (static_cast<int>(fine.size()) >= m) break;
        if ((side > 0 && !right_ok) || (side < 0 && !left_ok)) continue;
        const double t = c + side * (k + 0.5) * delta;
        if (t < tmin || t > tmax) continue;
        const Point x = line.At(t);
        // Already evaluated points are skipped so that each refinement
        // spends exactly m new evaluations.
        if (Cached(x) || std::find(chosen.begin(), chosen.end(), x) != chosen.end()) continue;
        fine.push_back(t);
        chosen.push_back(x);
      }
    }
    if (fine.empty()) break;
    values = line.Batch(fine);
    for (std::size_t k = 0; k < fine.size(); ++k) known.emplace_back(fine[k], values[k]);
    half = delta;
  }
  return line.best();
}

Result Powell::Run() {
  Point p = options_.start;
  double fp = Evaluate(p);

  std::vector<Direction> directions(n_);
  for (std::size_t i = 0; i < n_; ++i) {
    directions[i].v.assign(n_, 0.0);
    directions[i].v[i] = 1.0;
    directions[i].id = static_cast<int>(i);
  }
  int next_id = static_cast<int>(n_);
  // Easy direction change applies only to new directions (6.2.4); the
  // set's own searches see the constant bad value.
  const Bounds regular = options_.bounds == Bounds::kEasyDirection ? Bounds::kConstant : options_.bounds;
  const Bounds fresh = options_.bounds;

  Result result;
  for (int iteration = 1; iteration <= options_.max_iterations; ++iteration) {
    if (options_.direction_order == DirectionOrder::kStatistics) {
      std::stable_sort(directions.begin(), directions.end(),
                       [](const Direction& a, const Direction& b) { return a.score > b.score; });
    }
    const Point ps = p;
    const double fps = fp;
    IterationReport report;
    report.iteration = iteration;
    double largest = 0.0;
    std::size_t largest_index = directions.size();
    for (std::size_t k = 0; k < directions.size(); ++k) {
      const Found found = LineMaximum(p, fp, directions[k].v, regular);
      const double gain = found.value - fp;
      p = found.point;
      fp = found.value;
      report.order.push_back(directions[k].id);
      report.gains.push_back(gain);
      directions[k].score = 0.5 * directions[k].score + gain;
      if (gain > largest) {
        largest = gain;
        largest_index = k;
      }
    }
    const double sweep = fp - fps;
    const bool converged = sweep <= options_.tolerance * std::max(1.0, std::abs(fps));

    if (!converged && options_.replace_directions && largest_index < directions.size()) {
      std::vector<double> moved(n_);
      for (std::size_t i = 0; i < n_; ++i) moved[i] = (p[i] - ps[i]) / range_[i];
      if (Clean(moved) && Norm(moved) > kTinyLength) {
        // The extrapolated point ps + 2(p - ps) is t = 1 along p - ps from p.
        LineProbe extrapolation(*this, p, fp, moved, fresh);
        const double fe = extrapolation(1.0);
        const bool replace = ReplacementCriterion(fps, fp, fe, largest);
        // A real evaluation there that beats p is not wasted.
        if (extrapolation.best().value > fp) {
          p = extrapolation.best().point;
          fp = extrapolation.best().value;
        }
        std::vector<double> unit = moved;
        if (replace && MakeUnit(unit)) {
          const Found found = LineMaximum(p, fp, unit, fresh);
          const double gain = found.value - fp;
          p = found.point;
          fp = found.value;
          directions.erase(directions.begin() + static_cast<std::ptrdiff_t>(largest_index));
          directions.push_back({unit, next_id, gain});
          report.order.push_back(next_id);
          report.gains.push_back(gain);
          ++next_id;
          report.direction_replaced = true;
          ++result.directions_replaced;
        }
      }
    }

    report.value = fp;
    report.improvement = fp - fps;
    report.point = p;
    report.evaluations = evaluations_;
    report.converged = converged;
    result.iterations = iteration;
    if (on_iteration_) on_iteration_(report);
    if (converged) {
      result.converged = true;
      break;
    }
  }
  result.point = p;
  result.value = fp;
  result.evaluations = evaluations_;
  return result;
}

std::vector<double> ParseStart(const std::string& text, const std::vector<double>& lower,
                               const std::vector<double>& upper,
                               const std::vector<std::string>& names,
                               const std::vector<double>& fallback) {
  const std::string all = Trim(text);
  if (all.empty()) return fallback;
  std::vector<std::string> items;
  std::size_t begin = 0;
  while (true) {
    const std::size_t comma = all.find(',', begin);
    items.push_back(Trim(all.substr(begin, comma == std::string::npos ? std::string::npos : comma - begin)));
    if (comma == std::string::npos) break;
    begin = comma + 1;
  }
  auto name = [&](std::size_t i) { return i < names.size() ? names[i] : "parameter " + std::to_string(i); };
  if (items.size() != lower.size()) {
    std::string list;
    for (std::size_t i = 0; i < lower.size(); ++i) list += (i == 0 ? "" : ", ") + name(i);
    throw std::invalid_argument("field start has " + std::to_string(items.size()) + " value" +
                                (items.size() == 1 ? "" : "s") + ", the problem has " +
                                std::to_string(lower.size()) + " parameter" +
                                (lower.size() == 1 ? "" : "s") + " (" + list + ")");
  }
  std::vector<double> start(items.size());
  for (std::size_t i = 0; i < items.size(); ++i) {
    const std::string& item = items[i];
    double value = 0.0;
    const char* first = item.data();
    const char* last = item.data() + item.size();
    if (!item.empty() && *first == '+') ++first;  // from_chars refuses a leading '+'
    const auto [end, ec] = std::from_chars(first, last, value);
    if (item.empty() || ec != std::errc() || end != last || !std::isfinite(value)) {
      throw std::invalid_argument("field start: value " + std::to_string(i + 1) + " ('" + item +
                                  "', for " + name(i) + ") is not a finite number");
    }
    if (!(value >= lower[i] && value <= upper[i])) {
      throw std::invalid_argument("field start: " + name(i) + " = " + item + " is outside [" +
                                  Num(lower[i]) + ", " + Num(upper[i]) + "]");
    }
    start[i] = value;
  }
  return start;
}

LineSearch ParseLineSearch(const std::string& text) {
  if (text == "brent") return LineSearch::kBrent;
  if (text == "interval") return LineSearch::kInterval;
  throw std::invalid_argument("line_search '" + text + "' is not brent or interval");
}

Bounds ParseBounds(const std::string& text) {
  if (text == "constant") return Bounds::kConstant;
  if (text == "stadium") return Bounds::kStadium;
  if (text == "easy-direction") return Bounds::kEasyDirection;
  throw std::invalid_argument("bounds '" + text + "' is not constant, stadium or easy-direction");
}

DirectionOrder ParseDirectionOrder(const std::string& text) {
  if (text == "fixed") return DirectionOrder::kFixed;
  if (text == "statistics") return DirectionOrder::kStatistics;
  throw std::invalid_argument("direction_order '" + text + "' is not fixed or statistics");
}

}  // namespace yamor::plugins::powell
