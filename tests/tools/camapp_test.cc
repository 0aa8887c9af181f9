// yamor-camapp's pieces in-process: the camera (projection, distortion,
// noise, rounding, dropouts, seeds), the calibration it writes (a tracker
// loading it recovers metres), the frame clock, and the CamApp server and
// filming loop against the host's LedTracker on loopback (latency, truth log).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <mutex>
#include <random>
#include <sstream>
#include <thread>
#include <vector>

#include "common/format.h"
#include "common/status.h"
#include "host/camera_model.h"
#include "host/led_tracker.h"
#include "tests/support/code_of.h"
#include "tools/camapp/camapp_server.h"
#include "tools/camapp/camera_emulator.h"
#include "tools/camapp/emulator.h"

namespace yamor::camapp {
namespace {

using ::testing::HasSubstr;
using ::yamor::testing::CodeOf;
using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

CameraOptions NoiseFree() {
  CameraOptions o;
  o.noise = 0.0;
  o.integer_pixels = false;
  return o;
}

host::CameraModel ModelOf(const CameraEmulator& camera, double led_height) {
  return host::CameraModel(host::ParseCameraCalibration(camera.CalibrationText(led_height), "camapp"),
                           "camapp");
}

TEST(CameraEmulatorTest, LooksStraightDownWithTheImageAsAMap) {
  const CameraEmulator camera(NoiseFree());
  Eigen::Vector2d pixel;
  ASSERT_TRUE(camera.ProjectExact({0, 0, 0.05}, &pixel));
  EXPECT_NEAR(pixel.x(), 319.5, 1e-9) << "the point below the lens is the principal point";
  EXPECT_NEAR(pixel.y(), 239.5, 1e-9);
  ASSERT_TRUE(camera.ProjectExact({0.5, 0.3, 0.05}, &pixel));
  EXPECT_GT(pixel.x(), 319.5) << "+x is to the right";
  EXPECT_LT(pixel.y(), 239.5) << "+y is up";
  Eigen::Vector2d ideal;
  ASSERT_TRUE(camera.ProjectIdeal({0.5, 0.3, 0.05}, &ideal));
  EXPECT_NEAR(ideal.x(), 319.5 + 800 * 0.5 / 2.65, 1e-9) << "pinhole: f X / depth";
  EXPECT_LT((pixel - Eigen::Vector2d(319.5, 239.5)).norm(), (ideal - Eigen::Vector2d(319.5, 239.5)).norm())
      << "barrel distortion pulls towards the centre";
  EXPECT_FALSE(camera.ProjectExact({3.0, 0, 0.05}, &pixel)) << "outside the image";
  EXPECT_FALSE(camera.ProjectExact({40.0, 30.0, 0.05}, &pixel)) << "far outside, where the lens folds";
  EXPECT_FALSE(camera.ProjectExact({0, 0, 2.8}, &pixel)) << "above the lens";
}

TEST(CameraEmulatorTest, ItsCalibrationRecoversMetresEverywhereInTheImage) {
  const CameraEmulator camera(NoiseFree());
  const host::CameraModel model = ModelOf(camera, 0.05);
  EXPECT_LT(model.fit().max_error, 1e-6);
  EXPECT_DOUBLE_EQ(model.led_height(), 0.05);
  EXPECT_EQ(model.lens().params().k1, camera.options().k1) << "the lens exactly";
  double worst = 0;
  for (double x = -1.0; x <= 1.0; x += 0.1) {
    for (double y = -0.75; y <= 0.75; y += 0.1) {
      Eigen::Vector2d pixel;
      if (!camera.ProjectExact({x, y, 0.05}, &pixel)) continue;
      worst = std::max(worst, (model.PixelToGround(pixel) - Eigen::Vector2d(x, y)).norm());
    }
  }
  RecordProperty("max_error_m", FormatRounded(worst));
  EXPECT_LT(worst, 1e-5);
}

TEST(CameraEmulatorTest, ACameraOffCentreWritesItsOwnCalibration) {
  CameraOptions o = NoiseFree();
  o.camera_x = 1.5;
  o.camera_y = -0.5;
  o.camera_height = 3.0;
  o.focal = 600;
  const CameraEmulator camera(o);
  const host::CameraModel model = ModelOf(camera, 0.1);
  Eigen::Vector2d pixel;
  ASSERT_TRUE(camera.ProjectExact({1.9, -0.2, 0.1}, &pixel));
  EXPECT_LT((model.PixelToGround(pixel) - Eigen::Vector2d(1.9, -0.2)).norm(), 1e-5);
}

TEST(CameraEmulatorTest, CaptureRoundsAddsSeededNoiseAndDropsFrames) {
  CameraOptions o;
  o.noise = 0.5;
  o.dropout = 0.2;
  o.seed = 42;
  CameraEmulator a(o), b(o);
  o.seed = 43;
  CameraEmulator c(o);
  int dropped = 0, differ = 0, inside = 0;
  double sum_sq = 0;
  const int n = 4000;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d led(0.001 * i - 2.0, 0.2, 0.05);
    const CameraFrame fa = a.Capture(led), fb = b.Capture(led), fc = c.Capture(led);
    EXPECT_EQ(fa.state, fb.state);
    EXPECT_EQ(fa.pixel, fb.pixel) << "the same seed replays exactly";
    if (fa.state != fc.state || fa.pixel != fc.pixel) ++differ;
    if (fa.state == FrameState::kOutside) continue;
    ++inside;
    EXPECT_EQ(fa.pixel, fa.pixel.array().round().matrix()) << "integer pixels";
    EXPECT_GE(fa.pixel.x(), 0);
    EXPECT_LE(fa.pixel.x(), 639);
    if (fa.state == FrameState::kDropout) ++dropped;
    sum_sq += (fa.pixel - fa.exact).squaredNorm() / 2;
  }
  EXPECT_GT(differ, n / 4) << "another seed, other frames";
  EXPECT_GT(inside, 2000) << "about 1.1 m visible each side of the lens";
  EXPECT_LT(inside, 3000);
  EXPECT_NEAR(static_cast<double>(dropped) / inside, 0.2, 0.03);
  // Rounding adds 1/12 px^2 of variance to the noise's 0.25.
  const double rms = std::sqrt(sum_sq / inside);
  EXPECT_NEAR(rms, std::sqrt(0.25 + 1.0 / 12), 0.1);
  EXPECT_EQ(a.PixelText(321), "321");
  o.integer_pixels = false;
  EXPECT_EQ(CameraEmulator(o).PixelText(321.5), "321.500");
}

TEST(CameraEmulatorTest, RejectsBadOptions) {
  auto code = [](auto change) {
    CameraOptions o;
    change(o);
    return CodeOf([&] { CameraEmulator camera(o); });
  };
  EXPECT_EQ(code([](CameraOptions& o) { o.camera_height = 0; }), StatusCode::kInvalidArgument);
  EXPECT_EQ(code([](CameraOptions& o) { o.noise = -1; }), StatusCode::kInvalidArgument);
  EXPECT_EQ(code([](CameraOptions& o) { o.dropout = 1; }), StatusCode::kInvalidArgument);
  EXPECT_EQ(code([](CameraOptions& o) { o.focal = NAN; }), StatusCode::kInvalidArgument);
  EXPECT_EQ(code([](CameraOptions& o) { o.k1 = -3; }), StatusCode::kInvalidArgument) << "folds";
  EXPECT_EQ(CodeOf([] { CameraEmulator(CameraOptions{}).CalibrationText(2.7); }),
            StatusCode::kInvalidArgument)
      << "an LED at the lens";
  EXPECT_EQ(CodeOf([] { FrameClock clock(0); }), StatusCode::kInvalidArgument);
}

TEST(FrameClockTest, FilmsEachFrameSlotOnceAndAStillSimulationEveryFramePeriod) {
  FrameClock clock(25);
  const auto t0 = Clock::now();
  auto d = clock.Poll(0.0, t0);
  EXPECT_TRUE(d.capture);
  EXPECT_FALSE(d.restarted);
  EXPECT_FALSE(clock.Poll(0.01, t0 + 1ms).capture) << "same slot [0, 0.04)";
  d = clock.Poll(0.04, t0 + 2ms);
  EXPECT_TRUE(d.capture) << "0.04 is the next slot despite rounding";
  EXPECT_EQ(d.skipped, 0u);
  d = clock.Poll(0.2, t0 + 3ms);
  EXPECT_TRUE(d.capture);
  EXPECT_EQ(d.skipped, 3u) << "slots 2, 3, 4 passed between two polls";
  EXPECT_FALSE(clock.Poll(0.2, t0 + 20ms).capture);
  EXPECT_TRUE(clock.Poll(0.2, t0 + 43ms).capture) << "a still simulation is filmed at 25 Hz wall";
  d = clock.Poll(0.1, t0 + 44ms);
  EXPECT_TRUE(d.capture);
  EXPECT_TRUE(d.restarted) << "the simulation clock went back";
}

// A pose source moving along x at 0.1 m/s of simulation time, stepped by the test.
struct FakeSimulation {
  double time = 0;
  SimulatedPose operator()() const { return {time, {0.1 * time, 0.2, 0.05}}; }
};

TEST(EmulatorTest, ServesFramesThatTheTrackerCorrectsAfterTheLatency) {
  EmulatorOptions options;
  options.camera.noise = 0;
  options.camera.integer_pixels = false;
  options.latency = 0.05;
  options.first_seq = 4294967294u;  // wraps to 0
  CamAppServer server(CamAppServerOptions{.port = 0});
  FakeSimulation sim;
  std::ostringstream truth;
  Emulator emulator(options, server, [&sim] { return sim(); }, &truth);
  auto tracker = std::make_shared<host::LedTracker>(
      ModelOf(emulator.camera(), 0.05),
      host::LedTrackerOptions{.port = server.port(), .reconnect_delay = 0.05});
  std::mutex mutex;
  std::vector<host::LedSample> samples;
  tracker->SetSampleHandler([&](const host::LedSample& s) {
    std::lock_guard lock(mutex);
    samples.push_back(s);
  });
  for (int i = 0; i < 500 && !tracker->connected(); ++i) std::this_thread::sleep_for(10ms);
  ASSERT_TRUE(tracker->connected());
  EXPECT_EQ(server.clients(), 1);

  std::vector<Clock::time_point> published;
  for (int k = 0; k < 3; ++k) {
    sim.time = 0.04 * k;
    const auto now = Clock::now();
    ASSERT_TRUE(emulator.PollOnce(now));
    published.push_back(now);
  }
  ASSERT_TRUE(tracker->WaitForSample([](const host::LedSample& s) { return s.sample.seq == 0; }, 5s));
  tracker->SetSampleHandler(nullptr);
  std::lock_guard lock(mutex);
  ASSERT_EQ(samples.size(), 3u);
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(samples[k].sample.camera_time_us, 40000u * k) << "the simulation's clock";
    EXPECT_GE(samples[k].arrival - published[k], 50ms) << "sent after the latency";
    const host::TrackedPosition p = tracker->Locate(samples[k]);
    EXPECT_NEAR(p.ground.x(), 0.1 * 0.04 * k, 1e-5);
    EXPECT_NEAR(p.ground.y(), 0.2, 1e-5);
  }
  EXPECT_EQ(samples[0].sample.seq, 4294967294u);
  EXPECT_EQ(samples[2].sample.seq, 0u) << "seq wraps";
  const std::string log = truth.str();
  EXPECT_EQ(log.substr(0, log.find('\n')), kTruthHeader);
  EXPECT_THAT(log, HasSubstr("\n4294967295,40000,0.04,0.004"));
  EXPECT_THAT(log, HasSubstr(",0.2,0.05,seen,"));
  EXPECT_EQ(emulator.frames(), 3u);
}

TEST(EmulatorTest, AStalledPoseMakesNoFramesAndOutsideFramesAreNotSeen) {
  CamAppServer server(CamAppServerOptions{.port = 0});
  bool fail = true;
  double x = 0;
  std::ostringstream truth;
  Emulator emulator(EmulatorOptions{}, server,
                    [&]() -> SimulatedPose {
                      if (fail) throw Error(StatusCode::kUnavailable, "yamord 127.0.0.1:1: down");
                      return {1.0, {x, 0, 0.05}};
                    },
                    &truth);
  EXPECT_FALSE(emulator.PollOnce(Clock::now()));
  EXPECT_FALSE(emulator.first_pose().has_value());
  fail = false;
  x = 5.0;  // far outside the field
  EXPECT_TRUE(emulator.PollOnce(Clock::now()));
  EXPECT_THAT(truth.str(), HasSubstr(",outside,,\n"));
  EXPECT_EQ(CodeOf([&] {
              Emulator bad(EmulatorOptions{.latency = -1}, server, [] { return SimulatedPose{}; }, nullptr);
            }),
            StatusCode::kInvalidArgument);
}

TEST(CamAppServerTest, APortInUseIsUnavailable) {
  CamAppServer first(CamAppServerOptions{.port = 0});
  std::string message;
  EXPECT_EQ(CodeOf([&] { CamAppServer second(CamAppServerOptions{.port = first.port()}); }, &message),
            StatusCode::kUnavailable);
  EXPECT_THAT(message, HasSubstr("127.0.0.1:" + std::to_string(first.port())));
}

}  // namespace
}  // namespace yamor::camapp
