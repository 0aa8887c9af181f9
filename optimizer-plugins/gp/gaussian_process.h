// A Gaussian process for Bayesian optimization: inputs in the unit box,
// outputs standardized inside (mean 0, variance 1), a Matérn 5/2 kernel with
// one length scale per input (ARD), a learned noise variance with a floor,
// and hyper-parameters by maximum a posteriori: the log marginal likelihood
// plus log-normal priors, maximized by NLopt's L-BFGS with analytic
// gradients from several seeded starts. The structure follows limbo and
// BoTorch (kernel, likelihood, priors as separate pieces); the code is ours.
#pragma once

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include <Eigen/Dense>

namespace yamor::gp {

/// Hyper-parameters in log space: log length scale per input, log signal
/// variance and log noise variance (both of the standardized outputs).
struct Hyperparameters {
  Eigen::VectorXd log_lengthscales;  ///< One per input dimension.
  double log_signal_variance = 0.0;  ///< log σ_f².
  double log_noise_variance = -4.0;  ///< log σ_n² (σ_n² ≥ the noise floor).
};

/// Priors and bounds of the MAP fit (log-normal: normal in log space).
struct Priors {
  /// Mean of log ℓ: ℓ ≈ 0.5 of the box. BoTorch's dimension-scaled prior
  /// (√2 + ½ ln d, Hvarfner et al. 2024) expects ℓ ≈ 10 for 6 inputs: too
  /// smooth for the budgets here (Hartmann-6 median 2.98 against 3.20 after
  /// 60 evaluations, tools/bench/gp_bench).
  double lengthscale_log_mean = -0.7;
  double lengthscale_log_sd = 1.0;  ///< Spread of log ℓ.
  double signal_log_mean = 0.0;     ///< Standardized outputs: σ_f² ≈ 1.
  double signal_log_sd = 1.0;       ///< Spread of log σ_f².
  double noise_log_mean = -6.0;     ///< σ_n² ≈ 0.0025 of the output variance.
  double noise_log_sd = 1.0;        ///< Spread of log σ_n².
  double noise_floor = 1e-6;        ///< Smallest σ_n² (standardized units).
  double min_lengthscale = 0.01;    ///< Bounds of ℓ in the unit box.
  double max_lengthscale = 100.0;
  double min_signal_variance = 1e-3;  ///< Bounds of σ_f².
  double max_signal_variance = 1e3;
};

/// The posterior at one point, in the outputs' own units.
struct Prediction {
  double mean = 0.0;      ///< Posterior mean of the latent function.
  double variance = 0.0;  ///< Posterior variance of the latent function (no noise), ≥ 0.
};

/// A Gaussian process regression model.
///
/// Thread safety: const methods may run concurrently; Fit/SetData are not.
class GaussianProcess {
 public:
  /// An empty model for inputs of `dimension` ≥ 1 (std::invalid_argument
  /// otherwise). An input flagged in `periodic` (empty: none) is an angle
  /// over one whole period of the box, 0 and 1 the same: its difference
  /// enters the distance as the chord sin(πΔ)/π, so the kernel wraps around.
  explicit GaussianProcess(int dimension, Priors priors = {}, std::vector<bool> periodic = {});

  /// Stores the data (rows of `x` in [0, 1]^d, finite `y`) and factorizes
  /// with the current hyper-parameters. The outputs' mean and scale are
  /// taken from `y` unless `keep_standardization` (fantasies of a batch must
  /// not move them). std::invalid_argument for a size mismatch, a point
  /// outside the box or a non-finite value.
  void SetData(const Eigen::MatrixXd& x, const Eigen::VectorXd& y, bool keep_standardization = false);

  /// Sets the hyper-parameters (the noise clamped to the floor) and refactorizes.
  void SetHyperparameters(const Hyperparameters& h);

  /// MAP fit from the current hyper-parameters, the prior's mode and
  /// `restarts` draws from the priors (seeded by `rng`; none beyond 100
  /// points, where each start is costly and the fit has settled); keeps the best.
  void Fit(std::mt19937_64& rng, int restarts = 3);

  /// The posterior at `x` (d values in the box).
  Prediction Predict(const Eigen::VectorXd& x) const;

  /// log p(y | θ) + log p(θ) at `h` and its gradient with respect to the log
  /// hyper-parameters (d length scales, signal, noise): what Fit maximizes.
  double LogPosterior(const Hyperparameters& h, Eigen::VectorXd* gradient) const;

  /// The kernel k(a, b) with the current hyper-parameters (standardized units).
  double Kernel(const Eigen::VectorXd& a, const Eigen::VectorXd& b) const;

  /// The current hyper-parameters.
  const Hyperparameters& hyperparameters() const { return h_; }
  /// The priors.
  const Priors& priors() const { return priors_; }
  /// Input dimension.
  int dimension() const { return dimension_; }
  /// Number of stored points.
  int size() const { return static_cast<int>(x_.rows()); }
  /// The stored inputs, one row per point.
  const Eigen::MatrixXd& inputs() const { return x_; }
  /// The stored outputs (original units).
  const Eigen::VectorXd& outputs() const { return y_; }
  /// Jitter added to the diagonal by the last factorization (0 when none was needed).
  double jitter() const { return jitter_; }

 private:
  Hyperparameters Mode() const;
  // The difference of inputs a and b along `j` (the chord for a periodic one).
  double Difference(int j, double a, double b) const {
    const double d = a - b;
    return periodic_[static_cast<std::size_t>(j)] ? std::sin(M_PI * d) / M_PI : d;
  }
  // Squared scaled distance of stored points a and b.
  double StoredDistance2(const Eigen::VectorXd& inverse_l, Eigen::Index a, Eigen::Index b) const;
  void Factorize();
  Hyperparameters Clamp(Hyperparameters h) const;

  int dimension_;
  Priors priors_;
  std::vector<bool> periodic_;
  Hyperparameters h_;
  Eigen::MatrixXd x_;
  Eigen::VectorXd y_;
  double y_mean_ = 0.0;
  double y_scale_ = 1.0;
  Eigen::VectorXd z_;             // standardized outputs
  Eigen::LLT<Eigen::MatrixXd> llt_;
  Eigen::VectorXd alpha_;         // (K + σ_n² I)⁻¹ z
  double jitter_ = 0.0;
};

/// A uniform number in [0, 1) from `rng` (53 bits: the same on every platform).
inline double Uniform(std::mt19937_64& rng) { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }

/// A standard normal number from `rng` by Box–Muller (the same sequence from
/// every standard library, unlike std::normal_distribution).
double StandardNormal(std::mt19937_64& rng);

/// The Matérn 5/2 kernel σ_f² (1 + √5 r + 5r²/3) e^{−√5 r}, r the distance
/// scaled by `lengthscales`.
double Matern52(const Eigen::VectorXd& a, const Eigen::VectorXd& b, const Eigen::VectorXd& lengthscales,
                double signal_variance);

/// Cholesky of `k` + jitter·I, the jitter growing tenfold from 1e-10 of the
/// mean diagonal until the factorization succeeds with every squared pivot
/// above 1e-12 of the mean diagonal; returns the jitter used.
double CholeskyWithJitter(const Eigen::MatrixXd& k, Eigen::LLT<Eigen::MatrixXd>& llt);

}  // namespace yamor::gp
