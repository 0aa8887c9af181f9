#include "optimizer-plugins/gp/gaussian_process.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <nlopt.h>

namespace yamor::gp {
namespace {

constexpr double kSqrt5 = 2.23606797749978969641;
constexpr double kLog2Pi = 1.83787706640934548356;
constexpr Eigen::Index kManyPoints = 100;

// log N(v; mean, sd) and its derivative in v.
double LogNormalDensity(double v, double mean, double sd, double* derivative) {
  const double z = (v - mean) / sd;
  *derivative = -z / sd;
  return -0.5 * z * z - std::log(sd) - 0.5 * kLog2Pi;
}

// The hyper-parameters as one vector θ (NLopt's variables) and back.
std::vector<double> Pack(const Hyperparameters& h) {
  std::vector<double> theta(h.log_lengthscales.data(), h.log_lengthscales.data() + h.log_lengthscales.size());
  theta.push_back(h.log_signal_variance);
  theta.push_back(h.log_noise_variance);
  return theta;
}

Hyperparameters Unpack(const double* theta, int d) {
  Hyperparameters h;
  h.log_lengthscales = Eigen::Map<const Eigen::VectorXd>(theta, d);
  h.log_signal_variance = theta[d];
  h.log_noise_variance = theta[d + 1];
  return h;
}

struct FitObjective {
  const GaussianProcess* gp;
  int dimension;
  static double Call(unsigned n, const double* theta, double* grad, void* data) {
    const auto* self = static_cast<const FitObjective*>(data);
    Eigen::VectorXd g;
    const double value = self->gp->LogPosterior(Unpack(theta, self->dimension), grad != nullptr ? &g : nullptr);
    if (grad != nullptr) {
      for (unsigned i = 0; i < n; ++i) grad[i] = std::isfinite(value) ? g[i] : 0.0;
    }
    // NLopt cannot use NaN or inf; a hopeless θ is just very unlikely.
    return std::isfinite(value) ? value : -1e300;
  }
};

}  // namespace

double StandardNormal(std::mt19937_64& rng) {
  const double u1 = 1.0 - Uniform(rng);  // (0, 1]: the log is finite
  const double u2 = Uniform(rng);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
}

double Matern52(const Eigen::VectorXd& a, const Eigen::VectorXd& b, const Eigen::VectorXd& lengthscales,
                double signal_variance) {
  const double r = ((a - b).array() / lengthscales.array()).matrix().norm();
  return signal_variance * (1.0 + kSqrt5 * r + 5.0 / 3.0 * r * r) * std::exp(-kSqrt5 * r);
}

double CholeskyWithJitter(const Eigen::MatrixXd& k, Eigen::LLT<Eigen::MatrixXd>& llt) {
  const double scale = std::max(k.diagonal().mean(), 1e-300);
  // Repeated or nearly repeated points make K singular to rounding: Eigen
  // may then fail, or succeed with pivots at rounding level whose solves are
  // noise. Either is a failure here; a growing diagonal makes K definite
  // long before it changes the model.
  const auto good = [&] {
    return llt.info() == Eigen::Success &&
           llt.matrixLLT().diagonal().array().square().minCoeff() > 1e-12 * scale;
  };
  llt.compute(k);
  if (good()) return 0.0;
  for (double jitter = 1e-10 * scale;; jitter *= 10.0) {
    Eigen::MatrixXd shifted = k;
    shifted.diagonal().array() += jitter;
    llt.compute(shifted);
    if (good()) return jitter;
    if (!(jitter < 1e10 * scale)) {
      throw std::runtime_error("the covariance matrix cannot be factorized (non-finite entries?)");
    }
  }
}

GaussianProcess::GaussianProcess(int dimension, Priors priors, std::vector<bool> periodic)
    : dimension_(dimension), priors_(priors), periodic_(std::move(periodic)) {
  if (dimension < 1) throw std::invalid_argument("GP dimension " + std::to_string(dimension) + " < 1");
  if (periodic_.empty()) periodic_.assign(static_cast<std::size_t>(dimension), false);
  if (periodic_.size() != static_cast<std::size_t>(dimension)) {
    throw std::invalid_argument("GP: " + std::to_string(periodic_.size()) + " periodic flags for dimension " +
                                std::to_string(dimension));
  }
  if (!(priors_.noise_floor > 0.0) || !(priors_.lengthscale_log_sd > 0.0) || !(priors_.signal_log_sd > 0.0) ||
      !(priors_.noise_log_sd > 0.0)) {
    throw std::invalid_argument("GP priors: the noise floor " + std::to_string(priors_.noise_floor) +
                                " and every prior's spread must be > 0");
  }
  h_ = Mode();
  x_.resize(0, dimension);
}

Hyperparameters GaussianProcess::Mode() const {
  Hyperparameters h;
  h.log_lengthscales = Eigen::VectorXd::Constant(dimension_, priors_.lengthscale_log_mean);
  h.log_signal_variance = priors_.signal_log_mean;
  h.log_noise_variance = priors_.noise_log_mean;
  return Clamp(h);
}

Hyperparameters GaussianProcess::Clamp(Hyperparameters h) const {
  h.log_lengthscales = h.log_lengthscales.cwiseMax(std::log(priors_.min_lengthscale))
                           .cwiseMin(std::log(priors_.max_lengthscale));
  h.log_signal_variance = std::clamp(h.log_signal_variance, std::log(priors_.min_signal_variance),
                                     std::log(priors_.max_signal_variance));
  h.log_noise_variance = std::clamp(h.log_noise_variance, std::log(priors_.noise_floor), std::log(2.0));
  return h;
}

void GaussianProcess::SetData(const Eigen::MatrixXd& x, const Eigen::VectorXd& y, bool keep_standardization) {
  if (x.cols() != dimension_ || x.rows() != y.size()) {
    throw std::invalid_argument("GP data: " + std::to_string(x.rows()) + " points of " +
                                std::to_string(x.cols()) + " values and " + std::to_string(y.size()) +
                                " outputs for dimension " + std::to_string(dimension_));
  }
  for (Eigen::Index i = 0; i < x.rows(); ++i) {
    if (!std::isfinite(y[i])) throw std::invalid_argument("GP data: output " + std::to_string(i) + " is not finite");
    for (Eigen::Index j = 0; j < x.cols(); ++j) {
      if (!(x(i, j) >= 0.0 && x(i, j) <= 1.0)) {
        throw std::invalid_argument("GP data: point " + std::to_string(i) + " coordinate " + std::to_string(j) +
                                    " = " + std::to_string(x(i, j)) + " is outside [0, 1]");
      }
    }
  }
  x_ = x;
  y_ = y;
  if (!keep_standardization) {
    const auto n = static_cast<double>(y.size());
    y_mean_ = n > 0 ? y.mean() : 0.0;
    y_scale_ = n > 1 ? std::sqrt((y.array() - y_mean_).square().sum() / (n - 1.0)) : 1.0;
    if (!(y_scale_ > 1e-12 * std::max(1.0, std::abs(y_mean_)))) y_scale_ = 1.0;  // all equal
  }
  z_ = (y.array() - y_mean_) / y_scale_;
  Factorize();
}

void GaussianProcess::SetHyperparameters(const Hyperparameters& h) {
  if (h.log_lengthscales.size() != dimension_) {
    throw std::invalid_argument("GP hyper-parameters: " + std::to_string(h.log_lengthscales.size()) +
                                " length scales for dimension " + std::to_string(dimension_));
  }
  h_ = Clamp(h);
  Factorize();
}

void GaussianProcess::Factorize() {
  const Eigen::Index n = x_.rows();
  jitter_ = 0.0;
  if (n == 0) return;
  const Eigen::VectorXd inverse_l = (-h_.log_lengthscales).array().exp();
  const double sf2 = std::exp(h_.log_signal_variance);
  Eigen::MatrixXd k(n, n);
  for (Eigen::Index a = 0; a < n; ++a) {
    k(a, a) = sf2 + std::exp(h_.log_noise_variance);
    for (Eigen::Index b = 0; b < a; ++b) {
      const double r = std::sqrt(StoredDistance2(inverse_l, a, b));
      k(a, b) = k(b, a) = sf2 * (1.0 + kSqrt5 * r + 5.0 / 3.0 * r * r) * std::exp(-kSqrt5 * r);
    }
  }
  jitter_ = CholeskyWithJitter(k, llt_);
  alpha_ = llt_.solve(z_);
}

double GaussianProcess::Kernel(const Eigen::VectorXd& a, const Eigen::VectorXd& b) const {
  double r2 = 0.0;
  for (int j = 0; j < dimension_; ++j) {
    const double t = Difference(j, a[j], b[j]) * std::exp(-h_.log_lengthscales[j]);
    r2 += t * t;
  }
  const double r = std::sqrt(r2);
  return std::exp(h_.log_signal_variance) * (1.0 + kSqrt5 * r + 5.0 / 3.0 * r2) * std::exp(-kSqrt5 * r);
}

double GaussianProcess::StoredDistance2(const Eigen::VectorXd& inverse_l, Eigen::Index a, Eigen::Index b) const {
  double r2 = 0.0;
  for (int j = 0; j < dimension_; ++j) {
    const double t = Difference(j, x_(a, j), x_(b, j)) * inverse_l[j];
    r2 += t * t;
  }
  return r2;
}

Prediction GaussianProcess::Predict(const Eigen::VectorXd& x) const {
  const double sf2 = std::exp(h_.log_signal_variance);
  const Eigen::Index n = x_.rows();
  if (n == 0) return {y_mean_, sf2 * y_scale_ * y_scale_};
  // Called thousands of times per proposal: no temporaries per kernel value.
  const Eigen::VectorXd inverse_l = (-h_.log_lengthscales).array().exp();
  Eigen::VectorXd ks(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    double r2 = 0.0;
    for (int j = 0; j < dimension_; ++j) {
      const double t = Difference(j, x[j], x_(i, j)) * inverse_l[j];
      r2 += t * t;
    }
    const double r = std::sqrt(r2);
    ks[i] = sf2 * (1.0 + kSqrt5 * r + 5.0 / 3.0 * r2) * std::exp(-kSqrt5 * r);
  }
  const Eigen::VectorXd v = llt_.matrixL().solve(ks);
  const double variance = std::max(0.0, sf2 - v.squaredNorm());
  return {y_mean_ + y_scale_ * ks.dot(alpha_), y_scale_ * y_scale_ * variance};
}

double GaussianProcess::LogPosterior(const Hyperparameters& h, Eigen::VectorXd* gradient) const {
  const int d = dimension_;
  const Eigen::Index n = x_.rows();
  const Eigen::VectorXd inverse_l = (-h.log_lengthscales).array().exp();
  const double sf2 = std::exp(h.log_signal_variance);
  const double sn2 = std::exp(h.log_noise_variance);
  Eigen::VectorXd g = Eigen::VectorXd::Zero(d + 2);
  double value = 0.0;
  if (n > 0) {
    // K and G = −(∂k/∂r)/r, since ∂k/∂log ℓ_i = G·(Δ_i/ℓ_i)² (r cancels: no
    // singularity at repeated points).
    Eigen::MatrixXd k(n, n), gmat(n, n);
    for (Eigen::Index a = 0; a < n; ++a) {
      k(a, a) = sf2 + sn2;
      gmat(a, a) = 0.0;
      for (Eigen::Index b = 0; b < a; ++b) {
        const double r = std::sqrt(StoredDistance2(inverse_l, a, b));
        const double e = std::exp(-kSqrt5 * r);
        k(a, b) = k(b, a) = sf2 * (1.0 + kSqrt5 * r + 5.0 / 3.0 * r * r) * e;
        gmat(a, b) = gmat(b, a) = sf2 * 5.0 / 3.0 * (1.0 + kSqrt5 * r) * e;
      }
    }
    Eigen::LLT<Eigen::MatrixXd> llt;
    CholeskyWithJitter(k, llt);
    const Eigen::VectorXd alpha = llt.solve(z_);
    const Eigen::MatrixXd lower = llt.matrixL();
    value = -0.5 * z_.dot(alpha) - lower.diagonal().array().log().sum() - 0.5 * static_cast<double>(n) * kLog2Pi;
    if (gradient != nullptr) {
      // ∂/∂θ = ½ tr((ααᵀ − K⁻¹) ∂K/∂θ).
      Eigen::MatrixXd w = alpha * alpha.transpose() - llt.solve(Eigen::MatrixXd::Identity(n, n));
      for (Eigen::Index a = 0; a < n; ++a) {
        for (Eigen::Index b = 0; b < a; ++b) {
          const double wg = w(a, b) * gmat(a, b);
          for (int i = 0; i < d; ++i) {
            const double s = Difference(i, x_(a, i), x_(b, i)) * inverse_l[i];
            g[i] += wg * s * s;  // both triangles: 2 × ½
          }
          g[d] += w(a, b) * k(a, b);
        }
      }
      g[d] += 0.5 * sf2 * w.diagonal().sum();  // the diagonal's σ_f²
      g[d + 1] = 0.5 * sn2 * w.diagonal().sum();
    }
  }
  double dp = 0.0;
  for (int i = 0; i < d; ++i) {
    value += LogNormalDensity(h.log_lengthscales[i], priors_.lengthscale_log_mean, priors_.lengthscale_log_sd, &dp);
    g[i] += dp;
  }
  value += LogNormalDensity(h.log_signal_variance, priors_.signal_log_mean, priors_.signal_log_sd, &dp);
  g[d] += dp;
  value += LogNormalDensity(h.log_noise_variance, priors_.noise_log_mean, priors_.noise_log_sd, &dp);
  g[d + 1] += dp;
  if (gradient != nullptr) *gradient = g;
  return value;
}

void GaussianProcess::Fit(std::mt19937_64& rng, int restarts) {
  if (x_.rows() == 0) return;
  const int d = dimension_;
  const auto size = static_cast<unsigned>(d + 2);
  std::vector<double> lower(size), upper(size);
  std::fill_n(lower.begin(), d, std::log(priors_.min_lengthscale));
  std::fill_n(upper.begin(), d, std::log(priors_.max_lengthscale));
  lower[d] = std::log(priors_.min_signal_variance);
  upper[d] = std::log(priors_.max_signal_variance);
  lower[d + 1] = std::log(priors_.noise_floor);
  upper[d + 1] = std::log(2.0);

  std::vector<Hyperparameters> starts = {h_, Mode()};
  // Beyond kManyPoints the posterior has settled near the previous fit and
  // every start costs O(n³) per step: no random starts.
  for (int k = 0; k < (x_.rows() > kManyPoints ? 0 : restarts); ++k) {
    Hyperparameters h;
    h.log_lengthscales.resize(d);
    for (int i = 0; i < d; ++i) {
      h.log_lengthscales[i] = priors_.lengthscale_log_mean + priors_.lengthscale_log_sd * StandardNormal(rng);
    }
    h.log_signal_variance = priors_.signal_log_mean + priors_.signal_log_sd * StandardNormal(rng);
    h.log_noise_variance = priors_.noise_log_mean + priors_.noise_log_sd * StandardNormal(rng);
    starts.push_back(Clamp(h));
  }

  FitObjective objective{this, d};
  Hyperparameters best = h_;
  double best_value = LogPosterior(h_, nullptr);
  if (!std::isfinite(best_value)) best_value = -std::numeric_limits<double>::infinity();
  for (const Hyperparameters& start : starts) {
    nlopt_opt opt = nlopt_create(NLOPT_LD_LBFGS, size);
    if (opt == nullptr) throw std::runtime_error("nlopt_create failed (out of memory)");
    nlopt_set_lower_bounds(opt, lower.data());
    nlopt_set_upper_bounds(opt, upper.data());
    nlopt_set_max_objective(opt, &FitObjective::Call, &objective);
    nlopt_set_maxeval(opt, 200);
    nlopt_set_ftol_rel(opt, 1e-8);
    nlopt_set_xtol_abs1(opt, 1e-6);
    std::vector<double> theta = Pack(start);
    double value = 0.0;
    // Any result, a roundoff-limited stop included, leaves θ at the best
    // point NLopt saw; its value decides.
    nlopt_optimize(opt, theta.data(), &value);
    nlopt_destroy(opt);
    const Hyperparameters found = Clamp(Unpack(theta.data(), d));
    const double found_value = LogPosterior(found, nullptr);
    if (std::isfinite(found_value) && found_value > best_value) {
      best_value = found_value;
      best = found;
    }
  }
  h_ = best;
  Factorize();
}

}  // namespace yamor::gp
