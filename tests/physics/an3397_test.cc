#include "physics/an3397.h"

#include <array>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/status.h"

namespace yamor::physics {
namespace {

// Unit options: one count = 1 m/s², one sample = 1 s, so the hand-computed
// numbers below are the trapezoid sums themselves.
An3397Options UnitOptions() {
  An3397Options o;
  o.sample_period = 1;
  o.count_size = 1;
  return o;
}

TEST(An3397Test, WindowZeroesPlusMinusThreeCounts) {
  EXPECT_EQ(WindowFilter(3, 3), 0);
  EXPECT_EQ(WindowFilter(-3, 3), 0);
  EXPECT_EQ(WindowFilter(2.5, 3), 0);
  EXPECT_EQ(WindowFilter(0, 3), 0);
  EXPECT_EQ(WindowFilter(3.25, 3), 3.25);
  EXPECT_EQ(WindowFilter(-4, 3), -4);
}

TEST(An3397Test, TrapezoidStep) {
  EXPECT_EQ(TrapezoidStep(1, 2, 4, 0.5), 2.5);  // 1 + (2 + 4)·0.5/2
  EXPECT_EQ(TrapezoidStep(0, 0, 10, 1), 5);
  EXPECT_EQ(TrapezoidStep(-1, 3, -3, 2), -1);
}

TEST(An3397Test, HandComputedSequenceWithResetAfterExactly25ZeroSamples) {
  DeadReckoning dr(UnitOptions());
  // a: 10, 10 then zeros. v: 5, 15, 20, 20, … p: 2.5, 12.5, 30, 50, …
  DeadReckoningSample s = dr.Add({10, 0, 0});
  EXPECT_EQ(s.velocity.x(), 5);
  EXPECT_EQ(s.position.x(), 2.5);
  s = dr.Add({10, 0, 0});
  EXPECT_EQ(s.velocity.x(), 15);
  EXPECT_EQ(s.position.x(), 12.5);
  for (int zero = 1; zero <= 24; ++zero) {
    s = dr.Add({zero % 2 ? 3.0 : -2.0, 0, 0});  // inside the window: zeros
    EXPECT_EQ(s.acceleration.x(), 0);
    EXPECT_EQ(s.velocity.x(), 20) << "zero sample " << zero;
    EXPECT_EQ(s.position.x(), 30 + 20 * (zero - 1)) << "zero sample " << zero;
    EXPECT_EQ(dr.zero_run()[0], zero);
  }
  s = dr.Add({0, 0, 0});  // the 25th zero sample: position still moves, then the reset
  EXPECT_EQ(s.position.x(), 30 + 20 * 24);
  EXPECT_EQ(s.velocity.x(), 0);
  s = dr.Add({0, 0, 0});
  EXPECT_EQ(s.position.x(), 510);
  EXPECT_EQ(s.velocity.x(), 0);
  // The other axes never moved.
  EXPECT_EQ(s.position.y(), 0);
  EXPECT_EQ(s.position.z(), 0);
}

TEST(An3397Test, A24ZeroRunDoesNotReset) {
  DeadReckoning dr(UnitOptions());
  DeadReckoningSample s = dr.Add({0, 8, 0});  // v = 4
  EXPECT_EQ(s.velocity.y(), 4);
  for (int i = 0; i < 24; ++i) s = dr.Add({0, 0, 0});  // v = 4 + 8/2 = 8, then constant
  EXPECT_EQ(s.velocity.y(), 8);
  s = dr.Add({0, -4, 0});  // breaks the run: v = 8 + (0 − 4)/2 = 6
  EXPECT_EQ(s.velocity.y(), 6);
  EXPECT_EQ(dr.zero_run()[1], 0);
  for (int i = 0; i < 24; ++i) s = dr.Add({0, 0, 0});  // v = 6 − 4/2 = 4, 24 zeros: kept
  EXPECT_EQ(s.velocity.y(), 4);
  EXPECT_EQ(dr.zero_run()[1], 24);
  s = dr.Add({0, 0, 0});  // the 25th
  EXPECT_EQ(s.velocity.y(), 0);
}

TEST(An3397Test, WithoutWindowAndResetNoiseIntegrates) {
  An3397Options o = UnitOptions();
  o.window_filter = false;
  o.movement_end = false;
  DeadReckoning dr(o);
  DeadReckoningSample s;
  for (int i = 0; i < 30; ++i) s = dr.Add({1, 0, 0});
  EXPECT_EQ(s.velocity.x(), 29.5);  // 0.5 + 29·1
  EXPECT_EQ(s.position.x(), 435.25);  // 0.25 + Σ_{j=2}^{30} (j − 1)
}

TEST(An3397Test, ChainCalibratesThenAveragesSixtyFourReadings) {
  An3397Options o;
  An3397Filter filter(o);
  for (int i = 0; i < 1023; ++i) {
    EXPECT_FALSE(filter.Add({512, 520, i % 2 ? 760 : 761}).has_value());
    EXPECT_FALSE(filter.calibrated());
  }
  EXPECT_FALSE(filter.Add({512, 520, 760}).has_value());  // 512 × 760 and 512 × 761
  ASSERT_TRUE(filter.calibrated());
  EXPECT_EQ(filter.offset(), Eigen::Vector3d(512, 520, 760.5));
  for (int i = 0; i < 63; ++i) EXPECT_FALSE(filter.Add({i % 2 ? 520 : 524, 520, 760}).has_value());
  const auto sample = filter.Add({520, 520, 761});  // x: 32 × 524, 32 × 520
  ASSERT_TRUE(sample.has_value());
  // x: mean 522 − 512 = 10 counts (outside the window); z: 760 + 1/64 − 760.5, in the window.
  EXPECT_NEAR(sample->acceleration.x(), 10 * o.count_size, 1e-12);
  EXPECT_EQ(sample->acceleration.y(), 0);
  EXPECT_EQ(sample->acceleration.z(), 0);
  EXPECT_NEAR(sample->velocity.x(), 10 * o.count_size * o.sample_period / 2, 1e-12);
}

TEST(An3397Test, BadOptionsAreRejectedNamingTheValue) {
  An3397Options o;
  o.average_count = 0;
  try {
    An3397Filter filter(o);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kInvalidArgument);
    EXPECT_NE(std::string(e.what()).find("average_count must be >= 1, got 0"), std::string::npos);
  }
  o = An3397Options();
  o.sample_period = -0.01;
  EXPECT_THROW(DeadReckoning dr(o), Error);
}

}  // namespace
}  // namespace yamor::physics
