// The Gaussian process: its posterior against the closed form of a 1-D case,
// the analytic gradient of the MAP objective against finite differences, a
// known length scale recovered from samples of a GP with that scale,
// repeated points, and the acquisitions' numerics.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "optimizer-plugins/gp/acquisition.h"
#include "optimizer-plugins/gp/gaussian_process.h"

namespace yamor::gp {
namespace {

// Matérn 5/2 written out for one input.
double Matern1d(double r, double l, double sf2) {
  const double s = std::sqrt(5.0) * std::abs(r) / l;
  return sf2 * (1.0 + s + s * s / 3.0) * std::exp(-s);
}

Hyperparameters Fixed(std::vector<double> lengthscales, double sf2, double sn2) {
  Hyperparameters h;
  h.log_lengthscales = Eigen::Map<Eigen::VectorXd>(lengthscales.data(), static_cast<Eigen::Index>(lengthscales.size()))
                           .array()
                           .log();
  h.log_signal_variance = std::log(sf2);
  h.log_noise_variance = std::log(sn2);
  return h;
}

TEST(GaussianProcessTest, PosteriorMatchesTheClosedFormOfTwoPoints) {
  // Two observations, fixed hyper-parameters: with m = ȳ, s the sample
  // standard deviation, z = (y − m)/s and K the 2×2 covariance,
  // mean(x) = m + s·k*ᵀK⁻¹z and var(x) = s²(σ_f² − k*ᵀK⁻¹k*).
  const double l = 0.3, sf2 = 1.5, sn2 = 0.01;
  const double xa = 0.2, xb = 0.7, ya = 1.0, yb = 3.0;
  GaussianProcess gp(1);
  gp.SetHyperparameters(Fixed({l}, sf2, sn2));
  Eigen::MatrixXd x(2, 1);
  x << xa, xb;
  gp.SetData(x, Eigen::Vector2d(ya, yb));
  const double m = 2.0, s = std::sqrt(2.0);
  const double za = (ya - m) / s, zb = (yb - m) / s;
  const double a = sf2 + sn2, b = Matern1d(xa - xb, l, sf2), det = a * a - b * b;
  for (double xs : {0.0, 0.2, 0.45, 0.9, 1.0}) {
    const double ka = Matern1d(xs - xa, l, sf2), kb = Matern1d(xs - xb, l, sf2);
    // K⁻¹ = [[a, −b], [−b, a]] / det.
    const double wa = (a * za - b * zb) / det, wb = (a * zb - b * za) / det;
    const double quad = (a * ka * ka - 2.0 * b * ka * kb + a * kb * kb) / det;
    const Prediction p = gp.Predict(Eigen::VectorXd::Constant(1, xs));
    EXPECT_NEAR(p.mean, m + s * (ka * wa + kb * wb), 1e-12) << "x = " << xs;
    EXPECT_NEAR(p.variance, s * s * (sf2 - quad), 1e-12) << "x = " << xs;
  }
  EXPECT_EQ(gp.jitter(), 0.0);
}

TEST(GaussianProcessTest, WithoutDataThePosteriorIsThePrior) {
  GaussianProcess gp(2);
  gp.SetHyperparameters(Fixed({0.5, 0.5}, 2.0, 1e-3));
  const Prediction p = gp.Predict(Eigen::Vector2d(0.3, 0.3));
  EXPECT_EQ(p.mean, 0.0);
  EXPECT_NEAR(p.variance, 2.0, 1e-15);
}

TEST(GaussianProcessTest, APeriodicInputWrapsAround) {
  // 0.01 and 0.99 are 0.02 apart around the circle: as correlated as 0.01
  // and 0.03 (chord sin(0.02π)/π both), where a plain input keeps them 0.98 apart.
  GaussianProcess periodic(2, {}, {true, false});
  GaussianProcess plain(2);
  for (GaussianProcess* gp : {&periodic, &plain}) gp->SetHyperparameters(Fixed({0.1, 0.1}, 1.0, 1e-4));
  const Eigen::Vector2d a(0.01, 0.5), b(0.99, 0.5), c(0.03, 0.5);
  EXPECT_NEAR(periodic.Kernel(a, b), periodic.Kernel(a, c), 1e-12);
  EXPECT_NEAR(periodic.Kernel(a, c), Matern52(a, Eigen::Vector2d(0.01 + std::sin(0.02 * M_PI) / M_PI, 0.5),
                                              Eigen::Vector2d(0.1, 0.1), 1.0), 1e-12);
  EXPECT_LT(plain.Kernel(a, b), 1e-6);
  EXPECT_THROW(GaussianProcess(2, {}, {true}), std::invalid_argument);
}

TEST(GaussianProcessTest, LogPosteriorGradientMatchesFiniteDifferences) {
  std::mt19937_64 rng(7);
  const int d = 3, n = 12;
  Eigen::MatrixXd x(n, d);
  Eigen::VectorXd y(n);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < d; ++j) x(i, j) = Uniform(rng);
    y[i] = std::sin(5.0 * x(i, 0)) + x(i, 1) * x(i, 2);
  }
  GaussianProcess gp(d, {}, {false, true, false});  // one periodic input: its chord too
  gp.SetData(x, y);
  const Hyperparameters h = Fixed({0.3, 0.8, 1.7}, 0.9, 0.02);
  Eigen::VectorXd gradient;
  gp.LogPosterior(h, &gradient);
  ASSERT_EQ(gradient.size(), d + 2);
  for (int k = 0; k < d + 2; ++k) {
    const double e = 1e-6;
    Hyperparameters plus = h, minus = h;
    if (k < d) {
      plus.log_lengthscales[k] += e;
      minus.log_lengthscales[k] -= e;
    } else if (k == d) {
      plus.log_signal_variance += e;
      minus.log_signal_variance -= e;
    } else {
      plus.log_noise_variance += e;
      minus.log_noise_variance -= e;
    }
    const double numeric = (gp.LogPosterior(plus, nullptr) - gp.LogPosterior(minus, nullptr)) / (2.0 * e);
    EXPECT_NEAR(gradient[k], numeric, 1e-5 * std::max(1.0, std::abs(numeric))) << "component " << k;
  }
}

// Draws y at `x` from a zero-mean GP with `lengthscales` and unit variance.
Eigen::VectorXd SampleGp(const Eigen::MatrixXd& x, const std::vector<double>& lengthscales, std::mt19937_64& rng) {
  const Eigen::Index n = x.rows();
  const Eigen::VectorXd l = Eigen::Map<const Eigen::VectorXd>(lengthscales.data(), x.cols());
  Eigen::MatrixXd k(n, n);
  for (Eigen::Index a = 0; a < n; ++a) {
    for (Eigen::Index b = 0; b < n; ++b) k(a, b) = Matern52(x.row(a), x.row(b), l, 1.0);
  }
  k.diagonal().array() += 1e-8;
  Eigen::LLT<Eigen::MatrixXd> llt(k);
  Eigen::VectorXd z(n);
  for (Eigen::Index i = 0; i < n; ++i) z[i] = StandardNormal(rng);
  return llt.matrixL() * z;
}

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.size() % 2 == 1 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

TEST(GaussianProcessTest, RecoversAKnownLengthScale) {
  // 60 points of a 1-D GP with ℓ = 0.15, five draws: the MAP length scale's
  // median lies within 30 % of the truth (the prior's median is 0.5).
  std::vector<double> found;
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    std::mt19937_64 rng(seed);
    Eigen::MatrixXd x(60, 1);
    for (int i = 0; i < 60; ++i) x(i, 0) = Uniform(rng);
    GaussianProcess gp(1);
    gp.SetData(x, SampleGp(x, {0.15}, rng));
    gp.Fit(rng);
    found.push_back(std::exp(gp.hyperparameters().log_lengthscales[0]));
  }
  EXPECT_NEAR(Median(found), 0.15, 0.3 * 0.15);
}

TEST(GaussianProcessTest, RecoversWhichInputMattersMore) {
  // ARD: 2-D samples with ℓ = (0.2, 2): the fit finds the first input an
  // order of magnitude more wiggly than the second.
  std::mt19937_64 rng(3);
  Eigen::MatrixXd x(80, 2);
  for (int i = 0; i < 80; ++i) x.row(i) << Uniform(rng), Uniform(rng);
  GaussianProcess gp(2);
  gp.SetData(x, SampleGp(x, {0.2, 2.0}, rng));
  gp.Fit(rng);
  const Eigen::VectorXd l = gp.hyperparameters().log_lengthscales.array().exp();
  EXPECT_NEAR(l[0], 0.2, 0.08);
  EXPECT_GT(l[1], 5.0 * l[0]);
}

TEST(GaussianProcessTest, RepeatedAndNearlyRepeatedPointsNeverFail) {
  // Ten copies of one point, two points 1e-13 apart, the smallest noise
  // floor: K is singular to rounding, the jitter makes it definite.
  Priors priors;
  priors.noise_floor = 1e-14;
  GaussianProcess gp(2, priors);
  Eigen::MatrixXd x(13, 2);
  Eigen::VectorXd y(13);
  for (int i = 0; i < 10; ++i) {
    x.row(i) << 0.5, 0.5;
    y[i] = 1.0 + 0.01 * i;
  }
  x.row(10) << 0.25, 0.75;
  x.row(11) << 0.25 + 1e-13, 0.75;
  x.row(12) << 1.0, 0.0;
  y.tail(3) << 0.3, 0.31, -2.0;
  Hyperparameters h = Fixed({5.0, 5.0}, 1.0, 1e-14);
  gp.SetHyperparameters(h);
  gp.SetData(x, y);
  EXPECT_GT(gp.jitter(), 0.0);
  std::mt19937_64 rng(1);
  gp.Fit(rng);
  for (const Eigen::Vector2d& p : {Eigen::Vector2d(0.5, 0.5), Eigen::Vector2d(0.25, 0.75), Eigen::Vector2d(0.9, 0.1)}) {
    const Prediction pr = gp.Predict(p);
    EXPECT_TRUE(std::isfinite(pr.mean));
    EXPECT_TRUE(std::isfinite(pr.variance));
    EXPECT_GE(pr.variance, 0.0);
  }
  EXPECT_NEAR(gp.Predict(Eigen::Vector2d(0.5, 0.5)).mean, 1.045, 0.05);  // the copies' mean
}

TEST(GaussianProcessTest, RefusesBadData) {
  GaussianProcess gp(2);
  Eigen::MatrixXd x(1, 2);
  x << 0.5, 1.5;
  EXPECT_THROW(gp.SetData(x, Eigen::VectorXd::Ones(1)), std::invalid_argument);
  x << 0.5, 0.5;
  EXPECT_THROW(gp.SetData(x, Eigen::VectorXd::Constant(1, std::nan(""))), std::invalid_argument);
  EXPECT_THROW(gp.SetData(x, Eigen::VectorXd::Ones(2)), std::invalid_argument);
  EXPECT_THROW(GaussianProcess(0), std::invalid_argument);
}

TEST(AcquisitionTest, LogExpectedImprovementIsTheLogOfTheClosedForm) {
  // EI = (μ − f*)Φ(z) + σφ(z), z = (μ − f*)/σ.
  for (double mean : {-3.0, -1.0, 0.0, 0.5, 2.0}) {
    const double sd = 0.7, best = 0.2, z = (mean - best) / sd;
    const double phi = std::exp(-0.5 * z * z) / std::sqrt(2.0 * M_PI);
    const double cdf = 0.5 * std::erfc(-z / std::sqrt(2.0));
    const double ei = (mean - best) * cdf + sd * phi;
    EXPECT_NEAR(ExpectedImprovement(mean, sd, best), ei, 1e-14);
    EXPECT_NEAR(LogExpectedImprovement(mean, sd, best), std::log(ei), 1e-9) << mean;
  }
}

TEST(AcquisitionTest, LogExpectedImprovementRanksFarInTheTail) {
  // Where EI underflows to 0, log EI is finite and still increases with the mean.
  double previous = -std::numeric_limits<double>::infinity();
  for (double mean : {-400.0, -100.0, -40.0, -30.5, -29.5, -20.0, -5.0}) {
    const double v = LogExpectedImprovement(mean, 1.0, 0.0);
    EXPECT_TRUE(std::isfinite(v)) << mean;
    EXPECT_GT(v, previous) << mean;
    previous = v;
  }
  EXPECT_EQ(ExpectedImprovement(-400.0, 1.0, 0.0), 0.0);
  // Continuous across the branch at z = −30: the series agrees with the exact form.
  EXPECT_NEAR(LogExpectedImprovement(-30.0 - 1e-9, 1.0, 0.0), LogExpectedImprovement(-30.0 + 1e-9, 1.0, 0.0), 1e-6);
}

TEST(AcquisitionTest, MaximizeInBoxFindsAnInteriorAndACornerMaximum) {
  const auto bump = [](const Eigen::VectorXd& x) { return -(x - Eigen::Vector3d(0.3, 0.71, 0.5)).squaredNorm(); };
  const Eigen::VectorXd best = MaximizeInBox(bump, 3, {}, {});
  EXPECT_NEAR((best - Eigen::Vector3d(0.3, 0.71, 0.5)).norm(), 0.0, 1e-5);
  const auto corner = [](const Eigen::VectorXd& x) { return x.sum(); };
  EXPECT_NEAR(MaximizeInBox(corner, 2, {}, {}).sum(), 2.0, 1e-9);
}

TEST(AcquisitionTest, LatinHypercubeHitsEveryStratumOnce) {
  std::mt19937_64 rng(5);
  const Eigen::MatrixXd design = LatinHypercube(10, 4, rng);
  for (int j = 0; j < 4; ++j) {
    std::vector<int> hits(10, 0);
    for (int i = 0; i < 10; ++i) {
      ASSERT_GE(design(i, j), 0.0);
      ASSERT_LT(design(i, j), 1.0);
      ++hits[static_cast<std::size_t>(design(i, j) * 10.0)];
    }
    EXPECT_EQ(hits, std::vector<int>(10, 1)) << "axis " << j;
  }
  std::mt19937_64 again(5);
  EXPECT_EQ(LatinHypercube(10, 4, again), design);
}

}  // namespace
}  // namespace yamor::gp
