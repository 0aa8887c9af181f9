// cmaes: the (mu/mu_w, lambda)-CMA-ES of Hansen's tutorial ("The CMA
// Evolution Strategy: A Tutorial", 2016): weighted recombination of the best
// half, cumulative step-size adaptation, rank-one plus rank-mu covariance
// update, eigendecomposition with Eigen::SelfAdjointEigenSolver. It is the
// modern baseline the thesis did not have. Each generation's lambda samples
// are ONE parallel batch.
//
// Written here on Eigen rather than taken from pagmo because pagmo is not
// packaged in Debian 12 (the project uses Debian packages only).
//
// The search runs in normalized coordinates (each parameter's range mapped to
// [0, 1]), so sigma is a fraction of the ranges. Bounds: a sample outside the
// box is redrawn (up to kResampleTries times), then clamped onto the box; the
// update uses the point actually evaluated, so the distribution learns from
// what was measured. Redrawing keeps the distribution's shape honest away
// from the faces; the final clamp lets an optimum lying on a face (common for
// gait amplitudes) be sampled exactly.
//
// Optional IPOP restarts: when a run stops on its tolerances with budget
// left, a new run starts from a uniform random mean with twice the
// population.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <deque>
#include <numeric>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "yamor/optimizer_plugin.hpp"

namespace yamor::plugins::cmaes {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

constexpr int kResampleTries = 10;
// cond(C) above this: the distribution is degenerate, stop (tutorial's
// suggested 1e14).
constexpr double kMaxCondition = 1e14;

std::string Number(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.6g", v);
  return buffer;
}

// Standard normal numbers from the context's seeded generator (Box–Muller:
// the same sequence on every platform, unlike std::normal_distribution).
class Normal {
 public:
  explicit Normal(yamor::plugin::Context& context) : context_(context) {}
  double operator()() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    const double u1 = 1.0 - context_.Uniform();  // (0, 1]: log is finite
    const double u2 = context_.Uniform();
    const double r = std::sqrt(-2.0 * std::log(u1));
    spare_ = r * std::sin(2.0 * M_PI * u2);
    has_spare_ = true;
    return r * std::cos(2.0 * M_PI * u2);
  }

 private:
  yamor::plugin::Context& context_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

class Cmaes : public yamor::plugin::Optimizer {
 public:
  void Run(yamor::plugin::Context& context) override {
    n_ = context.Dimension();
    lower_ = context.Lower();
    upper_ = context.Upper();
    const long long population = context.IntField("population");
    if (population == 1) {
      throw std::invalid_argument("population = 1: CMA-ES needs at least 2 samples per generation");
    }
    const double sigma0 = context.RealField("sigma");
    const double xtol = context.RealField("xtol");
    const double ftol = context.RealField("ftol");
    const long long restarts = context.IntField("restarts");
    budget_ = context.IntField("max_evaluations");
    Normal normal(context);

    std::size_t lambda = population > 0
                             ? static_cast<std::size_t>(population)
                             : 4 + static_cast<std::size_t>(std::floor(3.0 * std::log(static_cast<double>(n_))));
    VectorXd mean(static_cast<Eigen::Index>(n_));
    const std::vector<double> start = context.Start();
    for (std::size_t i = 0; i < n_; ++i) {
      mean[static_cast<Eigen::Index>(i)] =
          context.BoolField("random_start") ? context.Uniform()
                                            : (start[i] - lower_[i]) / (upper_[i] - lower_[i]);
    }
    std::string reason;
    long long run = 0;
    try {
      while (true) {
        reason = RunOnce(context, normal, mean, sigma0, lambda, xtol, ftol);
        // A population beyond the budget could not finish one generation.
        if (run >= restarts || lambda > static_cast<std::size_t>(budget_) / 2) break;
        ++run;
        lambda *= 2;
        for (Eigen::Index i = 0; i < mean.size(); ++i) mean[i] = context.Uniform();
        context.Info("cmaes: restart " + std::to_string(run) + " after " + reason + ", population " +
                     std::to_string(lambda));
      }
    } catch (const yamor::plugin::Stopped&) {
      Summary(context, "budget or stop", run, lambda);
      throw;
    }
    Summary(context, reason, run, lambda);
  }

 private:
  // One CMA-ES run from `mean` until a tolerance stops it (returns which);
  // throws Stopped when the budget is spent.
  std::string RunOnce(yamor::plugin::Context& context, Normal& normal, VectorXd mean, double sigma,
                      std::size_t lambda, double xtol, double ftol) {
    const auto n = static_cast<Eigen::Index>(n_);
    const double nd = static_cast<double>(n_);
    const std::size_t mu = lambda / 2;
    VectorXd weights(static_cast<Eigen::Index>(mu));
    for (std::size_t i = 0; i < mu; ++i) {
      weights[static_cast<Eigen::Index>(i)] =
          std::log((static_cast<double>(lambda) + 1.0) / 2.0) - std::log(static_cast<double>(i + 1));
    }
    weights /= weights.sum();
    const double mueff = 1.0 / weights.squaredNorm();
    const double cs = (mueff + 2.0) / (nd + mueff + 5.0);
    const double ds = 1.0 + 2.0 * std::max(0.0, std::sqrt((mueff - 1.0) / (nd + 1.0)) - 1.0) + cs;
    const double cc = (4.0 + mueff / nd) / (nd + 4.0 + 2.0 * mueff / nd);
    const double c1 = 2.0 / ((nd + 1.3) * (nd + 1.3) + mueff);
    const double cmu =
        std::min(1.0 - c1, 2.0 * (mueff - 2.0 + 1.0 / mueff) / ((nd + 2.0) * (nd + 2.0) + mueff));
    const double chi_n = std::sqrt(nd) * (1.0 - 1.0 / (4.0 * nd) + 1.0 / (21.0 * nd * nd));
    // The tutorial's flat-fitness window: 10 + ceil(30 n / lambda) generations.
    const std::size_t history_length =
        10 + static_cast<std::size_t>(std::ceil(30.0 * nd / static_cast<double>(lambda)));

    VectorXd ps = VectorXd::Zero(n), pc = VectorXd::Zero(n);
    MatrixXd cov = MatrixXd::Identity(n, n), basis = MatrixXd::Identity(n, n);
    VectorXd axes = VectorXd::Ones(n);  // sqrt of C's eigenvalues
    MatrixXd inv_sqrt_cov = MatrixXd::Identity(n, n);
    std::deque<double> history;  // best value of each recent generation

    for (long long generation = 0;; ++generation) {
      std::vector<VectorXd> samples(lambda);
      std::vector<std::vector<double>> batch(lambda, std::vector<double>(n_));
      for (std::size_t k = 0; k < lambda; ++k) {
        VectorXd x(n), z(n);
        for (int attempt = 0; attempt < kResampleTries; ++attempt) {
          for (Eigen::Index i = 0; i < n; ++i) z[i] = normal();
          x = mean + sigma * (basis * axes.cwiseProduct(z));
          if ((x.array() >= 0.0).all() && (x.array() <= 1.0).all()) break;
        }
        x = x.cwiseMax(0.0).cwiseMin(1.0);
        samples[k] = x;
        for (std::size_t i = 0; i < n_; ++i) {
          batch[k][i] = ToReal(x[static_cast<Eigen::Index>(i)], lower_[i], upper_[i]);
        }
      }
      const std::vector<double> values = context.Evaluate(batch);
      evaluations_ += static_cast<long long>(lambda);
      ++generations_;

      std::vector<std::size_t> order(lambda);
      std::iota(order.begin(), order.end(), std::size_t{0});
      std::stable_sort(order.begin(), order.end(),
                       [&](std::size_t a, std::size_t b) { return values[a] > values[b]; });
      if (!has_best_ || values[order[0]] > best_value_) {
        has_best_ = true;
        best_value_ = values[order[0]];
        best_ = batch[order[0]];
      }

      // Recombination and the evolution paths (tutorial eqs. 39–47).
      const VectorXd old_mean = mean;
      MatrixXd ys(n, static_cast<Eigen::Index>(mu));
      for (std::size_t i = 0; i < mu; ++i) {
        ys.col(static_cast<Eigen::Index>(i)) = (samples[order[i]] - old_mean) / sigma;
      }
      const VectorXd yw = ys * weights;
      mean = old_mean + sigma * yw;
      ps = (1.0 - cs) * ps + std::sqrt(cs * (2.0 - cs) * mueff) * (inv_sqrt_cov * yw);
      const double ps_norm = ps.norm();
      const bool hsig =
          ps_norm / std::sqrt(1.0 - std::pow(1.0 - cs, 2.0 * static_cast<double>(generation + 1))) <
          (1.4 + 2.0 / (nd + 1.0)) * chi_n;
      pc = (1.0 - cc) * pc + (hsig ? std::sqrt(cc * (2.0 - cc) * mueff) : 0.0) * yw;
      const double delta_h = hsig ? 0.0 : cc * (2.0 - cc);
      cov = (1.0 - c1 - cmu) * cov + c1 * (pc * pc.transpose() + delta_h * cov) +
            cmu * ys * weights.asDiagonal() * ys.transpose();
      sigma *= std::exp((cs / ds) * (ps_norm / chi_n - 1.0));

      // C = B·diag(D²)·Bᵀ, kept symmetric against rounding.
      cov = (0.5 * (cov + cov.transpose())).eval();
      Eigen::SelfAdjointEigenSolver<MatrixXd> eigen(cov);
      if (eigen.info() != Eigen::Success || !cov.allFinite() || !mean.allFinite() ||
          !std::isfinite(sigma)) {
        return "numerical breakdown";
      }
      basis = eigen.eigenvectors();
      axes = eigen.eigenvalues().cwiseMax(1e-300).cwiseSqrt();
      inv_sqrt_cov = basis * axes.cwiseInverse().asDiagonal() * basis.transpose();
      // A step wider than the whole box only samples the faces: cap it.
      if (sigma * axes.maxCoeff() > 1.0) sigma = 1.0 / axes.maxCoeff();

      history.push_back(values[order[0]]);
      if (history.size() > history_length) history.pop_front();
      context.Progress(std::min(1.0, static_cast<double>(evaluations_) / static_cast<double>(budget_)),
                       "generation " + std::to_string(generations_) + ", sigma " + Number(sigma) +
                           ", best " + Number(best_value_));

      if (sigma * axes.maxCoeff() < xtol) return "xtol (largest std " + Number(sigma * axes.maxCoeff()) + ")";
      if (ftol > 0.0 && history.size() >= history_length) {
        const auto [lo, hi] = std::minmax_element(history.begin(), history.end());
        const auto [vlo, vhi] = std::minmax_element(values.begin(), values.end());
        if (std::max(*hi, *vhi) - std::min(*lo, *vlo) < ftol) return "ftol";
      }
      const double condition = (axes.maxCoeff() / axes.minCoeff());
      if (condition * condition > kMaxCondition) return "condition of C";
    }
  }

  // Normalized u in [0, 1] to the parameter's value, never outside [lo, hi].
  static double ToReal(double u, double lo, double hi) {
    if (u >= 1.0) return hi;
    if (u <= 0.0) return lo;
    return std::clamp(lo + u * (hi - lo), lo, hi);
  }

  void Summary(yamor::plugin::Context& context, const std::string& reason, long long restarts,
               std::size_t lambda) const {
    // A generation cut short by the budget never reaches the plugin: the
    // best named here is that of complete generations.
    std::string text = "cmaes: " + std::to_string(generations_) + " complete generations, " +
                       std::to_string(restarts) + " restarts, last population " +
                       std::to_string(lambda) + ", stopped by " + reason;
    if (has_best_) {
      text += ", best " + Number(best_value_) + " at";
      for (std::size_t i = 0; i < best_.size(); ++i) {
        text += std::string(i == 0 ? " " : ", ") + context.Parameter(i).name + "=" + Number(best_[i]);
      }
    }
    context.Info(text);
  }

  std::size_t n_ = 0;
  std::vector<double> lower_, upper_;
  long long budget_ = 1;
  long long evaluations_ = 0;
  long long generations_ = 0;
  std::vector<double> best_;
  double best_value_ = 0.0;
  bool has_best_ = false;
};

const YamorField kFields[] = {
    {"sigma", "initial step size, as a fraction of each parameter's range", YAMOR_FIELD_REAL, 1e-6, 1.0,
     "0.3", nullptr},
    {"population", "samples per generation, one parallel batch (0: 4 + floor(3 ln n))",
     YAMOR_FIELD_INTEGER, 0, 100000, "0", nullptr},
    {"xtol", "stop when every axis of the search distribution is below this (fraction of range)",
     YAMOR_FIELD_REAL, 0.0, 1.0, "1e-6", nullptr},
    {"ftol", "stop when recent generations' values span less than this (0: never)", YAMOR_FIELD_REAL,
     0.0, 1e9, "1e-12", nullptr},
    {"restarts", "IPOP restarts after a tolerance stop (random mean, population doubled)",
     YAMOR_FIELD_INTEGER, 0, 100, "0", nullptr},
    {"random_start", "first mean uniform at random instead of the configuration's values",
     YAMOR_FIELD_BOOLEAN, 0, 0, "false", nullptr},
};

}  // namespace
}  // namespace yamor::plugins::cmaes

YAMOR_OPTIMIZER_PLUGIN(yamor::plugins::cmaes::Cmaes, "cmaes", "1.0.0", "yamor",
                       "CMA-ES with bounds (own, on Eigen); each generation is one parallel batch",
                       yamor::plugins::cmaes::kFields)
