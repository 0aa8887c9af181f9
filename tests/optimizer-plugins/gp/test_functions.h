// Analytic test functions of Bayesian optimization on the unit box and a
// plain sequential driver, shared by gp_test and tools/bench/gp_bench.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>

#include "optimizer-plugins/gp/bayes_optimizer.h"

namespace yamor::gp {

// Negated Branin on [−5, 10] × [0, 15] seen from the unit box: maximum
// −0.397887 at three points.
inline double NegBranin(const Eigen::VectorXd& u) {
  const double x1 = -5.0 + 15.0 * u[0], x2 = 15.0 * u[1];
  const double b = 5.1 / (4.0 * M_PI * M_PI), c = 5.0 / M_PI, t = 1.0 / (8.0 * M_PI);
  const double q = x2 - b * x1 * x1 + c * x1 - 6.0;
  return -(q * q + 10.0 * (1.0 - t) * std::cos(x1) + 10.0);
}
constexpr double kBraninMax = -0.397887;

// Hartmann-6 on [0, 1]^6 (its sign flipped to maximize): maximum 3.32237.
inline double Hartmann6(const Eigen::VectorXd& x) {
  static const double alpha[4] = {1.0, 1.2, 3.0, 3.2};
  static const double a[4][6] = {{10, 3, 17, 3.5, 1.7, 8}, {0.05, 10, 17, 0.1, 8, 14},
                                 {3, 3.5, 1.7, 10, 17, 8}, {17, 8, 0.05, 10, 0.1, 14}};
  static const double p[4][6] = {{0.1312, 0.1696, 0.5569, 0.0124, 0.8283, 0.5886},
                                 {0.2329, 0.4135, 0.8307, 0.3736, 0.1004, 0.9991},
                                 {0.2348, 0.1451, 0.3522, 0.2883, 0.3047, 0.6650},
                                 {0.4047, 0.8828, 0.8732, 0.5743, 0.1091, 0.0381}};
  double sum = 0.0;
  for (int i = 0; i < 4; ++i) {
    double inner = 0.0;
    for (int j = 0; j < 6; ++j) inner += a[i][j] * (x[j] - p[i][j]) * (x[j] - p[i][j]);
    sum += alpha[i] * std::exp(-inner);
  }
  return sum;
}
constexpr double kHartmannMax = 3.32237;

// The best value of a sequential run: `initial` Latin-hypercube points, then
// one proposal at a time up to `budget` evaluations.
inline double BestOfRun(const std::function<double(const Eigen::VectorXd&)>& f, int dimension, int initial, int budget,
                 std::uint64_t seed, BayesOptions options = {}) {
  options.dimension = dimension;
  BayesianOptimizer bo(options, seed);
  double best = -std::numeric_limits<double>::infinity();
  for (const Eigen::VectorXd& x : bo.InitialDesign(initial)) {
    const double v = f(x);
    bo.Tell(x, v);
    best = std::max(best, v);
  }
  while (bo.observations() < budget) {
    const Eigen::VectorXd x = bo.Ask(1).front();
    const double v = f(x);
    bo.Tell(x, v);
    best = std::max(best, v);
  }
  return best;
}

}  // namespace yamor::gp
