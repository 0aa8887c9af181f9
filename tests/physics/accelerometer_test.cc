#include "physics/accelerometer.h"

#include <array>
#include <cmath>
#include <map>
#include <string>

#include <gtest/gtest.h>

#include "common/status.h"

namespace yamor::physics {
namespace {

TEST(AccelerometerTest, ZeroForceReadsTheNoiseBand) {
  const AccelerometerSpec spec;
  Eigen::Vector3d low = Eigen::Vector3d::Constant(1e9), high = -low, sum = Eigen::Vector3d::Zero();
  const int samples = 20000;
  for (int i = 0; i < samples; ++i) {
    const AccelerometerReading r = SampleAccelerometer(Eigen::Vector3d::Zero(), 7, 3, i, spec);
    for (int axis = 0; axis < 3; ++axis) {
      EXPECT_EQ(r.acceleration[axis], (r.counts[axis] - spec.zero_count) * spec.count_size);
    }
    low = low.cwiseMin(r.acceleration);
    high = high.cwiseMax(r.acceleration);
    sum += r.acceleration;
  }
  const Eigen::Vector3d half_count = Eigen::Vector3d::Constant(spec.count_size / 2 + 1e-12);
  EXPECT_TRUE((low.array() >= (spec.noise_min - half_count).array()).all()) << low.transpose();
  EXPECT_TRUE((high.array() <= (spec.noise_max + half_count).array()).all()) << high.transpose();
  // The band is covered: the observed amplitude is Table 4.1's within a count.
  const Eigen::Vector3d amplitude = high - low;
  const Eigen::Vector3d expected = spec.noise_max - spec.noise_min;
  EXPECT_TRUE(((amplitude - expected).cwiseAbs().array() <= spec.count_size * 1.01).all())
      << amplitude.transpose();
  // Uniform noise: the mean is the band centre.
  const Eigen::Vector3d mean = sum / samples;
  EXPECT_TRUE(((mean - (spec.noise_max + spec.noise_min) / 2).cwiseAbs().array() < 0.01).all())
      << mean.transpose();
}

TEST(AccelerometerTest, QuantisesAndClamps) {
  const AccelerometerSpec spec;
  const AccelerometerReading g = SampleAccelerometer(Eigen::Vector3d(0, 0, 9.81), 1, 0, 0, spec);
  EXPECT_NEAR(g.acceleration.z(), 9.81, 0.4);
  EXPECT_NEAR(g.counts[2], 512 + std::lround(9.81 / 0.0395), 10);
  const AccelerometerReading big = SampleAccelerometer(Eigen::Vector3d(100, -100, 0), 1, 0, 0, spec);
  EXPECT_EQ(big.counts[0], 1023);
  EXPECT_EQ(big.counts[1], 0);
}

TEST(AccelerometerTest, NoiseIsAFunctionOfSeedModuleAndSample) {
  const Eigen::Vector3d f(1, 2, 3);
  const auto a = SampleAccelerometer(f, 42, 5, 100);
  const auto b = SampleAccelerometer(f, 42, 5, 100);
  EXPECT_EQ(a.counts, b.counts);
  int differing = 0;
  for (int i = 0; i < 50; ++i) {
    if (SampleAccelerometer(f, 42, 5, i).counts != SampleAccelerometer(f, 43, 5, i).counts) {
      ++differing;
    }
  }
  EXPECT_GT(differing, 25);
}

}  // namespace
}  // namespace yamor::physics

namespace yamor::physics {
namespace {

TEST(AccelerometerDnlTest, MissingCodesGoToTheirNeighbours) {
  const AccelerometerSpec spec;  // x misses 513 and 515
  EXPECT_EQ(QuantiseCount(512.4, 0, spec), 512);
  EXPECT_EQ(QuantiseCount(512.8, 0, spec), 512);  // rounds to 513, lies below it
  EXPECT_EQ(QuantiseCount(513.2, 0, spec), 514);  // rounds to 513, lies above it
  EXPECT_EQ(QuantiseCount(514.6, 0, spec), 514);
  EXPECT_EQ(QuantiseCount(515.3, 0, spec), 516);
  EXPECT_EQ(QuantiseCount(513.2, 2, spec), 513);  // z keeps 513
  AccelerometerSpec run = spec;
  run.missing_codes[1] = {10, 11};
  // A run of missing codes splits its range [9.5, 11.5) at 10.5.
  EXPECT_EQ(QuantiseCount(10.2, 1, run), 9);
  EXPECT_EQ(QuantiseCount(10.6, 1, run), 12);
  EXPECT_EQ(QuantiseCount(11.3, 1, run), 12);
  EXPECT_EQ(QuantiseCount(9.8, 1, run), 9);
  EXPECT_EQ(QuantiseCount(-5.0, 1, run), 0);
  EXPECT_EQ(QuantiseCount(5000.0, 1, run), 1023);
}

TEST(AccelerometerDnlTest, MissingCodesNeverOccurAtRest) {
  const AccelerometerSpec spec;
  std::array<std::map<int, int>, 3> histogram;
  for (int i = 0; i < 20000; ++i) {
    const auto r = SampleAccelerometer(Eigen::Vector3d(0, 0, 9.81), 11, 2, i, spec);
    for (size_t axis = 0; axis < 3; ++axis) ++histogram[axis][r.counts[axis]];
  }
  for (size_t axis = 0; axis < 3; ++axis) {
    for (int code : spec.missing_codes[axis]) {
      EXPECT_EQ(histogram[axis].count(code), 0u) << "axis " << axis << " code " << code;
      // Its neighbours are inside the band and twice as likely as elsewhere.
      EXPECT_GT(histogram[axis][code - 1], 0) << code - 1;
      EXPECT_GT(histogram[axis][code + 1], 0) << code + 1;
    }
  }
  EXPECT_GT(histogram[0][514], histogram[0][517] * 1.5);  // 514 collects half of 513 and 515
}

TEST(AccelerometerDnlTest, BadSpecIsRejectedNamingTheValue) {
  AccelerometerSpec spec;
  spec.missing_codes[2] = {0};
  try {
    ValidateAccelerometerSpec(spec);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kInvalidArgument);
    EXPECT_NE(std::string(e.what()).find("missing code 0 on z"), std::string::npos) << e.what();
  }
  spec = AccelerometerSpec();
  spec.noise_min.x() = 1.0;  // above noise_max
  EXPECT_THROW(AccelerometerBoard(spec, 1, 1), Error);
}

TEST(AccelerometerBoardTest, EachShockShiftsTheOffsetOnce) {
  const AccelerometerSpec spec;
  AccelerometerBoard board(spec, 5, 1);
  const Eigen::Vector3d rest(0, 0, 9.81);
  for (int i = 0; i < 10; ++i) board.Read(rest, i);
  EXPECT_EQ(board.impacts(), 0);
  EXPECT_EQ(board.offset(), Eigen::Vector3d::Zero());
  for (int i = 10; i < 20; ++i) board.Read(Eigen::Vector3d(0, 0, 200), i);  // one shock
  EXPECT_EQ(board.impacts(), 1);
  const Eigen::Vector3d first = board.offset();
  for (int axis = 0; axis < 3; ++axis) {
    EXPECT_GE(std::abs(first[axis]), spec.impact_offset_shift[axis] / 2 - 1e-12) << axis;
    EXPECT_LE(std::abs(first[axis]), spec.impact_offset_shift[axis] + 1e-12) << axis;
  }
  // The shift shows in the readings: the mean at rest moves with it.
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (int i = 20; i < 20020; ++i) sum += board.Read(rest, i).acceleration;
  const Eigen::Vector3d centre = (spec.noise_max + spec.noise_min) / 2 + rest;
  EXPECT_NEAR(sum.x() / 20000 - centre.x(), first.x(), 0.02);
  for (int i = 0; i < 5; ++i) board.Read(Eigen::Vector3d(50, 0, 0), 30000 + i);  // second shock
  EXPECT_EQ(board.impacts(), 2);
  EXPECT_NE(board.offset(), first);
  // Seeded: the same seed gives the same shifts, another seed others.
  AccelerometerBoard same(spec, 5, 1), other(spec, 6, 1);
  same.Read(Eigen::Vector3d(0, 0, 200), 0);
  other.Read(Eigen::Vector3d(0, 0, 200), 0);
  EXPECT_EQ(same.offset(), first);
  EXPECT_NE(other.offset(), first);
}

}  // namespace
}  // namespace yamor::physics
