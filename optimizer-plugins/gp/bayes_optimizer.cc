#include "optimizer-plugins/gp/bayes_optimizer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace yamor::gp {
namespace {

// Two proposals closer than this (unit box) are the same point: evaluating
// it again teaches a deterministic simulation nothing.
constexpr double kSamePoint = 1e-6;

double Seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

}  // namespace

BayesianOptimizer::BayesianOptimizer(BayesOptions options, std::uint64_t seed)
    : options_(options), rng_(seed), model_(options.dimension, options.priors, options.periodic) {
  side_ = options_.trust_region;
  if (!(options_.kappa >= 0.0) || options_.fit_restarts < 0 || options_.max_model_points < 0 ||
      options_.max_model_points == 1 || !(options_.trust_region >= 0.0 && options_.trust_region <= 1.0)) {
    throw std::invalid_argument("bayesian optimizer: kappa " + std::to_string(options_.kappa) + ", fit restarts " +
                                std::to_string(options_.fit_restarts) + ", max model points " +
                                std::to_string(options_.max_model_points) + " or trust region " +
                                std::to_string(options_.trust_region) + " is invalid");
  }
}

std::vector<Eigen::VectorXd> BayesianOptimizer::InitialDesign(int n, const Eigen::VectorXd& center) {
  std::vector<Eigen::VectorXd> design = InitialDesign(n);
  if (options_.trust_region <= 0.0) return design;
  if (center.size() != options_.dimension) throw std::invalid_argument("bayesian optimizer: a centre of the wrong size");
  const double side = options_.trust_region;
  for (Eigen::VectorXd& x : design) {
    for (Eigen::Index i = 0; i < x.size(); ++i) {
      // The region keeps its side against a face: shifted inside, not cut.
      const double lo = std::clamp(center[i] - 0.5 * side, 0.0, 1.0 - side);
      x[i] = std::clamp(lo + side * x[i], 0.0, 1.0);
    }
  }
  return design;
}

std::vector<Eigen::VectorXd> BayesianOptimizer::InitialDesign(int n) {
  const Eigen::MatrixXd design = LatinHypercube(n, options_.dimension, rng_);
  std::vector<Eigen::VectorXd> out;
  for (Eigen::Index i = 0; i < design.rows(); ++i) out.emplace_back(design.row(i).transpose());
  return out;
}

void BayesianOptimizer::Tell(const Eigen::VectorXd& x, double value) {
  if (x.size() != options_.dimension) {
    throw std::invalid_argument("bayesian optimizer: a point of " + std::to_string(x.size()) +
                                " values for dimension " + std::to_string(options_.dimension));
  }
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    if (!(x[i] >= 0.0 && x[i] <= 1.0)) {
      throw std::invalid_argument("bayesian optimizer: coordinate " + std::to_string(i) + " = " +
                                  std::to_string(x[i]) + " is outside [0, 1]");
    }
  }
  points_.push_back(x);
  values_.push_back(value);
  if (!std::isfinite(value)) ++failures_;
}

double BayesianOptimizer::Acquire(const GaussianProcess& gp, const Eigen::VectorXd& x, double incumbent) const {
  const Prediction p = gp.Predict(x);
  const double sd = std::sqrt(p.variance);
  if (options_.acquisition == Acquisition::kUpperConfidenceBound) return UpperConfidenceBound(p.mean, sd, options_.kappa);
  return LogExpectedImprovement(p.mean, sd, incumbent);
}

bool BayesianOptimizer::IsNew(const Eigen::VectorXd& x, const std::vector<Eigen::VectorXd>& others) const {
  return std::none_of(others.begin(), others.end(),
                      [&](const Eigen::VectorXd& o) { return (o - x).norm() < kSamePoint; });
}

Eigen::VectorXd BayesianOptimizer::FarthestRandomPoint(const std::vector<Eigen::VectorXd>& others) {
  Eigen::VectorXd best;
  double best_distance = -1.0;
  for (int k = 0; k < 100 * options_.dimension; ++k) {
    Eigen::VectorXd x(options_.dimension);
    for (Eigen::Index i = 0; i < x.size(); ++i) x[i] = Uniform(rng_);
    double distance = std::numeric_limits<double>::infinity();
    for (const Eigen::VectorXd& o : others) distance = std::min(distance, (o - x).norm());
    if (distance > best_distance) {
      best_distance = distance;
      best = x;
    }
  }
  return best;
}

void BayesianOptimizer::UpdateTrustRegion(double best, int q) {
  if (!std::isnan(best_at_last_ask_)) {
    if (best > best_at_last_ask_ + 1e-3 * std::abs(best_at_last_ask_)) {
      ++improving_;
      stalled_ = 0;
    } else {
      ++stalled_;
      improving_ = 0;
    }
  }
  best_at_last_ask_ = best;
  const int patience = static_cast<int>(std::ceil(std::max(4.0, static_cast<double>(options_.dimension)) / q));
  if (improving_ >= 3) {
    side_ = std::min(1.0, 2.0 * side_);
    improving_ = 0;
  } else if (stalled_ >= patience) {
    side_ *= 0.5;
    stalled_ = 0;
    if (side_ < 1.0 / 128.0) side_ = options_.trust_region;
  }
}

std::vector<std::size_t> BayesianOptimizer::ModelPoints(const std::vector<double>& values) const {
  std::vector<std::size_t> all(values.size());
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = i;
  const auto cap = static_cast<std::size_t>(options_.max_model_points);
  if (cap == 0 || all.size() <= cap) return all;
  // The best half by value (where the optimum is sought), then the most
  // recent (where the search is now), in observation order.
  std::vector<std::size_t> by_value = all;
  std::stable_sort(by_value.begin(), by_value.end(), [&](std::size_t a, std::size_t b) { return values[a] > values[b]; });
  std::vector<bool> keep(all.size(), false);
  for (std::size_t k = 0; k < cap / 2; ++k) keep[by_value[k]] = true;
  std::size_t kept = cap / 2;
  for (std::size_t i = all.size(); i-- > 0 && kept < cap;) {
    if (!keep[i]) {
      keep[i] = true;
      ++kept;
    }
  }
  std::vector<std::size_t> out;
  for (std::size_t i = 0; i < all.size(); ++i) {
    if (keep[i]) out.push_back(i);
  }
  return out;
}

std::vector<Eigen::VectorXd> BayesianOptimizer::Ask(int q) {
  if (q < 1) throw std::invalid_argument("bayesian optimizer: asked for " + std::to_string(q) + " points");
  const auto started = std::chrono::steady_clock::now();
  std::vector<Eigen::VectorXd> taken = points_;  // observed and proposed: what a new point must differ from
  std::vector<Eigen::VectorXd> batch;
  const auto finite = [](double v) { return std::isfinite(v); };
  if (std::none_of(values_.begin(), values_.end(), finite)) {
    for (const Eigen::VectorXd& x : InitialDesign(q)) {
      batch.push_back(IsNew(x, taken) ? x : FarthestRandomPoint(taken));
      taken.push_back(batch.back());
    }
    last_ask_seconds_ = Seconds(started);
    return batch;
  }

  double floor = std::numeric_limits<double>::infinity();
  for (double v : values_) {
    if (std::isfinite(v)) floor = std::min(floor, v);
  }
  std::vector<double> values = values_;
  for (double& v : values) {
    if (!std::isfinite(v)) v = floor;
  }
  const std::vector<std::size_t> kept = ModelPoints(values);
  const int n = static_cast<int>(kept.size());
  Eigen::MatrixXd x(n + q, options_.dimension);
  Eigen::VectorXd y(n + q);
  for (int i = 0; i < n; ++i) {
    x.row(i) = points_[kept[static_cast<std::size_t>(i)]].transpose();
    y[i] = values[kept[static_cast<std::size_t>(i)]];
  }
  model_.SetData(x.topRows(n), y.head(n));
  const auto fit_started = std::chrono::steady_clock::now();
  model_.Fit(rng_, options_.fit_restarts);
  last_fit_seconds_ = Seconds(fit_started);

  // The search box: the trust region around the best point, or the whole box.
  Eigen::VectorXd lower = Eigen::VectorXd::Zero(options_.dimension), upper = Eigen::VectorXd::Ones(options_.dimension);
  if (options_.trust_region > 0.0) {
    int best_index = 0;
    for (int i = 1; i < n; ++i) {
      if (y[i] > y[best_index]) best_index = i;
    }
    UpdateTrustRegion(y[best_index], q);
    const Eigen::VectorXd l = model_.hyperparameters().log_lengthscales.array().exp();
    const Eigen::VectorXd weights = l / std::exp(l.array().log().mean());  // geometric mean 1
    for (int i = 0; i < options_.dimension; ++i) {
      lower[i] = std::clamp(x(best_index, i) - 0.5 * side_ * weights[i], 0.0, 1.0);
      upper[i] = std::clamp(x(best_index, i) + 0.5 * side_ * weights[i], 0.0, 1.0);
      if (!(upper[i] - lower[i] > 1e-9)) upper[i] = std::min(1.0, lower[i] + 1e-9), lower[i] = upper[i] - 1e-9;
    }
  }

  GaussianProcess believer = model_;
  for (int k = 0; k < q; ++k) {
    // Incumbent: the best posterior mean at a point of the data (noisy EI);
    // the local search also starts there and at the best observed value.
    int incumbent_index = 0;
    double incumbent = -std::numeric_limits<double>::infinity();
    for (int i = 0; i < n + k; ++i) {
      const double mean = believer.Predict(x.row(i).transpose()).mean;
      if (mean > incumbent) {
        incumbent = mean;
        incumbent_index = i;
      }
    }
    int best_observed = 0;
    for (int i = 1; i < n; ++i) {
      if (y[i] > y[best_observed]) best_observed = i;
    }
    const std::vector<Eigen::VectorXd> starts = {x.row(incumbent_index).transpose(), x.row(best_observed).transpose()};
    Eigen::VectorXd next = MaximizeInBox(
        [&](const Eigen::VectorXd& p) { return Acquire(believer, p, incumbent); }, lower, upper, starts,
        options_.maximizer);
    if (!IsNew(next, taken)) next = FarthestRandomPoint(taken);
    taken.push_back(next);
    batch.push_back(next);
    if (k + 1 < q) {
      x.row(n + k) = next.transpose();
      y[n + k] = believer.Predict(next).mean;
      believer.SetData(x.topRows(n + k + 1), y.head(n + k + 1), /*keep_standardization=*/true);
    }
  }
  last_ask_seconds_ = Seconds(started);
  return batch;
}

}  // namespace yamor::gp
