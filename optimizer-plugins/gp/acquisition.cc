#include "optimizer-plugins/gp/acquisition.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include <nlopt.h>

namespace yamor::gp {
namespace {

constexpr double kLogSqrt2Pi = 0.91893853320467274178;

double NormalPdf(double z) { return std::exp(-0.5 * z * z - kLogSqrt2Pi); }
double NormalCdf(double z) { return 0.5 * std::erfc(-z / std::sqrt(2.0)); }

// log h(z), h(z) = φ(z) + zΦ(z) = EI / sd at z = (mean − incumbent) / sd.
double LogH(double z) {
  if (z > -1.0) return std::log(NormalPdf(z) + z * NormalCdf(z));
  const double t = -z;
  const double log_pdf = -0.5 * t * t - kLogSqrt2Pi;
  if (t <= 30.0) {
    // h = φ(t)(1 − t·Q(t)/φ(t)), Q the upper tail: both factors are still
    // representable here, and the cancellation loses at most t² ulps.
    const double mills = 0.5 * std::erfc(t / std::sqrt(2.0)) / NormalPdf(t);
    return log_pdf + std::log1p(-t * mills);
  }
  // Asymptotic series of 1 − t·Q(t)/φ(t); its next term is below 1e-7 relative here.
  const double u = 1.0 / (t * t);
  return log_pdf + std::log(u * (1.0 - 3.0 * u + 15.0 * u * u));
}

struct BoxObjective {
  const std::function<double(const Eigen::VectorXd&)>* f;
  int dimension;
  std::vector<double> lower, upper;
  static double Call(unsigned n, const double* x, double* /*grad*/, void* data) {
    const auto* self = static_cast<const BoxObjective*>(data);
    Eigen::VectorXd point = Eigen::Map<const Eigen::VectorXd>(x, n);
    for (unsigned i = 0; i < n; ++i) point[i] = std::clamp(point[i], self->lower[i], self->upper[i]);
    const double value = (*self->f)(point);
    return std::isfinite(value) ? value : -1e300;
  }
};

// One NLopt run of `algorithm` from `x` (updated to its best) in the box.
double RunNlopt(nlopt_algorithm algorithm, BoxObjective& objective, std::vector<double>& x, int evaluations) {
  const auto n = static_cast<unsigned>(objective.dimension);
  nlopt_opt opt = nlopt_create(algorithm, n);
  if (opt == nullptr) throw std::runtime_error("nlopt_create failed (out of memory)");
  nlopt_set_lower_bounds(opt, objective.lower.data());
  nlopt_set_upper_bounds(opt, objective.upper.data());
  nlopt_set_max_objective(opt, &BoxObjective::Call, &objective);
  nlopt_set_maxeval(opt, evaluations);
  if (algorithm == NLOPT_LN_BOBYQA) {
    nlopt_set_xtol_abs1(opt, 1e-7);
    // The trust region starts at a tenth of the box, or less near a face.
    std::vector<double> step(n);
    for (unsigned i = 0; i < n; ++i) {
      const double width = objective.upper[i] - objective.lower[i];
      step[i] = std::max(1e-4 * width, std::min({0.1 * width, x[i] - objective.lower[i], objective.upper[i] - x[i]}));
    }
    nlopt_set_initial_step(opt, step.data());
  }
  double value = -std::numeric_limits<double>::infinity();
  nlopt_optimize(opt, x.data(), &value);  // any stop leaves x at the best seen
  nlopt_destroy(opt);
  for (unsigned i = 0; i < n; ++i) x[i] = std::clamp(x[i], objective.lower[i], objective.upper[i]);
  return BoxObjective::Call(n, x.data(), nullptr, &objective);
}

}  // namespace

double ExpectedImprovement(double mean, double sd, double incumbent) {
  if (!(sd > 0.0)) return std::max(0.0, mean - incumbent);
  const double z = (mean - incumbent) / sd;
  return sd * (NormalPdf(z) + z * NormalCdf(z));
}

double LogExpectedImprovement(double mean, double sd, double incumbent) {
  if (!(sd > 1e-300)) return mean > incumbent ? std::log(mean - incumbent) : -1e10;
  return std::max(-1e10, std::log(sd) + LogH((mean - incumbent) / sd));
}

double UpperConfidenceBound(double mean, double sd, double kappa) { return mean + kappa * sd; }

Eigen::VectorXd MaximizeInBox(const std::function<double(const Eigen::VectorXd&)>& f, int dimension,
                              const std::vector<Eigen::VectorXd>& local_starts, const MaximizerOptions& options,
                              double* value) {
  return MaximizeInBox(f, Eigen::VectorXd::Zero(dimension), Eigen::VectorXd::Ones(dimension), local_starts, options,
                       value);
}

Eigen::VectorXd MaximizeInBox(const std::function<double(const Eigen::VectorXd&)>& f, const Eigen::VectorXd& lower,
                              const Eigen::VectorXd& upper, const std::vector<Eigen::VectorXd>& local_starts,
                              const MaximizerOptions& options, double* value) {
  const auto dimension = static_cast<int>(lower.size());
  if (dimension < 1 || upper.size() != lower.size() || !((upper - lower).array() > 0.0).all()) {
    throw std::invalid_argument("MaximizeInBox: dimension " + std::to_string(dimension) +
                                " < 1 or bounds of the wrong size or empty");
  }
  const int global = options.global_evaluations > 0 ? options.global_evaluations : std::min(2000, 150 * dimension);
  const int local = options.local_evaluations > 0 ? options.local_evaluations : 40 * dimension + 40;
  BoxObjective objective{&f, dimension, std::vector<double>(lower.data(), lower.data() + dimension),
                         std::vector<double>(upper.data(), upper.data() + dimension)};
  std::vector<double> x(static_cast<std::size_t>(dimension));
  for (int i = 0; i < dimension; ++i) x[static_cast<std::size_t>(i)] = 0.5 * (lower[i] + upper[i]);
  double best_value = RunNlopt(NLOPT_GN_DIRECT_L, objective, x, global);
  std::vector<std::vector<double>> starts = {x};
  for (const Eigen::VectorXd& s : local_starts) {
    if (s.size() != dimension) throw std::invalid_argument("MaximizeInBox: a local start of the wrong size");
    starts.emplace_back(s.data(), s.data() + s.size());
    for (int i = 0; i < dimension; ++i) {
      starts.back()[static_cast<std::size_t>(i)] = std::clamp(s[i], lower[i], upper[i]);
    }
  }
  std::vector<double> best = x;
  for (std::vector<double>& start : starts) {
    const double v = RunNlopt(NLOPT_LN_BOBYQA, objective, start, local);
    if (v > best_value) {
      best_value = v;
      best = start;
    }
  }
  if (value != nullptr) *value = best_value;
  return Eigen::Map<const Eigen::VectorXd>(best.data(), dimension);
}

Eigen::MatrixXd LatinHypercube(int n, int dimension, std::mt19937_64& rng, int tries) {
  if (n < 1 || dimension < 1) {
    throw std::invalid_argument("LatinHypercube: " + std::to_string(n) + " points of dimension " +
                                std::to_string(dimension));
  }
  Eigen::MatrixXd best;
  double best_distance = -1.0;
  std::vector<int> strata(static_cast<std::size_t>(n));
  for (int attempt = 0; attempt < std::max(1, tries); ++attempt) {
    Eigen::MatrixXd design(n, dimension);
    for (int j = 0; j < dimension; ++j) {
      for (int i = 0; i < n; ++i) strata[static_cast<std::size_t>(i)] = i;
      // Fisher–Yates with our generator (std::shuffle's order is unspecified).
      for (int i = n - 1; i > 0; --i) {
        std::swap(strata[static_cast<std::size_t>(i)], strata[rng() % static_cast<std::uint64_t>(i + 1)]);
      }
      for (int i = 0; i < n; ++i) design(i, j) = (strata[static_cast<std::size_t>(i)] + Uniform(rng)) / n;
    }
    double distance = std::numeric_limits<double>::infinity();
    for (int a = 0; a < n; ++a) {
      for (int b = 0; b < a; ++b) distance = std::min(distance, (design.row(a) - design.row(b)).squaredNorm());
    }
    if (distance > best_distance) {
      best_distance = distance;
      best = design;
    }
  }
  return best;
}

}  // namespace yamor::gp
