// LedTracker against an in-test CamApp server on an ephemeral loopback port:
// samples decoded and corrected, "not seen", staleness, a server restart,
// protocol errors; and the sample-line decoder on its own.
#include "host/led_tracker.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <utility>  // before Asio: its awaitable.hpp uses std::exchange

#include <boost/asio.hpp>
#include <atomic>
#include <cstdio>
#include <mutex>
#include <vector>
#include <functional>
#include <thread>

#include "common/format.h"
#include "common/status.h"
#include "tests/support/code_of.h"

namespace yamor::host {
namespace {

namespace asio = boost::asio;
using asio::ip::tcp;
using ::testing::HasSubstr;
using ::yamor::testing::CodeOf;
using namespace std::chrono_literals;

constexpr double kDepth = 2.64;  // camera 2.7 m above the ground, LED at 6 cm

LensParameters Lens() {
  LensParameters p;
  p.fx = p.fy = 520;
  p.cx = 319.5;
  p.cy = 239.5;
  p.k1 = -0.28;
  p.k2 = 0.09;
  p.k3 = -0.012;
  p.p1 = 0.0004;
  p.p2 = -0.0002;
  return p;
}

// Raw pixel of ground point g for a camera looking straight down.
Eigen::Vector2d RawPixel(const LensModel& lens, const Eigen::Vector2d& g) {
  const auto& p = lens.params();
  return lens.Distort({p.fx * g.x() / kDepth + p.cx, -p.fy * g.y() / kDepth + p.cy});
}

CameraModel Model() {
  CameraCalibration cal;
  cal.lens = Lens();
  cal.led_height = 0.06;
  const LensModel lens(cal.lens);
  for (double x = -1.2; x <= 1.2; x += 0.4)
    for (double y = -0.8; y <= 0.8; y += 0.4) cal.points.push_back({RawPixel(lens, {x, y}), {x, y}, 0});
  return CameraModel(cal, "test");
}

// A blocking CamApp stand-in: accepts one client and writes lines to it.
class FakeCamApp {
 public:
  explicit FakeCamApp(unsigned short port = 0)
      : acceptor_(io_, tcp::endpoint(asio::ip::address_v4::loopback(), port)), socket_(io_) {}
  unsigned short port() const { return acceptor_.local_endpoint().port(); }
  void Accept() { acceptor_.accept(socket_); }
  void Send(const std::string& text) { asio::write(socket_, asio::buffer(text)); }
  void Close() {
    boost::system::error_code ignored;
    socket_.close(ignored);
    acceptor_.close(ignored);
  }

 private:
  asio::io_context io_;
  tcp::acceptor acceptor_;
  tcp::socket socket_;
};

bool WaitFor(const std::function<bool()>& condition) {
  for (int i = 0; i < 500; ++i) {
    if (condition()) return true;
    std::this_thread::sleep_for(10ms);
  }
  return condition();
}

bool WaitForSeq(const LedTracker& tracker, std::uint32_t seq) {
  return WaitFor([&] {
    const auto s = tracker.LatestSample();
    return s && s->sample.seq == seq;
  });
}

std::string Fixed(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6f", v);
  return buf;
}

LedTrackerOptions Options(unsigned short port) {
  LedTrackerOptions o;
  o.port = port;
  o.reconnect_delay = 0.05;
  return o;
}

TEST(CamAppLineTest, DecodesSamples) {
  const CamAppSample s = ParseCamAppSample("1041  83200000 321 240.5", 640, 480);
  EXPECT_EQ(s.seq, 1041u);
  EXPECT_EQ(s.camera_time_us, 83200000u);
  EXPECT_TRUE(s.seen);
  EXPECT_EQ(s.pixel, Eigen::Vector2d(321, 240.5));
  const CamAppSample hidden = ParseCamAppSample("4294967295 18446744073709551615 - -", 640, 480);
  EXPECT_EQ(hidden.seq, 4294967295u);
  EXPECT_FALSE(hidden.seen);
  EXPECT_DOUBLE_EQ(ParseCamAppSample("0 0 639 479", 640, 480).pixel.x(), 639);
}

TEST(CamAppLineTest, RejectsMalformedLines) {
  for (const char* bad : {"1 2 3", "1 2 3 4 5", "x 2 3 4", "-1 2 3 4", "1 2 640 4", "1 2 3 480",
                          "1 2 3.1234567 4", "1 2 -3 4", "1 2 nan 4", "1 2 1e2 4", "1 2 - 4",
                          "4294967296 0 1 1", "1 2 3. 4"}) {
    try {
      ParseCamAppSample(bad, 640, 480);
      ADD_FAILURE() << "accepted \"" << bad << "\"";
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), StatusCode::kInvalidArgument);
      EXPECT_THAT(e.what(), HasSubstr(bad));
    }
  }
}

TEST(LedTrackerTest, DecodesAndCorrectsSamples) {
  FakeCamApp server;
  LedTracker tracker(Model(), Options(server.port()));
  server.Accept();
  server.Send("YAMOR-CAMAPP 1 640 480\n# relay comment\n");
  const LensModel lens(Lens());
  double worst = 0;
  std::uint32_t seq = 7;
  for (const Eigen::Vector2d& g : {Eigen::Vector2d(0.5, 0.3), Eigen::Vector2d(-1.1, 0.75), Eigen::Vector2d(0, 0)}) {
    const Eigen::Vector2d raw = RawPixel(lens, g);
    ++seq;
    server.Send(std::to_string(seq) + " " + std::to_string(1000 * seq) + " " + Fixed(raw.x()) + " " +
                Fixed(raw.y()) + "\r\n");
    ASSERT_TRUE(WaitForSeq(tracker, seq));
    const TrackedPosition p = tracker.LatestPosition(5s);
    EXPECT_EQ(p.camera_time_us, 1000u * seq);
    worst = std::max(worst, (p.ground - g).norm());
  }
  RecordProperty("max_error_m", FormatRounded(worst));
  EXPECT_LT(worst, 1e-6);  // pixels rounded to 1e-6 px
  EXPECT_TRUE(tracker.connected());
  EXPECT_EQ(tracker.connections(), 1u);

  server.Send("12 13000 - -\n");
  ASSERT_TRUE(WaitForSeq(tracker, 12));
  try {
    tracker.LatestPosition(5s);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kUnavailable);
    EXPECT_THAT(e.what(), HasSubstr("led-tracker 127.0.0.1:"));
    EXPECT_THAT(e.what(), HasSubstr("not seen"));
  }
}

TEST(LedTrackerTest, StaleStreamIsUnavailable) {
  FakeCamApp server;
  LedTracker tracker(Model(), Options(server.port()));
  try {
    tracker.LatestPosition(1s);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kUnavailable);
    EXPECT_THAT(e.what(), HasSubstr("no sample"));
  }
  server.Accept();
  server.Send("YAMOR-CAMAPP 1 640 480\n5 100 320 240\n");
  ASSERT_TRUE(WaitForSeq(tracker, 5));
  EXPECT_NO_THROW(tracker.LatestPosition(5s));
  std::this_thread::sleep_for(150ms);
  try {
    tracker.LatestPosition(100ms);
    FAIL() << "a stale sample passed off as fresh";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kUnavailable);
    EXPECT_THAT(e.what(), HasSubstr(tracker.name()));
    EXPECT_THAT(e.what(), HasSubstr("seq 5"));
    EXPECT_THAT(e.what(), HasSubstr("s old"));
  }
}

TEST(LedTrackerTest, ReconnectsAfterServerRestart) {
  auto server = std::make_unique<FakeCamApp>();
  const unsigned short port = server->port();
  LedTracker tracker(Model(), Options(port));
  server->Accept();
  server->Send("YAMOR-CAMAPP 1 640 480\n100 1 320 240\n");
  ASSERT_TRUE(WaitForSeq(tracker, 100));
  server->Close();
  server.reset();
  ASSERT_TRUE(WaitFor([&] { return !tracker.connected(); }));
  server = std::make_unique<FakeCamApp>(port);
  server->Accept();
  server->Send("YAMOR-CAMAPP 1 640 480\n3 2 330 250\n");
  ASSERT_TRUE(WaitForSeq(tracker, 3));
  EXPECT_TRUE(tracker.connected());
  EXPECT_EQ(tracker.connections(), 2u);
  EXPECT_NO_THROW(tracker.LatestPosition(5s));
}

TEST(LedTrackerTest, ProtocolErrorsDropTheConnection) {
  FakeCamApp server;
  LedTracker tracker(Model(), Options(server.port()));
  server.Accept();
  const unsigned short port = server.port();
  server.Send("HELLO\n");  // not our protocol
  server.Close();
  FakeCamApp second(port);
  second.Accept();
  EXPECT_EQ(tracker.connections(), 0u);
  second.Send("YAMOR-CAMAPP 1 640 480\n1 1 700 10\n");  // outside the image
  ASSERT_TRUE(WaitFor([&] { return tracker.connections() == 1u && !tracker.connected(); }));
  EXPECT_FALSE(tracker.LatestSample().has_value());
}

TEST(LedTrackerTest, RawOnlyTrackerHandsEverySampleToItsHandler) {
  FakeCamApp server;
  LedTracker tracker(640, 480, Options(server.port()));
  EXPECT_FALSE(tracker.has_model());
  std::mutex mutex;
  std::vector<LedSample> received;
  tracker.SetSampleHandler([&](const LedSample& s) {
    std::lock_guard lock(mutex);
    received.push_back(s);
  });
  server.Accept();
  server.Send("YAMOR-CAMAPP 1 640 480\n1 40000 12 34\n2 80000 - -\n3 120000 600.25 470\n");
  ASSERT_TRUE(WaitForSeq(tracker, 3));
  tracker.SetSampleHandler(nullptr);
  std::lock_guard lock(mutex);
  ASSERT_EQ(received.size(), 3u) << "every sample, not only the latest";
  EXPECT_EQ(received[0].sample.pixel, Eigen::Vector2d(12, 34));
  EXPECT_FALSE(received[1].sample.seen);
  EXPECT_EQ(received[2].sample.camera_time_us, 120000u);
  EXPECT_EQ(received[2].connection, 1u);
  EXPECT_EQ(CodeOf([&] { tracker.LatestPosition(5s); }), StatusCode::kFailedPrecondition)
      << "no calibration: no metres";
  EXPECT_EQ(CodeOf([&] { LedTracker(0, 480, Options(server.port())); }), StatusCode::kInvalidArgument);
}

TEST(LedTrackerTest, WaitForSampleWaitsForAnAcceptableOne) {
  FakeCamApp server;
  LedTracker tracker(Model(), Options(server.port()));
  auto after = [](std::uint64_t us) {
    return [us](const LedSample& s) { return s.sample.camera_time_us >= us; };
  };
  EXPECT_FALSE(tracker.WaitForSample(after(0), 50ms).has_value()) << "nothing received";
  server.Accept();
  server.Send("YAMOR-CAMAPP 1 640 480\n1 1000 320 240\n");
  ASSERT_TRUE(WaitForSeq(tracker, 1));
  EXPECT_EQ(tracker.WaitForSample(after(1000), 0s)->sample.seq, 1u) << "the latest already qualifies";
  std::thread late([&] {
    std::this_thread::sleep_for(50ms);
    server.Send("2 2000 321 241\n");
  });
  const auto found = tracker.WaitForSample(after(2000), 5s);
  late.join();
  ASSERT_TRUE(found.has_value());
  EXPECT_EQ(found->sample.seq, 2u);
}

TEST(LedTrackerTest, PositionTrackerReportsTheFrameCapturedInTheWindow) {
  FakeCamApp server;
  auto tracker = std::make_shared<LedTracker>(Model(), Options(server.port()));
  const auto positions = MakeLedPositionTracker(tracker, 300ms);
  EXPECT_EQ(positions->name(), tracker->name());
  std::atomic<int> handled{0};
  positions->SetHandler([&](const TrackedPose&) { ++handled; });
  server.Accept();
  const LensModel lens(Lens());
  const Eigen::Vector2d raw = RawPixel(lens, {0.4, -0.2});
  // Frames at 1 s (LED seen), 2 s (not seen) and, after a reset, 0.5 s.
  server.Send("YAMOR-CAMAPP 1 640 480\n1 1000000 " + Fixed(raw.x()) + " " + Fixed(raw.y()) + "\n");
  ASSERT_TRUE(WaitForSeq(*tracker, 1));
  const TrackedPose pose = positions->CapturedBetween(1.0, [] { return 1.0; });
  EXPECT_NEAR(pose.position[0], 0.4, 1e-6);
  EXPECT_NEAR(pose.position[1], -0.2, 1e-6);
  EXPECT_DOUBLE_EQ(pose.position[2], 0.06) << "the calibration's LED height";
  EXPECT_DOUBLE_EQ(pose.camera_time, 1.0);
  EXPECT_EQ(handled.load(), 1);

  std::string message;
  EXPECT_EQ(CodeOf([&] { positions->CapturedBetween(1.5, [] { return 5.0; }); }, &message),
            StatusCode::kUnavailable);
  EXPECT_THAT(message, HasSubstr("captured at 1 s")) << "only an older frame came";
  server.Send("2 2000000 - -\n");
  ASSERT_TRUE(WaitForSeq(*tracker, 2));
  EXPECT_EQ(CodeOf([&] { positions->CapturedBetween(1.5, [] { return 5.0; }); }, &message),
            StatusCode::kUnavailable);
  EXPECT_THAT(message, HasSubstr("LED not seen since"));
  EXPECT_EQ(CodeOf([&] { positions->CapturedBetween(0.0, [] { return 0.5; }); }, &message),
            StatusCode::kUnavailable)
      << "a frame captured after the simulation's present is from before its reset";
  std::thread late([&] {
    std::this_thread::sleep_for(30ms);
    server.Send("3 2000000 " + Fixed(raw.x()) + " " + Fixed(raw.y()) + "\n");
  });
  EXPECT_DOUBLE_EQ(positions->CapturedBetween(1.5, [] { return 5.0; }).camera_time, 2.0)
      << "waits for the next frame that sees the LED";
  late.join();
  EXPECT_EQ(handled.load(), 2) << "seen frames only";
  positions->SetHandler(nullptr);
  EXPECT_NEAR(positions->Latest().position[0], 0.4, 1e-6);
}

}  // namespace
}  // namespace yamor::host
