#include "physics/driven_module.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/status.h"
#include "physics/module.h"

namespace yamor::physics {
namespace {

std::vector<MotionPath> AllMoves() {
  return {SineMove(), CircleMove(), GoAndReturnMove(), RandomAirMove(3), DropMove(), FlipMove()};
}

// The analytic derivatives agree with the path: integrating the sensor's
// acceleration twice (trapezoid, fine step) retraces its position.
TEST(DrivenModuleTest, AccelerationIntegratesBackToThePath) {
  for (const MotionPath& path : AllMoves()) {
    DrivenModuleOptions options;
    options.sample_rate = 20000;
    DrivenModule module(path, options);
    const std::vector<DrivenSample> samples = module.Run();
    ASSERT_EQ(samples.size(), module.SampleCount());
    Eigen::Vector3d v = samples.front().sensor_velocity, p = samples.front().sensor_position;
    double worst_v = 0, worst_p = 0;
    const double dt = 1 / options.sample_rate;
    for (size_t i = 1; i < samples.size(); ++i) {
      const Eigen::Vector3d v_next =
          v + (samples[i - 1].sensor_acceleration + samples[i].sensor_acceleration) * dt / 2;
      p += (v + v_next) * dt / 2;
      v = v_next;
      worst_v = std::max(worst_v, (v - samples[i].sensor_velocity).norm());
      worst_p = std::max(worst_p, (p - samples[i].sensor_position).norm());
    }
    // The drop's contact starts with a jump of g in acceleration; the
    // trapezoid straddling it leaves ~1e-4 m/s, i.e. < 1 mm over the settle.
    EXPECT_LT(worst_v, 2e-3) << path.name();
    EXPECT_LT(worst_p, 1e-3) << path.name();
  }
}

TEST(DrivenModuleTest, MovesStartAndEndAtRestWhereTheThesisSays) {
  for (const MotionPath& path : AllMoves()) {
    const PathPoint start = path.At(0), end = path.At(path.duration());
    EXPECT_LT(start.velocity.norm() + end.velocity.norm(), 1e-9) << path.name();
    EXPECT_LT(start.acceleration.norm() + end.acceleration.norm(), 1e-9) << path.name();
    if (path.name() != "drop" && path.name() != "flip" && path.name() != "sine") {
      EXPECT_LT((end.position - start.position).norm(), 1e-9) << path.name() << " returns";
      EXPECT_NEAR(start.position.z(), RestingHeight(), 1e-12) << path.name();
    }
  }
  // Sine: 25 cm along x, y swinging ±10 cm.
  const MotionPath sine = SineMove();
  EXPECT_NEAR(sine.At(sine.duration()).position.x(), 0.25, 1e-12);
  double y_max = 0, y_min = 0;
  for (double t = 0; t <= sine.duration(); t += 0.001) {
    y_max = std::max(y_max, sine.At(t).position.y());
    y_min = std::min(y_min, sine.At(t).position.y());
  }
  EXPECT_NEAR(y_max, 0.10, 1e-4);
  EXPECT_NEAR(y_min, -0.10, 1e-4);
  // Circle: clockwise seen from above (angular momentum about the centre along −z).
  const MotionPath circle = CircleMove();
  const Eigen::Vector3d centre = circle.At(0).position - Eigen::Vector3d(0, 0.05, 0);
  for (double t = 1.1; t < 2.9; t += 0.2) {
    const PathPoint p = circle.At(t);
    EXPECT_NEAR((p.position - centre).norm(), 0.05, 1e-12);
    EXPECT_LT((p.position - centre).cross(p.velocity).z(), 0) << t;
  }
  // Go and return: 10 cm out.
  const MotionPath go = GoAndReturnMove();
  EXPECT_NEAR(go.At(2.0).position.x(), 0.10, 1e-12);
  // Flip: ends upside down on the ground.
  const MotionPath flip = FlipMove();
  const PathPoint flipped = flip.At(flip.duration());
  EXPECT_NEAR((flipped.orientation * Eigen::Vector3d::UnitZ()).z(), -1, 1e-12);
  EXPECT_NEAR(flipped.position.z(), RestingHeight(), 1e-12);
}

TEST(DrivenModuleTest, RandomMoveIsSeededStaysLowAndTilts) {
  for (std::uint64_t seed : {1u, 2u, 3u, 4u, 5u}) {
    const MotionPath path = RandomAirMove(seed);
    DrivenModule module(path);  // validates: never below the ground
    double top = 0, tilt = 0;
    for (double t = 0; t <= path.duration(); t += 0.002) {
      const PathPoint p = path.At(t);
      top = std::max(top, p.position.z() - RestingHeight());
      tilt = std::max(tilt, Eigen::AngleAxisd(p.orientation).angle());
    }
    EXPECT_LE(top, 0.10 + 1e-12) << seed;
    EXPECT_GT(top, 0.03) << seed;
    EXPECT_GT(tilt, 0.2) << seed;
    EXPECT_LE(tilt, 0.6 + 1e-9) << seed;
  }
  EXPECT_EQ(RandomAirMove(7).At(2.5).position, RandomAirMove(7).At(2.5).position);
  EXPECT_NE(RandomAirMove(7).At(2.5).position, RandomAirMove(8).At(2.5).position);
}

TEST(DrivenModuleTest, ReadsGravityAtRestAndNothingInFreeFall) {
  DrivenModuleOptions options;
  options.seed = 9;
  DrivenModule module(DropMove(), options);
  const std::vector<DrivenSample> samples = module.Run();
  const double fall = std::sqrt(2 * 0.07 / 9.81);
  double peak = 0;
  for (const DrivenSample& s : samples) {
    if (s.time < 0.9) {
      EXPECT_NEAR((s.specific_force - Eigen::Vector3d(0, 0, 9.81)).norm(), 0, 1e-9);
    } else if (s.time > 1.0 + 0.01 && s.time < 1.0 + fall - 0.01) {
      EXPECT_LT(s.specific_force.norm(), 1e-9) << s.time;  // free fall reads zero
      EXPECT_LE(std::abs(s.reading.acceleration.z()), 0.35) << s.time;
    }
    peak = std::max(peak, s.specific_force.z());
  }
  EXPECT_GT(peak, 300);  // the impact
  for (const DrivenSample& s : samples) {
    for (int c : s.reading.counts) ASSERT_TRUE(c >= 0 && c <= 1023) << s.time;
  }
  EXPECT_EQ(module.board().impacts(), 1);
  EXPECT_NE(module.board().offset(), Eigen::Vector3d::Zero());
  EXPECT_THROW(module.Next(), Error);
}

TEST(DrivenModuleTest, ReadingsAreDeterministicPerSeed) {
  DrivenModuleOptions a, b;
  a.seed = b.seed = 4;
  const auto ra = DrivenModule(CircleMove(), a).Run();
  const auto rb = DrivenModule(CircleMove(), b).Run();
  ASSERT_EQ(ra.size(), rb.size());
  for (size_t i = 0; i < ra.size(); i += 97) EXPECT_EQ(ra[i].reading.counts, rb[i].reading.counts);
  b.seed = 5;
  const auto rc = DrivenModule(CircleMove(), b).Run();
  int differing = 0;
  for (size_t i = 0; i < ra.size(); i += 97) differing += ra[i].reading.counts != rc[i].reading.counts;
  EXPECT_GT(differing, 10);
}

std::string ErrorOf(const MotionPath& path, DrivenModuleOptions options = {}) {
  try {
    DrivenModule module(path, options);
  } catch (const Error& e) {
    return std::string(StatusCodeName(e.code())) + ": " + e.what();
  }
  return "no error";
}

TEST(DrivenModuleTest, BadPathsAreRejectedBeforeAnyReading) {
  // Sinks 5 cm into the ground.
  const MotionPath into_ground("dig", 1.0, [](double t) {
    PathPoint p;
    p.position = Eigen::Vector3d(0, 0, RestingHeight() - 0.05 * t);
    p.velocity = Eigen::Vector3d(0, 0, -0.05);
    return p;
  });
  const std::string dig = ErrorOf(into_ground);
  EXPECT_NE(dig.find("OUT_OF_RANGE"), std::string::npos) << dig;
  EXPECT_NE(dig.find("'dig'"), std::string::npos) << dig;
  EXPECT_NE(dig.find("lowest point z = -0.003"), std::string::npos) << dig;
  // A 0.1 ms impact asks ~18000 m/s².
  const std::string hard = ErrorOf(DropMove(0.07, 1e-4));
  EXPECT_NE(hard.find("OUT_OF_RANGE"), std::string::npos) << hard;
  EXPECT_NE(hard.find("impossible acceleration: |a| = "), std::string::npos) << hard;
  // Tilting a module resting on the ground digs a corner in.
  const MotionPath tilt("tilt", 1.0, [](double t) {
    PathPoint p;
    p.position = Eigen::Vector3d(0, 0, RestingHeight());
    p.orientation = Eigen::AngleAxisd(0.5 * t, Eigen::Vector3d::UnitX());
    p.angular_velocity = Eigen::Vector3d(0.5, 0, 0);
    return p;
  });
  EXPECT_NE(ErrorOf(tilt).find("leaves free space"), std::string::npos) << ErrorOf(tilt);
  const MotionPath nan("nan", 1.0, [](double t) {
    PathPoint p;
    p.position = Eigen::Vector3d(t > 0.5 ? NAN : 0, 0, RestingHeight());
    return p;
  });
  EXPECT_NE(ErrorOf(nan).find("INVALID_ARGUMENT"), std::string::npos) << ErrorOf(nan);
  DrivenModuleOptions bad;
  bad.sample_rate = 0;
  EXPECT_NE(ErrorOf(SineMove(), bad).find("sample_rate must be finite and > 0, got 0"),
            std::string::npos) << ErrorOf(SineMove(), bad);
  EXPECT_THROW(SineMove(0.1, 0.25, -1), Error);
  EXPECT_THROW(MotionPath("x", INFINITY, [](double) { return PathPoint(); }), Error);
}

}  // namespace
}  // namespace yamor::physics
