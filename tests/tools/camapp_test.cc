// yamor-camapp's pieces in-process: the camera (projection, distortion,
// noise, rounding, dropouts, seeds), the calibration it writes (a tracker
// loading it recovers metres), the frame clock, and the CamApp server and
// filming loop against the host's LedTracker on loopback (latency, truth log).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <unistd.h>
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
#include "tools/camapp/camera_picture.h"
#include "tools/camapp/emulator.h"
#include "physics/render/renderer.h"

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
  EXPECT_EQ(code([](CameraOptions& o) { o.led_cone = 0; }), StatusCode::kInvalidArgument);
  EXPECT_EQ(code([](CameraOptions& o) { o.led_cone = 181; }), StatusCode::kInvalidArgument);
  EXPECT_EQ(code([](CameraOptions& o) { o.led_cone = NAN; }), StatusCode::kInvalidArgument);
  EXPECT_EQ(code([](CameraOptions& o) { o.led_axis = Eigen::Vector3d::Zero(); }), StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf([] { CameraEmulator(CameraOptions{}).SetLedAxis(Eigen::Vector3d(NAN, 0, 1)); }),
            StatusCode::kInvalidArgument);
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

// The LED faces the central module's +z: a robot on its back hides it, a
// tilted one shows it while the lens stays inside the emission cone.
TEST(CameraEmulatorTest, TheLedIsHiddenWhenItFacesAwayFromTheLens) {
  CameraOptions o = NoiseFree();
  o.led_cone = 80.0;
  CameraEmulator camera(o);
  const Eigen::Vector3d below_lens(0.0, 0.0, 0.05);
  auto tilted = [](double degrees) {
    return Eigen::Quaterniond(Eigen::AngleAxisd(degrees * M_PI / 180.0, Eigen::Vector3d::UnitX()));
  };
  EXPECT_EQ(camera.Capture(below_lens).state, FrameState::kSeen);
  EXPECT_EQ(camera.Capture(below_lens, tilted(60)).state, FrameState::kSeen);
  EXPECT_EQ(camera.Capture(below_lens, tilted(79)).state, FrameState::kSeen);
  EXPECT_EQ(camera.Capture(below_lens, tilted(81)).state, FrameState::kHidden);
  EXPECT_EQ(camera.Capture(below_lens, tilted(180)).state, FrameState::kHidden) << "upside down";
  EXPECT_EQ(camera.Capture(below_lens, tilted(-100)).state, FrameState::kHidden);
  // Off to the side the lens is seen at an angle: tilting towards it keeps
  // the LED visible further, tilting away hides it sooner.
  const Eigen::Vector3d aside(0.0, 1.0, 0.05);  // lens direction 20 deg from vertical, towards -y
  EXPECT_FALSE(camera.LedFacesLens(aside, tilted(-65)));  // faces +y: 85 deg from the lens
  EXPECT_TRUE(camera.LedFacesLens(aside, tilted(95)));    // faces -y: 75 deg from the lens
  // Outside the image wins over hidden; a hidden frame keeps its exact pixel.
  EXPECT_EQ(camera.Capture(Eigen::Vector3d(5.0, 0.0, 0.05), tilted(180)).state, FrameState::kOutside);
  const CameraFrame hidden = camera.Capture(below_lens, tilted(180));
  EXPECT_NEAR(hidden.exact.x(), o.cx, 1e-9);
  EXPECT_STREQ(FrameStateName(FrameState::kHidden), "hidden");
  // A cone of 180 deg never hides it.
  o.led_cone = 180.0;
  EXPECT_EQ(CameraEmulator(o).Capture(below_lens, tilted(180)).state, FrameState::kSeen);
}

TEST(EmulatorTest, ARobotOnItsBackSendsNotSeenAndLogsHidden) {
  CamAppServer server(CamAppServerOptions{.port = 0});
  std::ostringstream truth;
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();
  double time = 0.0;
  std::vector<CapturedFrame> observed;
  Emulator emulator(EmulatorOptions{}, server,
                    [&]() -> SimulatedPose { return {time, {0.1, 0.1, 0.05}, orientation}; }, &truth);
  emulator.SetFrameObserver([&](const CapturedFrame& f) { observed.push_back(f); });
  EXPECT_TRUE(emulator.PollOnce(Clock::now()));
  orientation = Eigen::Quaterniond(Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitY()));
  time = 0.04;
  EXPECT_TRUE(emulator.PollOnce(Clock::now()));
  EXPECT_THAT(truth.str(), HasSubstr(",seen,"));
  EXPECT_THAT(truth.str(), HasSubstr(",hidden,,\n"));
  ASSERT_EQ(observed.size(), 2u);
  EXPECT_EQ(observed[0].frame.state, FrameState::kSeen);
  EXPECT_EQ(observed[1].frame.state, FrameState::kHidden);
  EXPECT_EQ(observed[1].seq, observed[0].seq + 1);
  EXPECT_EQ(observed[1].time_us, 40000u);
  // A module built lying on its side (the quadruped's central module: +x
  // up) carries its LED on that side: the first pose tells which axis.
  CamAppServer server2(CamAppServerOptions{.port = 0});
  const Eigen::Quaterniond on_side(Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitY()));
  orientation = on_side;
  Emulator lying(EmulatorOptions{}, server2, [&]() -> SimulatedPose { return {time, {0.1, 0.1, 0.05}, orientation}; },
                 nullptr);
  lying.SetFrameObserver([&](const CapturedFrame& f) { observed.push_back(f); });
  EXPECT_TRUE(lying.PollOnce(Clock::now()));
  EXPECT_EQ(observed.back().frame.state, FrameState::kSeen);
  EXPECT_TRUE(lying.camera().options().led_axis.isApprox(Eigen::Vector3d::UnitX()));
  orientation = Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitY()));  // flipped over
  time += 0.04;
  EXPECT_TRUE(lying.PollOnce(Clock::now()));
  EXPECT_EQ(observed.back().frame.state, FrameState::kHidden);
  // Without the automatic axis the LED faces the module's +z as configured.
  EmulatorOptions fixed;
  fixed.led_axis_from_first_pose = false;
  orientation = on_side;
  Emulator configured(fixed, server2, [&]() -> SimulatedPose { return {time, {0.1, 0.1, 0.05}, orientation}; },
                      nullptr);
  configured.SetFrameObserver([&](const CapturedFrame& f) { observed.push_back(f); });
  time += 0.04;
  EXPECT_TRUE(configured.PollOnce(Clock::now()));
  EXPECT_EQ(observed.back().frame.state, FrameState::kHidden) << "+z is horizontal";
  orientation = Eigen::Quaterniond::Identity();
  // A pose with a degenerate orientation is no pose.
  orientation = Eigen::Quaterniond(0, 0, 0, 0);
  time = 0.08;
  EXPECT_FALSE(emulator.PollOnce(Clock::now()));
}

// The camera's picture: a real top-down render resampled through the lens
// shows a module where the camera's own projection puts it, also in the
// corners where the barrel moves it by many pixels.
TEST(CameraPictureTest, AModuleAppearsWhereTheLensProjectsIt) {
  std::unique_ptr<render::Renderer> renderer;
  try {
    renderer = std::make_unique<render::Renderer>();
  } catch (const Error& e) {
    GTEST_SKIP() << "no renderer here: " << e.what();
  }
  CameraOptions o = NoiseFree();
  CameraEmulator camera(o);
  CameraPicture picture(camera);
  const PinholeRequest& request = picture.request();
  EXPECT_GT(request.width, o.width) << "the barrel needs a wider pinhole view";
  EXPECT_GT(request.height_px, o.height);
  const render::RenderOptions flat{.lighting = false, .edges = false, .grid = false, .shadows = false,
                                   .labels = false, .legend = false};
  render::Camera top;
  top.kind = render::CameraKind::kTop;
  top.target = request.target;
  top.height = request.height;
  top.fov = request.fov;
  const render::Color colour = render::ModuleColor(1);
  const std::array<int, 3> want = {static_cast<int>(std::lround(colour[0] * 255)),
                                   static_cast<int>(std::lround(colour[1] * 255)),
                                   static_cast<int>(std::lround(colour[2] * 255))};
  double largest_shift = 0.0;
  for (const Eigen::Vector2d& ground : {Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(0.6, 0.4),
                                       Eigen::Vector2d(-1.0, -0.75), Eigen::Vector2d(1.1, 0.8)}) {
    render::Scene scene;
    scene.shape = {render::ShapeBox{.part = render::ShapePart::kBody, .center = Eigen::Vector3d::Zero(),
                                    .size = Eigen::Vector3d(0.06, 0.06, 0.002)}};
    render::SceneModule m;
    m.id = 1;
    m.body.position = Eigen::Vector3d(ground.x(), ground.y(), 0.001);  // a thin plate: no sides seen
    m.handle.position = m.body.position;
    scene.modules.push_back(m);
    const render::Image pinhole = renderer->Render(scene, top, request.width, request.height_px, flat);
    const render::Image image = picture.Distort(pinhole);
    ASSERT_EQ(image.width, o.width);
    ASSERT_EQ(image.height, o.height);
    Eigen::Vector2d sum = Eigen::Vector2d::Zero();
    int n = 0;
    for (int y = 0; y < image.height; ++y) {
      for (int x = 0; x < image.width; ++x) {
        const auto p = image.At(x, y);
        if (std::abs(p[0] - want[0]) <= 2 && std::abs(p[1] - want[1]) <= 2 && std::abs(p[2] - want[2]) <= 2) {
          sum += Eigen::Vector2d(x, y);
          ++n;
        }
      }
    }
    ASSERT_GT(n, 20) << "module at " << ground.transpose() << " not in the picture";
    Eigen::Vector2d expected, ideal;
    const Eigen::Vector3d top_face(ground.x(), ground.y(), 0.001);
    ASSERT_TRUE(camera.ProjectExact(top_face, &expected));
    ASSERT_TRUE(camera.ProjectIdeal(top_face, &ideal));
    EXPECT_LT((sum / n - expected).norm(), 1.0) << "module at " << ground.transpose();
    largest_shift = std::max(largest_shift, (expected - ideal).norm());
  }
  EXPECT_GT(largest_shift, 10.0) << "the corners must test the distortion";
  // The reported pixel is marked, and a wrong render size is refused.
  render::Image blank{.width = o.width, .height = o.height,
                      .rgba = std::vector<uint8_t>(static_cast<size_t>(o.width) * o.height * 4, 0)};
  CameraPicture::MarkPixel(blank, {100, 50}, 9, {40, 220, 60});
  EXPECT_EQ(blank.At(108, 50)[1], 220);
  EXPECT_EQ(blank.At(100, 50)[1], 0) << "the LED itself stays visible";
  EXPECT_EQ(CodeOf([&] { picture.Distort(blank); }), StatusCode::kInvalidArgument);
}

TEST(PictureRecorderTest, WritesPicturesAndAnIndexAndSurvivesAFailedRender) {
  CameraOptions o = NoiseFree();
  o.width = 64;
  o.height = 48;
  o.cx = 31.5;
  o.cy = 23.5;
  o.focal = 80;
  CameraEmulator camera(o);
  const std::filesystem::path folder =
      std::filesystem::temp_directory_path() / ("camapp_pictures_" + std::to_string(::getpid()));
  std::filesystem::remove_all(folder);
  std::atomic<int> calls{0};
  {
    PictureRecorder recorder(camera, folder, 2, [&](const PinholeRequest& request) {
      if (++calls == 2) throw Error(StatusCode::kUnavailable, "yamord gone");
      render::Image grey{.width = request.width, .height = request.height_px,
                         .rgba = std::vector<uint8_t>(
                             static_cast<size_t>(request.width) * request.height_px * 4, 128)};
      return std::pair{render::EncodePng(grey), 0.5 * calls};
    });
    for (std::uint32_t seq = 0; seq < 6; ++seq) {
      CapturedFrame frame;
      frame.seq = seq;
      frame.time_us = seq * 40000;
      frame.frame = camera.Capture(Eigen::Vector3d(0, 0, 0.05));
      recorder.Offer(frame);
      recorder.Drain();
    }
    EXPECT_EQ(recorder.written(), 2u) << "frames 0, 2, 4; the render of 2 failed";
    EXPECT_EQ(recorder.failed(), 1u);
    EXPECT_EQ(recorder.skipped(), 0u);
  }
  EXPECT_TRUE(std::filesystem::exists(folder / "frame-000000.png"));
  EXPECT_FALSE(std::filesystem::exists(folder / "frame-000001.png"));
  EXPECT_FALSE(std::filesystem::exists(folder / "frame-000002.png"));
  EXPECT_TRUE(std::filesystem::exists(folder / "frame-000004.png"));
  std::ifstream index(folder / "frames.csv");
  std::stringstream text;
  text << index.rdbuf();
  EXPECT_THAT(text.str(), HasSubstr("seq,camera_time_us,picture_time,state,pixel_x,pixel_y,file\n"));
  EXPECT_THAT(text.str(), HasSubstr("4,160000,1.5,seen,31.500,23.500,frame-000004.png\n"));
  std::ifstream png(folder / "frame-000004.png", std::ios::binary);
  const std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(png)), std::istreambuf_iterator<char>());
  const render::Image decoded = render::DecodePng(bytes);
  EXPECT_EQ(decoded.width, 64);
  EXPECT_EQ(decoded.height, 48);
  std::filesystem::remove_all(folder);
  EXPECT_EQ(CodeOf([&] { PictureRecorder bad(camera, folder, 0, nullptr); }), StatusCode::kInvalidArgument);
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
