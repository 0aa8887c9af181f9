#include "physics/accelerometer.h"

#include <cmath>

#include <gtest/gtest.h>

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
