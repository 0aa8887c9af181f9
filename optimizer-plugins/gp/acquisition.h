// Acquisition functions of Bayesian optimization (maximizing) and their
// maximizer over the unit box: a global pass (NLopt DIRECT-L) then local
// polishing (NLopt BOBYQA) from the global best and given points; and the
// seeded Latin hypercube used as an initial design.
#pragma once

#include <functional>
#include <random>
#include <vector>

#include <Eigen/Dense>

#include "optimizer-plugins/gp/gaussian_process.h"

namespace yamor::gp {

/// Expected improvement over `incumbent` of a normal N(mean, sd²): E[max(Y − incumbent, 0)].
double ExpectedImprovement(double mean, double sd, double incumbent);

/// log ExpectedImprovement, accurate where the improvement is far in the
/// tail (Ament et al. 2023, "LogEI"): where EI underflows to 0, the log
/// still ranks candidates, so the maximizer is never left on a flat zero.
/// −1e10 when sd is 0 and the mean is not above the incumbent.
double LogExpectedImprovement(double mean, double sd, double incumbent);

/// Upper confidence bound mean + kappa·sd.
double UpperConfidenceBound(double mean, double sd, double kappa);

/// Budgets of MaximizeInBox.
struct MaximizerOptions {
  int global_evaluations = 0;  ///< DIRECT-L evaluations; 0: 150·d, at most 2000.
  int local_evaluations = 0;   ///< BOBYQA evaluations per start; 0: 40·d + 40.
};

/// The point of the unit box [0, 1]^d maximizing `f` found by DIRECT-L, then
/// BOBYQA from its best and from each of `local_starts`; `value` (when not
/// null) receives f there. `f` must return finite numbers.
Eigen::VectorXd MaximizeInBox(const std::function<double(const Eigen::VectorXd&)>& f, int dimension,
                              const std::vector<Eigen::VectorXd>& local_starts, const MaximizerOptions& options,
                              double* value = nullptr);

/// MaximizeInBox over the box [lower, upper] inside the unit box (a trust
/// region); local starts outside it are moved onto it.
Eigen::VectorXd MaximizeInBox(const std::function<double(const Eigen::VectorXd&)>& f, const Eigen::VectorXd& lower,
                              const Eigen::VectorXd& upper, const std::vector<Eigen::VectorXd>& local_starts,
                              const MaximizerOptions& options, double* value = nullptr);

/// `n` points of a Latin hypercube in [0, 1]^d (each axis's n strata hit
/// once, a uniform point within each), the best of `tries` by the smallest
/// pairwise distance (maximin). Deterministic for `rng`'s state.
Eigen::MatrixXd LatinHypercube(int n, int dimension, std::mt19937_64& rng, int tries = 20);

}  // namespace yamor::gp
