// Tests of the CPG oscillator network against closed-form solutions of the
// thesis 6.1.1 equations.
#include "cpg/network.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <limits>
#include <new>
#include <numbers>
#include <random>
#include <ostream>
#include <string>
#include <vector>

#include "common/status.h"
#include "tests/support/code_of.h"

// Counts heap allocations so the test can prove Step() does not allocate.
namespace {
std::atomic<long> g_allocations{0};
}  // namespace

void* operator new(std::size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
// GCC 12 flags free() in a replacement operator delete once it inlines the
// pair; the pairing is correct (our operator new uses malloc).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
#pragma GCC diagnostic pop

namespace yamor::cpg {
namespace {

using ::testing::HasSubstr;

constexpr double kPi = std::numbers::pi;
constexpr double kTwoPi = 2.0 * std::numbers::pi;
// The five continuous state components.
constexpr std::vector<double> NetworkState::*kComponents[] = {
    &NetworkState::phase, &NetworkState::r, &NetworkState::dr, &NetworkState::x,
    &NetworkState::dx};

ModuleParams Module(ModuleId id, double amplitude, double offset, double speed,
                    double min_angle = -10.0, double max_angle = 10.0) {
  ModuleParams m;
  m.id = id;
  m.amplitude = amplitude;
  m.offset = offset;
  m.speed = speed;
  m.min_angle = min_angle;
  m.max_angle = max_angle;
  return m;
}

Coupling Link(ModuleId from, ModuleId to, double phase, double weight = 1.0) {
  return Coupling{from, to, phase, weight};
}

RobotConfig Config(std::vector<ModuleParams> modules,
                   std::vector<Coupling> couplings = {}) {
  RobotConfig config;
  config.modules = std::move(modules);
  config.couplings = std::move(couplings);
  return config;
}

// Angle reduced to (-pi, pi].
double Wrap(double angle) {
  double wrapped = std::remainder(angle, kTwoPi);
  if (wrapped <= -kPi) wrapped += kTwoPi;
  return wrapped;
}

// Closed-form solution of y'' = a (a/4 (target - y) - y'), critically damped
// (double root -a/2): y = target + (e0 + (v0 + a e0 / 2) t) exp(-a t / 2).
struct Damped {
  double a, target, y0, v0;
  double Value(double t) const {
    const double e0 = y0 - target;
    return target + (e0 + (v0 + 0.5 * a * e0) * t) * std::exp(-0.5 * a * t);
  }
  double Rate(double t) const {
    const double c1 = y0 - target;
    const double c2 = v0 + 0.5 * a * c1;
    return (c2 - 0.5 * a * (c1 + c2 * t)) * std::exp(-0.5 * a * t);
  }
};

using ::yamor::testing::CodeOf;

// --------------------------------------------------------- amplitude/offset --

class CpgNetworkAmplitude : public ::testing::TestWithParam<double> {};

TEST_P(CpgNetworkAmplitude, FollowsClosedFormFromRest) {
  const double a = GetParam();
  const double target = 0.7;
  const Network net =
      Network::Compile(Config({Module(3, target, 0.0, 0.5)}), {a, a});
  NetworkState s = net.InitialState();
  const double dt = 0.001;
  for (int k = 1; k <= 5000; ++k) {
    Step(net, s, dt);
    if (k % 25 != 0) continue;
    const double t = k * dt;
    // From r(0) = dr(0) = 0: r = R (1 - (1 + a t / 2) e^{-a t / 2}).
    const double expected = target * (1.0 - (1.0 + 0.5 * a * t) * std::exp(-0.5 * a * t));
    const double expected_rate = target * a * a * t / 4.0 * std::exp(-0.5 * a * t);
    ASSERT_NEAR(s.r[0], expected, 1e-6) << "t=" << t;
    ASSERT_NEAR(s.dr[0], expected_rate, 1e-6) << "t=" << t;
  }
  EXPECT_NEAR(s.r[0], target, 1e-3);  // converged within 5 s
}

INSTANTIATE_TEST_SUITE_P(Gains, CpgNetworkAmplitude, ::testing::Values(4.0, 6.5));

TEST(CpgNetworkTest, OffsetFollowsGeneralSolutionFromNonzeroStart) {
  const Network net = Network::Compile(Config({Module(1, 0.0, -0.4, 1.0)}));
  NetworkState s = net.InitialState();
  s.x[0] = 0.3;
  s.dx[0] = -1.2;
  const Damped expected{4.0, -0.4, 0.3, -1.2};
  const double dt = 0.002;
  for (int k = 1; k <= 3000; ++k) {
    Step(net, s, dt);
    if (k % 10 != 0) continue;
    const double t = k * dt;
    ASSERT_NEAR(s.x[0], expected.Value(t), 1e-6) << "t=" << t;
    ASSERT_NEAR(s.dx[0], expected.Rate(t), 1e-6) << "t=" << t;
  }
}

TEST(CpgNetworkTest, OffsetTargetChangeMidRunIsSmoothAndConverges) {
  RobotConfig config = Config({Module(1, 0.5, 0.5, 1.0), Module(2, 0.2, 0.0, 1.0)},
                              {Link(1, 2, 0.3), Link(2, 1, -0.3)});
  const Network before = Network::Compile(config);
  NetworkState s = before.InitialState();
  const double dt = 0.001;
  for (int k = 0; k < 1300; ++k) Step(before, s, dt);
  ASSERT_GT(std::abs(s.dx[0]), 0.01);  // still moving: a real mid-run change

  config.FindModule(1)->offset = -0.2;
  const Network after = Network::Compile(config);
  NetworkState changed = RemapState(before, s, after);
  // No jump at the change: the state is carried over exactly.
  EXPECT_EQ(changed, s);
  const double raw_before = RawOutput(before, s, 0);
  EXPECT_EQ(RawOutput(after, changed, 0), raw_before);

  const Damped expected{4.0, -0.2, s.x[0], s.dx[0]};
  const double t_change = s.time;
  double previous_x = changed.x[0];
  for (int k = 1; k <= 6000; ++k) {
    Step(after, changed, dt);
    // Continuous: x moves by at most |dx| dt plus O(dt^2).
    ASSERT_LT(std::abs(changed.x[0] - previous_x), 5.0 * dt);
    previous_x = changed.x[0];
    if (k % 20 != 0) continue;
    const double t = k * dt;
    ASSERT_NEAR(changed.x[0], expected.Value(t), 1e-6) << "t after change=" << t;
    ASSERT_NEAR(changed.dx[0], expected.Rate(t), 1e-6) << "t after change=" << t;
  }
  EXPECT_NEAR(changed.time, t_change + 6.0, 1e-9);
  EXPECT_NEAR(changed.x[0], -0.2, 1e-3);
}

// -------------------------------------------------------------------- phase --

TEST(CpgNetworkTest, UncoupledPhaseAdvancesAtTwoPiSpeed) {
  const Network net =
      Network::Compile(Config({Module(4, 0.3, 0.1, 0.7), Module(9, 0.5, 0.0, 2.3)}));
  NetworkState s = net.InitialState();
  const double dt = 0.001;
  for (int k = 1; k <= 10000; ++k) {
    Step(net, s, dt);
    if (k % 100 != 0) continue;
    const double t = k * dt;
    ASSERT_NEAR(s.phase[0], kTwoPi * 0.7 * t, 1e-9) << "t=" << t;
    ASSERT_NEAR(s.phase[1], kTwoPi * 2.3 * t, 1e-9) << "t=" << t;
  }
  EXPECT_NEAR(s.time, 10.0, 1e-9);
  EXPECT_DOUBLE_EQ(RawOutput(net, s, 1), s.x[1] + s.r[1] * std::cos(s.phase[1]));
}

class CpgNetworkLock : public ::testing::TestWithParam<std::uint64_t> {};

TEST_P(CpgNetworkLock, EqualFrequenciesLockToBias) {
  for (const double bias : {1.1, -2.5, 0.0}) {
    const Network net = Network::Compile(
        Config({Module(1, 1.0, 0.0, 1.0), Module(2, 1.0, 0.0, 1.0)},
               {Link(1, 2, bias), Link(2, 1, -bias)}));
    NetworkState s = net.InitialState(GetParam());
    ASSERT_NE(s.phase[0], s.phase[1]);
    for (int k = 0; k < 6000; ++k) Step(net, s, 0.005);
    // phi_2 - phi_1 -> bias (mod 2 pi), rotating at the common omega.
    EXPECT_NEAR(Wrap(s.phase[1] - s.phase[0] - bias), 0.0, 1e-6) << "bias " << bias;
    const double phase_before = s.phase[0];
    for (int k = 0; k < 200; ++k) Step(net, s, 0.005);
    EXPECT_NEAR((s.phase[0] - phase_before) / 1.0, kTwoPi, 1e-6);
  }
}

TEST_P(CpgNetworkLock, DifferentFrequenciesLockAtAnalyticFixedPoint) {
  // d(phi_B - phi_A)/dt = dOmega - (w_BA r_A + w_AB r_B) sin(delta - b):
  // locked where sin(delta - b) = dOmega / (w_BA R_A + w_AB R_B).
  const double f_a = 1.0, f_b = 1.1, r_a = 0.8, r_b = 1.2;
  const double w_ab = 1.0, w_ba = 0.6, bias = 0.5;
  const Network net = Network::Compile(
      Config({Module(10, r_a, 0.0, f_a), Module(20, r_b, 0.0, f_b)},
             {Link(10, 20, bias, w_ab), Link(20, 10, -bias, w_ba)}));
  NetworkState s = net.InitialState(GetParam());
  for (int k = 0; k < 8000; ++k) Step(net, s, 0.005);
  const double sine = kTwoPi * (f_b - f_a) / (w_ba * r_a + w_ab * r_b);
  ASSERT_LT(sine, 1.0);  // inside the locking range
  const double delta = bias + std::asin(sine);
  EXPECT_NEAR(Wrap(s.phase[1] - s.phase[0] - delta), 0.0, 1e-6);
  // Both rotate at the common locked frequency.
  const double locked_omega = kTwoPi * f_a + w_ab * r_b * sine;
  const NetworkState start = s;
  for (int k = 0; k < 400; ++k) Step(net, s, 0.005);
  EXPECT_NEAR((s.phase[0] - start.phase[0]) / 2.0, locked_omega, 1e-6);
  EXPECT_NEAR((s.phase[1] - start.phase[1]) / 2.0, locked_omega, 1e-6);
}

INSTANTIATE_TEST_SUITE_P(Seeds, CpgNetworkLock, ::testing::Values(1u, 2u, 3u, 42u, 2024u));

// Bidirectional ring: module k pulled by k+1 with bias b_k, k+1 by k with -b_k.
RobotConfig Ring(const std::vector<double>& biases) {
  std::vector<ModuleParams> modules;
  std::vector<Coupling> couplings;
  const int n = static_cast<int>(biases.size());
  for (int k = 0; k < n; ++k) modules.push_back(Module(k + 1, 0.6, 0.0, 0.8));
  for (int k = 0; k < n; ++k) {
    const int next = (k + 1) % n;
    couplings.push_back(Link(k + 1, next + 1, biases[k]));
    couplings.push_back(Link(next + 1, k + 1, -biases[k]));
  }
  return Config(modules, couplings);
}

void ExpectLockedToBiases(const NetworkState& s, const std::vector<double>& biases) {
  const std::size_t n = biases.size();
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t next = (k + 1) % n;
    EXPECT_NEAR(Wrap(s.phase[next] - s.phase[k] - biases[k]), 0.0, 1e-6)
        << "edge " << k << " -> " << next;
  }
}

TEST(CpgNetworkTest, RingOfFourLocksToBiasesFromRandomPhases) {
  const std::vector<double> biases(4, kPi / 2.0);  // sum = 2 pi
  const Network net = Network::Compile(Ring(biases));
  for (const std::uint64_t seed : {5u, 6u, 7u, 8u}) {
    NetworkState s = net.InitialState(seed);
    for (int k = 0; k < 8000; ++k) Step(net, s, 0.01);
    ExpectLockedToBiases(s, biases);
  }
}

TEST(CpgNetworkTest, RingOfEightLocksToBiasesNearTheTarget) {
  // Rings of five or more also have stable "twisted" states, so start in the
  // basin of the biased pattern: target phases plus up to +-0.6 rad noise.
  const std::vector<double> biases = {0.9, -0.4, 1.3, 0.2, -1.1, 0.7, 0.5, -2.1};
  const Network net = Network::Compile(Ring(biases));
  for (const std::uint64_t seed : {11u, 12u, 13u}) {
    NetworkState s = net.InitialState();
    std::mt19937_64 rng(seed);
    double target = 0.0;
    for (std::size_t k = 0; k < biases.size(); ++k) {
      s.phase[k] = target + (static_cast<double>(rng() >> 11) * 0x1.0p-53 - 0.5) * 1.2;
      target += biases[k];
    }
    for (int k = 0; k < 8000; ++k) Step(net, s, 0.01);
    ExpectLockedToBiases(s, biases);
  }
}

// ------------------------------------------------------- set-points, enable --

TEST(CpgNetworkTest, ClampHoldsWhileRawOutputExceedsLimits) {
  const Network net = Network::Compile(
      Config({Module(7, 1.0, 0.1, 1.5, -0.4, 0.5), Module(8, 0.3, 0.0, 1.0)},
             {Link(7, 8, 1.0), Link(8, 7, -1.0)}));
  NetworkState s = net.InitialState();
  std::vector<std::optional<double>> bulk;
  double raw_min = 1e9, raw_max = -1e9;
  int at_lower = 0, at_upper = 0;
  for (int k = 0; k < 8000; ++k) {
    Step(net, s, 0.001);
    const double raw = RawOutput(net, s, 0);
    const std::optional<double> point = SetPoint(net, s, 0);
    ASSERT_TRUE(point.has_value());
    ASSERT_GE(*point, -0.4);
    ASSERT_LE(*point, 0.5);
    ASSERT_EQ(*point, std::clamp(raw, -0.4, 0.5));
    SetPoints(net, s, bulk);
    ASSERT_EQ(bulk.size(), 2u);
    ASSERT_EQ(bulk[0], point);
    raw_min = std::min(raw_min, raw);
    raw_max = std::max(raw_max, raw);
    at_lower += *point == -0.4;
    at_upper += *point == 0.5;
  }
  EXPECT_GT(raw_max, 0.9);
  EXPECT_LT(raw_min, -0.7);
  EXPECT_GT(at_lower, 0);
  EXPECT_GT(at_upper, 0);
}

TEST(CpgNetworkTest, DisabledModuleIsSilentFrozenAndStillDrivesNeighbours) {
  // B has omega = 0, so once A freezes, B's only motion is the pull of A's
  // held phase: the coupling 2 -> 1 with phase -bias locks phi_A - phi_B = -bias.
  const double bias = 0.8;
  const Network net = Network::Compile(
      Config({Module(1, 1.0, 0.2, 1.0), Module(2, 1.0, 0.0, 0.0)},
             {Link(2, 1, -bias), Link(1, 2, bias)}));
  NetworkState s = net.InitialState();
  for (int k = 0; k < 3000; ++k) Step(net, s, 0.001);
  s.enabled[0] = false;
  const NetworkState frozen = s;
  std::vector<std::optional<double>> bulk;
  const double b_phase_at_disable = s.phase[1];
  for (int k = 0; k < 20000; ++k) {
    Step(net, s, 0.001);
    if (k % 500 != 0) continue;
    ASSERT_EQ(SetPoint(net, s, 0), std::nullopt);
    SetPoints(net, s, bulk);
    ASSERT_EQ(bulk[0], std::nullopt);
    ASSERT_TRUE(bulk[1].has_value());
  }
  // Bit-for-bit frozen.
  for (const auto v : kComponents) {
    EXPECT_EQ(0, std::memcmp(&(s.*v)[0], &(frozen.*v)[0], sizeof(double)));
  }
  EXPECT_FALSE(s.enabled[0]);
  EXPECT_GT(std::abs(s.phase[1] - b_phase_at_disable), 0.01);
  EXPECT_NEAR(Wrap(s.phase[0] - s.phase[1] + bias), 0.0, 1e-6);
  // The raw output of the frozen oscillator is still available.
  EXPECT_DOUBLE_EQ(RawOutput(net, s, 0), frozen.x[0] + frozen.r[0] * std::cos(frozen.phase[0]));

  // Re-enabled, it runs on from where it stopped.
  s.enabled[0] = true;
  Step(net, s, 0.001);
  EXPECT_NE(s.phase[0], frozen.phase[0]);
  EXPECT_NEAR(s.phase[0], frozen.phase[0], 0.01);
  EXPECT_TRUE(SetPoint(net, s, 0).has_value());
}

// ----------------------------------------------------------------- accuracy --

// Largest |a - b| over every component.
double MaxDifference(const NetworkState& a, const NetworkState& b) {
  double worst = 0.0;
  for (const auto v : kComponents) {
    for (std::size_t i = 0; i < (a.*v).size(); ++i) {
      worst = std::max(worst, std::abs((a.*v)[i] - (b.*v)[i]));
    }
  }
  return worst;
}

NetworkState RunSteps(const Network& net, NetworkState s, double dt, int steps) {
  for (int k = 0; k < steps; ++k) Step(net, s, dt);
  return s;
}

TEST(CpgNetworkTest, Rk4ErrorShrinksSixteenfoldPerHalvingAgainstClosedForm) {
  const Network net = Network::Compile(Config({Module(1, 0.9, -0.3, 1.0)}));
  NetworkState start = net.InitialState();
  start.r[0] = 0.1;
  start.dr[0] = 2.0;
  start.x[0] = 0.4;
  start.dx[0] = -0.5;
  const Damped r{4.0, 0.9, 0.1, 2.0};
  const Damped x{4.0, -0.3, 0.4, -0.5};
  std::vector<double> errors;
  for (const double dt : {0.02, 0.01, 0.005}) {
    NetworkState s = start;
    double worst = 0.0;
    const int steps = static_cast<int>(std::lround(3.0 / dt));
    for (int k = 1; k <= steps; ++k) {
      Step(net, s, dt);
      const double t = k * dt;
      worst = std::max({worst, std::abs(s.r[0] - r.Value(t)), std::abs(s.dr[0] - r.Rate(t)),
                        std::abs(s.x[0] - x.Value(t)), std::abs(s.dx[0] - x.Rate(t))});
    }
    errors.push_back(worst);
  }
  ASSERT_GT(errors[2], 1e-12);  // well above round-off
  EXPECT_THAT(errors[0] / errors[1], ::testing::AllOf(::testing::Ge(12.0), ::testing::Le(20.0)));
  EXPECT_THAT(errors[1] / errors[2], ::testing::AllOf(::testing::Ge(12.0), ::testing::Le(20.0)));
}

TEST(CpgNetworkTest, Rk4ErrorShrinksSixteenfoldPerHalvingOnCoupledNetwork) {
  const Network net = Network::Compile(
      Config({Module(1, 1.0, 0.1, 1.0), Module(2, 1.5, -0.2, 1.4), Module(3, 0.7, 0.0, 0.6)},
             {Link(1, 2, 0.5, 2.0), Link(2, 1, -0.5, 1.5), Link(2, 3, 1.2, 3.0),
              Link(3, 2, -1.2, 2.5), Link(3, 1, 2.0, 1.0)}));
  NetworkState start = net.InitialState(99);
  start.r = {0.5, 1.8, 0.2};
  const double duration = 2.0;
  const double reference_dt = 0.005 / 16.0;
  const NetworkState reference =
      RunSteps(net, start, reference_dt, static_cast<int>(std::lround(duration / reference_dt)));
  std::vector<double> errors;
  for (const double dt : {0.02, 0.01, 0.005}) {
    const NetworkState s = RunSteps(net, start, dt, static_cast<int>(std::lround(duration / dt)));
    errors.push_back(MaxDifference(s, reference));
  }
  ASSERT_GT(errors[2], 1e-11);
  EXPECT_THAT(errors[0] / errors[1], ::testing::AllOf(::testing::Ge(12.0), ::testing::Le(20.0)));
  EXPECT_THAT(errors[1] / errors[2], ::testing::AllOf(::testing::Ge(12.0), ::testing::Le(20.0)));
}

// ---------------------------------------------------------------- compiling --

TEST(CpgNetworkTest, CompileBuildsIdMapsAndCsrCouplings) {
  const Network net = Network::Compile(
      Config({Module(5, 0.1, 0.2, 0.5, -1.0, 1.0), Module(2, 0.3, 0.4, 2.0), Module(9, 0, 0, 0)},
             {Link(2, 5, 0.7, 1.5), Link(5, 9, -0.1), Link(2, 9, 0.3, 0.5)}));
  ASSERT_EQ(net.size(), 3u);
  EXPECT_EQ(net.ids(), (std::vector<ModuleId>{5, 2, 9}));
  EXPECT_EQ(net.IndexOf(2), 1u);
  EXPECT_EQ(net.IdAt(2), 9);
  EXPECT_EQ(net.FindIndex(4), std::nullopt);
  EXPECT_EQ(net.params(0).amplitude, 0.1);
  EXPECT_EQ(net.omega(1), kTwoPi * 2.0);
  EXPECT_EQ(net.target_amplitude(1), 0.3);
  EXPECT_EQ(net.target_offset(1), 0.4);
  EXPECT_EQ(net.min_angle(0), -1.0);
  EXPECT_EQ(net.max_angle(0), 1.0);
  EXPECT_EQ(net.link_count(), 3u);
  ASSERT_EQ(net.LinksOf(0).size(), 1u);
  EXPECT_EQ(net.LinksOf(0)[0].source, 2u);
  ASSERT_EQ(net.LinksOf(1).size(), 2u);  // config order kept
  EXPECT_EQ(net.LinksOf(1)[0].source, 0u);
  EXPECT_EQ(net.LinksOf(1)[0].weight, 1.5);
  EXPECT_EQ(net.LinksOf(1)[0].phase, 0.7);
  EXPECT_EQ(net.LinksOf(1)[1].source, 2u);
  EXPECT_TRUE(net.LinksOf(2).empty());

  EXPECT_EQ(CodeOf([&] { (void)net.IndexOf(4); }), StatusCode::kNotFound);
  EXPECT_EQ(CodeOf([&] { (void)net.IdAt(3); }), StatusCode::kOutOfRange);
  EXPECT_EQ(CodeOf([&] { (void)net.params(3); }), StatusCode::kOutOfRange);
  EXPECT_EQ(Network().size(), 0u);
}

struct BadModuleCase {
  const char* attribute;
  double ModuleParams::*field;
  double value;
  friend void PrintTo(const BadModuleCase& c, std::ostream* os) {
    *os << c.attribute << "=" << c.value;
  }
};

class CpgNetworkCompileRejects : public ::testing::TestWithParam<BadModuleCase> {};

TEST_P(CpgNetworkCompileRejects, WithInvalidArgumentNamingIt) {
  RobotConfig config = Config({Module(1, 0.1, 0, 1), Module(7, 0.2, 0, 1)});
  config.modules[1].*(GetParam().field) = GetParam().value;
  std::string message;
  EXPECT_EQ(CodeOf([&] { Network::Compile(config); }, &message),
            StatusCode::kInvalidArgument);
  EXPECT_THAT(message, HasSubstr("module 7"));
  EXPECT_THAT(message, HasSubstr(GetParam().attribute));
}

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

INSTANTIATE_TEST_SUITE_P(
    NonFinite, CpgNetworkCompileRejects,
    ::testing::Values(BadModuleCase{"amplitude", &ModuleParams::amplitude, kNaN},
                      BadModuleCase{"offset", &ModuleParams::offset, -kInf},
                      BadModuleCase{"speed", &ModuleParams::speed, kInf},
                      BadModuleCase{"speed", &ModuleParams::speed, 1e308},  // omega overflows
                      BadModuleCase{"minangle", &ModuleParams::min_angle, kNaN},
                      BadModuleCase{"maxangle", &ModuleParams::max_angle, kInf},
                      BadModuleCase{"minangle", &ModuleParams::min_angle, 11.0}));  // > max

TEST(CpgNetworkTest, CompileRejectsBadCouplingsAndIds) {
  std::string message;
  EXPECT_EQ(CodeOf([&] { Network::Compile(Config({Module(1, 0, 0, 1)}, {Link(1, 9, 0)})); },
                   &message),
            StatusCode::kNotFound);
  EXPECT_THAT(message, HasSubstr("module 9"));
  EXPECT_EQ(CodeOf([&] { Network::Compile(Config({Module(1, 0, 0, 1)}, {Link(8, 1, 0)})); },
                   &message),
            StatusCode::kNotFound);
  EXPECT_THAT(message, HasSubstr("module 8"));
  EXPECT_EQ(CodeOf([&] {
              Network::Compile(Config({Module(1, 0, 0, 1), Module(2, 0, 0, 1)},
                                      {Link(1, 2, kNaN)}));
            }, &message),
            StatusCode::kInvalidArgument);
  EXPECT_THAT(message, HasSubstr("phase"));
  EXPECT_EQ(CodeOf([&] {
              Network::Compile(Config({Module(1, 0, 0, 1), Module(2, 0, 0, 1)},
                                      {Link(2, 1, 0.0, kInf)}));
            }, &message),
            StatusCode::kInvalidArgument);
  EXPECT_THAT(message, HasSubstr("weight"));
  EXPECT_EQ(CodeOf([&] { Network::Compile(Config({Module(3, 0, 0, 1), Module(3, 0, 0, 1)})); },
                   &message),
            StatusCode::kInvalidArgument);
  EXPECT_THAT(message, HasSubstr("3"));
  EXPECT_EQ(CodeOf([&] { Network::Compile(Config({Module(3, 0, 0, 1)}), {0.0, 4.0}); }),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf([&] { Network::Compile(Config({Module(3, 0, 0, 1)}), {4.0, kNaN}); }),
            StatusCode::kInvalidArgument);
}

TEST(CpgNetworkTest, CompileErrorNamesSourceLine) {
  RobotConfig config = Config({Module(4, kNaN, 0, 1)});
  config.module_locations[4] = SourceLocation{"robot.xml", 12};
  std::string message;
  EXPECT_EQ(CodeOf([&] { Network::Compile(config); }, &message), StatusCode::kInvalidArgument);
  EXPECT_THAT(message, HasSubstr("robot.xml:12"));
}

// ------------------------------------------------------------ state handling --

TEST(CpgNetworkTest, RemapStateKeepsStatePerModuleId) {
  const Network from = Network::Compile(
      Config({Module(1, 0.5, 0.1, 1.0), Module(2, 0.4, 0, 0.5), Module(3, 0.3, 0, 2.0)},
             {Link(1, 2, 0.4), Link(2, 3, 0.4)}));
  NetworkState s = from.InitialState(7);
  for (int k = 0; k < 700; ++k) Step(from, s, 0.001);
  s.enabled[2] = false;
  const Network to = Network::Compile(
      Config({Module(3, 0.3, 0, 2.0), Module(1, 0.9, 0.1, 1.0), Module(4, 0.2, 0, 1.0)},
             {Link(4, 1, 0.2)}));
  const NetworkState remapped = RemapState(from, s, to);
  ASSERT_EQ(remapped.size(), 3u);
  EXPECT_EQ(remapped.time, s.time);
  const std::size_t pairs[][2] = {{0, 2}, {1, 0}};  // {new index, old index}
  for (const auto& pair : pairs) {
    EXPECT_EQ(remapped.phase[pair[0]], s.phase[pair[1]]);
    EXPECT_EQ(remapped.r[pair[0]], s.r[pair[1]]);
    EXPECT_EQ(remapped.dr[pair[0]], s.dr[pair[1]]);
    EXPECT_EQ(remapped.x[pair[0]], s.x[pair[1]]);
    EXPECT_EQ(remapped.dx[pair[0]], s.dx[pair[1]]);
    EXPECT_EQ(remapped.enabled[pair[0]], s.enabled[pair[1]]);
  }
  EXPECT_EQ(remapped.phase[2], 0.0);
  EXPECT_EQ(remapped.r[2], 0.0);
  EXPECT_EQ(remapped.x[2], 0.0);
  EXPECT_TRUE(remapped.enabled[2]);
  // The set-point of a kept module does not jump.
  EXPECT_EQ(RawOutput(to, remapped, 1), RawOutput(from, s, 0));

  const NetworkState wrong = Network::Compile(Config({Module(1, 0, 0, 1)})).InitialState();
  EXPECT_EQ(CodeOf([&] { (void)RemapState(from, wrong, to); }), StatusCode::kInvalidArgument);
}

TEST(CpgNetworkTest, StepRejectsBadTimeStepAndMismatchedState) {
  const Network net = Network::Compile(Config({Module(1, 0.5, 0, 1), Module(2, 0.5, 0, 1)}));
  NetworkState s = net.InitialState(3);
  const NetworkState before = s;
  for (const double dt : {0.0, -0.01, kNaN, kInf}) {
    EXPECT_EQ(CodeOf([&] { Step(net, s, dt); }), StatusCode::kInvalidArgument) << dt;
  }
  EXPECT_EQ(s, before);
  EXPECT_EQ(CodeOf([&] { Integrate(net, s, -1.0, 0.01); }), StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf([&] { Integrate(net, s, kNaN, 0.01); }), StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf([&] { Integrate(net, s, 1.0, 0.0); }), StatusCode::kInvalidArgument);
  NetworkState small = Network::Compile(Config({Module(1, 0.5, 0, 1)})).InitialState();
  EXPECT_EQ(CodeOf([&] { Step(net, small, 0.01); }), StatusCode::kInvalidArgument);
  s.enabled.pop_back();
  EXPECT_EQ(CodeOf([&] { Step(net, s, 0.01); }), StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf([&] { (void)SetPoint(net, before, 2); }), StatusCode::kOutOfRange);
  EXPECT_EQ(CodeOf([&] { (void)RawOutput(net, before, 5); }), StatusCode::kOutOfRange);
}

TEST(CpgNetworkTest, IntegrateLandsOnDurationWithShorterLastStep) {
  const Network net = Network::Compile(
      Config({Module(1, 0.5, 0.1, 1.3), Module(2, 0.5, 0, 0.9)}, {Link(1, 2, 0.5)}));
  NetworkState integrated = net.InitialState(4);
  NetworkState stepped = integrated;
  Integrate(net, integrated, 0.25, 0.1);
  Step(net, stepped, 0.1);
  Step(net, stepped, 0.1);
  Step(net, stepped, 0.25 - 2 * 0.1);
  EXPECT_EQ(integrated, stepped);
  EXPECT_NEAR(integrated.time, 0.25, 1e-15);
  NetworkState zero = net.InitialState();
  Integrate(net, zero, 0.0, 0.1);
  EXPECT_EQ(zero, net.InitialState());
}

TEST(CpgNetworkTest, SeededInitialPhasesAreInRangeAndSeedDependent) {
  const Network net = Network::Compile(Ring(std::vector<double>(6, 0.3)));
  const NetworkState a = net.InitialState(1);
  const NetworkState b = net.InitialState(1);
  const NetworkState c = net.InitialState(2);
  EXPECT_EQ(a, b);
  EXPECT_NE(a.phase, c.phase);
  for (double phase : a.phase) {
    EXPECT_GE(phase, 0.0);
    EXPECT_LT(phase, kTwoPi);
  }
  const NetworkState zero = net.InitialState();
  EXPECT_THAT(zero.phase, ::testing::Each(0.0));
  EXPECT_THAT(zero.r, ::testing::Each(0.0));
  EXPECT_THAT(zero.enabled, ::testing::Each(true));
  EXPECT_EQ(zero.time, 0.0);
}

TEST(CpgNetworkTest, IdenticalRunsAreBitIdentical) {
  const Network net = Network::Compile(Ring({0.4, -0.3, 1.0, 0.2, -0.1}));
  auto run = [&] {
    NetworkState s = net.InitialState(77);
    for (int k = 0; k < 5000; ++k) {
      if (k == 2000) s.enabled[3] = false;
      Step(net, s, 0.003);
    }
    return s;
  };
  const NetworkState first = run();
  const NetworkState second = run();
  for (const auto v : kComponents) {
    ASSERT_EQ((first.*v).size(), (second.*v).size());
    EXPECT_EQ(0, std::memcmp((first.*v).data(), (second.*v).data(),
                             (first.*v).size() * sizeof(double)));
  }
  EXPECT_EQ(0, std::memcmp(&first.time, &second.time, sizeof(double)));
}

TEST(CpgNetworkTest, StepAndSetPointsDoNotAllocate) {
  const Network net = Network::Compile(Ring(std::vector<double>(16, 0.2)));
  NetworkState s = net.InitialState(5);
  std::vector<std::optional<double>> points;
  SetPoints(net, s, points);
  const long before = g_allocations.load();
  for (int k = 0; k < 1000; ++k) {
    Step(net, s, 0.001);
    SetPoints(net, s, points);
  }
  EXPECT_EQ(g_allocations.load(), before);

  // A copied state sizes its scratch once, then runs allocation-free too.
  NetworkState copy = s;
  Step(net, copy, 0.001);
  const long after_first = g_allocations.load();
  for (int k = 0; k < 100; ++k) Step(net, copy, 0.001);
  EXPECT_EQ(g_allocations.load(), after_first);
}

}  // namespace
}  // namespace yamor::cpg
