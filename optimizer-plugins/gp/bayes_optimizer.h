// Bayesian optimization over the unit box, ask and tell: a Gaussian process
// (gaussian_process.h) refitted on every observation, proposals maximizing
// log expected improvement (noisy: the incumbent is the best posterior mean
// at an observed point) or an upper confidence bound, and batches by the
// Kriging believer (each chosen point joins the model at its predicted mean,
// with the same hyper-parameters, before the next is chosen). Maximizes.
// Independent of the plugin ABI: the bayesopt plugin and gap mode drive it.
#pragma once

#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include <Eigen/Dense>

#include "optimizer-plugins/gp/acquisition.h"
#include "optimizer-plugins/gp/gaussian_process.h"

namespace yamor::gp {

/// Which acquisition function proposals maximize.
enum class Acquisition {
  kExpectedImprovement,    ///< log EI over the best posterior mean at an observed point.
  kUpperConfidenceBound,   ///< mean + kappa·sd.
};

/// Settings of a BayesianOptimizer.
struct BayesOptions {
  int dimension = 1;                                        ///< Inputs, ≥ 1.
  Acquisition acquisition = Acquisition::kExpectedImprovement;  ///< What proposals maximize.
  double kappa = 2.0;                                       ///< UCB's sd multiplier.
  int fit_restarts = 2;                                     ///< Random MAP starts per fit (besides warm and mode).
  Priors priors;                                            ///< The GP's priors and noise floor.
  MaximizerOptions maximizer;                               ///< The acquisition maximizer's budgets.
  /// At most this many observations in the model (0: all): the best half by
  /// value and the most recent rest. A fit costs O(n³) per step: ~0.9 s of
  /// CPU at 300 points of 7 inputs, minutes at 1000.
  int max_model_points = 300;
  /// Inputs that are angles over one whole period of the box (empty: none);
  /// see GaussianProcess.
  std::vector<bool> periodic;
  /// Initial side of a trust region (TuRBO, Eriksson et al. 2019), as a
  /// fraction of the box; 0: proposals come from the whole box. The region
  /// is centred on the best point, stretched along the fitted length scales,
  /// doubled after 3 improving proposals in a row, halved after
  /// max(4, dimension) proposals without, and reset to this side below 1/128.
  double trust_region = 0.0;
};

/// Sequential model-based optimization. Not thread-safe (one caller).
class BayesianOptimizer {
 public:
  /// Every random choice (initial design, MAP restarts, fallbacks) comes
  /// from a generator seeded with `seed`. std::invalid_argument for a bad option.
  BayesianOptimizer(BayesOptions options, std::uint64_t seed);

  /// `n` points of a seeded maximin Latin hypercube (the design without a prior).
  std::vector<Eigen::VectorXd> InitialDesign(int n);
  /// The same inside the initial trust region around `center` (the whole box
  /// without a trust region): a design near a known good point.
  std::vector<Eigen::VectorXd> InitialDesign(int n, const Eigen::VectorXd& center);

  /// Records that `x` (in the unit box) gave `value`. A NaN or infinite
  /// value is a failed evaluation: it counts as the worst finite value seen
  /// (the floor), so the model learns to avoid the point without a
  /// non-number ever entering it. std::invalid_argument for a bad `x`.
  void Tell(const Eigen::VectorXd& x, double value);

  /// `q` ≥ 1 new points, pairwise distinct and distinct from every observed
  /// point: refits the model, then picks them one by one (Kriging believer).
  /// Before any finite value, Latin-hypercube points.
  std::vector<Eigen::VectorXd> Ask(int q);

  /// The model of the last Ask (real observations only, failures at the
  /// floor; at most max_model_points of them).
  const GaussianProcess& model() const { return model_; }
  /// Observations told so far.
  int observations() const { return static_cast<int>(values_.size()); }
  /// Failed (non-finite) observations among them.
  int failures() const { return failures_; }
  /// The trust region's current side (1 without one).
  double trust_region_side() const { return options_.trust_region > 0.0 ? side_ : 1.0; }
  /// Wall seconds of the last hyper-parameter fit.
  double last_fit_seconds() const { return last_fit_seconds_; }
  /// Wall seconds of the last Ask (fit and acquisition maximization).
  double last_ask_seconds() const { return last_ask_seconds_; }

 private:
  std::vector<std::size_t> ModelPoints(const std::vector<double>& values) const;
  void UpdateTrustRegion(double best, int q);
  double Acquire(const GaussianProcess& gp, const Eigen::VectorXd& x, double incumbent) const;
  bool IsNew(const Eigen::VectorXd& x, const std::vector<Eigen::VectorXd>& others) const;
  Eigen::VectorXd FarthestRandomPoint(const std::vector<Eigen::VectorXd>& others);

  BayesOptions options_;
  std::mt19937_64 rng_;
  GaussianProcess model_;
  std::vector<Eigen::VectorXd> points_;
  std::vector<double> values_;  // as told; non-finite = failed
  int failures_ = 0;
  double side_ = 1.0;               // trust region
  int improving_ = 0, stalled_ = 0;  // proposals in a row with / without improvement
  double best_at_last_ask_ = std::numeric_limits<double>::quiet_NaN();
  double last_fit_seconds_ = 0.0;
  double last_ask_seconds_ = 0.0;
};

}  // namespace yamor::gp
