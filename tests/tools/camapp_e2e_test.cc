// End to end, real processes on loopback: yamord (the quadruped, virtual
// time, --position-source tracker) filmed by yamor-camapp, recorded by
// `yamorctl track`. Over a 20-s walk stepped 40 ms at a time, every tracked
// position (RobotPosition) is compared with the simulation's own
// (SimulatedPosition) at the same instant; random dropouts are waited out,
// and the camera is killed and restarted mid-walk. The recorded CSV is joined
// with the emulator's truth log.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "common/format.h"
#include "physics/render/image.h"
#include "tests/support/host_call.h"
#include "tests/support/unused_port.h"
#include "tests/support/yamord_process.h"
#include "yamor/v1/host.grpc.pb.h"

namespace yamor::camapp {
namespace {

namespace v1 = yamor::v1;
using google::protobuf::Empty;
using ::yamor::testing::YamordProcess;

const std::string kYamord = YAMORD_PATH;
const std::string kCamApp = YAMOR_CAMAPP_PATH;
const std::string kYamorctl = YAMORCTL_PATH;

// The quadruped's central module rests this high: the LED height the camera
// is calibrated for (checked below against the simulation).
constexpr double kLedHeight = 0.0401;

std::filesystem::path TempDir() {
  std::string pattern = (std::filesystem::temp_directory_path() / "yamor-camapp-XXXXXX").string();
  if (mkdtemp(pattern.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
  return pattern;
}

// yamor-camapp filming the yamord on `yamord_port`, serving on `port`.
std::unique_ptr<YamordProcess> StartCamera(int yamord_port, int port, const std::string& truth,
                                           const std::string& first_seq) {
  auto camera = std::make_unique<YamordProcess>(
      kCamApp, std::vector<std::string>{"--yamord", "127.0.0.1:" + std::to_string(yamord_port), "--listen",
                                        "127.0.0.1:" + std::to_string(port), "--truth", truth, "--noise",
                                        "0.1", "--dropout", "0.05", "--latency", "0.002", "--seed",
                                        first_seq, "--poll-interval", "0.002", "--first-seq", first_seq,
                                        "--log-level", "warn"});
  EXPECT_EQ(camera->ReadLine(), "yamor-camapp: listening on 127.0.0.1:" + std::to_string(port));
  return camera;
}

std::vector<std::vector<std::string>> ReadCsv(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::vector<std::string>> rows;
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    std::vector<std::string> fields;
    std::stringstream row(line);
    for (std::string f; std::getline(row, f, ',');) fields.push_back(f);
    if (!line.empty() && line.back() == ',') fields.emplace_back();
    rows.push_back(fields);
  }
  return rows;
}

struct Errors {
  double sum_sq = 0, max = 0;
  int n = 0;
  void Add(double e) {
    sum_sq += e * e;
    max = std::max(max, e);
    ++n;
  }
  double Rms() const { return n ? std::sqrt(sum_sq / n) : 0; }
};

// A calibration file written by yamor-camapp for the quadruped's LED height
// and a yamord (virtual time) whose position source is the camera on
// camera_port_, which each test starts itself.
class CamAppEndToEndTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = TempDir();
    calibration_ = (dir_ / "camera.txt").string();
    YamordProcess writer(kCamApp, {"--calibration-only", "--write-calibration", calibration_, "--led-height",
                                   FormatDouble(kLedHeight)});
    ASSERT_EQ(writer.WaitForExit(std::chrono::seconds(20)), 0);
    camera_port_ = ::yamor::testing::UnusedPort();  // fixed across the camera's restart
    yamord_ = std::make_unique<YamordProcess>(
        kYamord, std::vector<std::string>{"--listen", "127.0.0.1:0", "--log-level", "warn", "--led-tracker",
                                          "127.0.0.1:" + std::to_string(camera_port_), "--tracker-calibration",
                                          calibration_, "--tracker-max-age", "1", "--position-source",
                                          "tracker"});
    port_ = yamord_->WaitForPort();
    ASSERT_GT(port_, 0);
    stub_ = v1::Host::NewStub(
        grpc::CreateChannel("127.0.0.1:" + std::to_string(port_), grpc::InsecureChannelCredentials()));
  }

  template <typename Method, typename Request, typename Response>
  grpc::Status Call(Method method, const Request& request, Response* response) {
    return ::yamor::testing::Call(*stub_, method, request, response, 30);
  }

  std::filesystem::path dir_;
  std::string calibration_;
  int camera_port_ = 0;
  std::unique_ptr<YamordProcess> yamord_;
  int port_ = 0;
  std::unique_ptr<v1::Host::Stub> stub_;
};

TEST_F(CamAppEndToEndTest, TrackedPositionsOfAWalkAreWithin5mmThroughDropoutsAndACameraRestart) {
  const std::filesystem::path& dir = dir_;
  const std::string& calibration = calibration_;
  const int camera_port = camera_port_;
  const int port = port_;
  auto call = [this](auto method, const auto& request, auto* response) { return Call(method, request, response); };
  v1::RobotPositionResponse truth;
  ASSERT_OK(call(&v1::Host::Stub::SimulatedPosition, Empty(), &truth));
  ASSERT_NEAR(truth.position().z(), kLedHeight, 1e-4) << "the camera's calibration height";
  v1::RobotPositionResponse tracked;
  grpc::Status s = call(&v1::Host::Stub::RobotPosition, Empty(), &tracked);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::UNAVAILABLE) << "no camera yet";
  EXPECT_NE(s.error_message().find("led-tracker 127.0.0.1"), std::string::npos) << s.error_message();

  const std::string truth1 = (dir / "truth1.csv").string(), truth2 = (dir / "truth2.csv").string();
  auto camera = StartCamera(port, camera_port, truth1, "1");
  const std::string recorded = (dir / "track.csv").string();
  YamordProcess track(kYamorctl, {"track", "--camapp", "127.0.0.1:" + std::to_string(camera_port),
                                  "--calibration", calibration, "--record", recorded, "--timeout", "30"});

  ASSERT_OK(call(&v1::Host::Stub::ConnectRobot, v1::ConnectRobotRequest(), static_cast<v1::ConnectRobotResponse*>(nullptr)));
  v1::ControlMessageRequest control;
  control.set_cpg(v1::SWITCH_ON);
  control.set_motors(v1::SWITCH_ON);
  control.set_all(true);
  ASSERT_OK(call(&v1::Host::Stub::SendControlMessage, control, static_cast<Empty*>(nullptr)));

  Errors errors;
  int restarts_unavailable = 0;
  double start_x = 0, start_y = 0, end_x = 0, end_y = 0;
  v1::SleepRequest step;
  step.set_seconds(0.04);
  for (int k = 1; k <= 500; ++k) {
    if (k == 250) camera->Kill();  // the camera dies mid-walk
    ASSERT_OK(call(&v1::Host::Stub::Sleep, step, static_cast<v1::SleepResponse*>(nullptr)));
    if (k == 250) {
      // Nothing filmed the present: no position rather than a stale one.
      s = call(&v1::Host::Stub::RobotPosition, Empty(), &tracked);
      EXPECT_EQ(s.error_code(), grpc::StatusCode::UNAVAILABLE);
      EXPECT_NE(s.error_message().find("led-tracker"), std::string::npos) << s.error_message();
      camera = StartCamera(port, camera_port, truth2, "100001");
    }
    s = call(&v1::Host::Stub::RobotPosition, Empty(), &tracked);
    for (int retry = 0; retry < 10 && k >= 250 && s.error_code() == grpc::StatusCode::UNAVAILABLE; ++retry) {
      ++restarts_unavailable;  // the tracker reconnects to the restarted camera
      s = call(&v1::Host::Stub::RobotPosition, Empty(), &tracked);
    }
    ASSERT_OK(s);
    ASSERT_OK(call(&v1::Host::Stub::SimulatedPosition, Empty(), &truth));
    ASSERT_EQ(tracked.source(), "led-tracker");
    ASSERT_NEAR(tracked.time(), truth.time(), 1e-6) << "the frame captured at the present";
    errors.Add(std::hypot(tracked.position().x() - truth.position().x(),
                          tracked.position().y() - truth.position().y()));
    if (k == 1) start_x = truth.position().x(), start_y = truth.position().y();
    end_x = truth.position().x();
    end_y = truth.position().y();
  }
  const double walked = std::hypot(end_x - start_x, end_y - start_y);
  std::cout << "tracked vs true over " << errors.n << " positions of a " << FormatRounded(walked)
            << " m walk: RMS " << FormatRounded(errors.Rms() * 1e3) << " mm, max "
            << FormatRounded(errors.max * 1e3) << " mm\n";
  RecordProperty("rms_mm", FormatRounded(errors.Rms() * 1e3));
  RecordProperty("max_mm", FormatRounded(errors.max * 1e3));
  EXPECT_GT(walked, 0.05) << "the quadruped walked";
  EXPECT_EQ(errors.n, 500);
  EXPECT_LT(errors.max, 0.005);
  EXPECT_LT(restarts_unavailable, 10);

  // yamorctl track recorded the same frames: joined with the truth logs.
  track.Signal(SIGTERM);
  track.WaitForExit(std::chrono::seconds(10));
  camera.reset();
  std::map<std::pair<std::string, std::string>, std::vector<std::string>> frames;  // (seq, time) -> truth row
  for (const std::string& file : {truth1, truth2}) {
    for (auto& row : ReadCsv(file)) frames[{row[0], row[1]}] = row;
  }
  Errors recorded_errors;
  int dropouts = 0, connections = 0, rows = 0;
  for (const auto& row : ReadCsv(recorded)) {
    ASSERT_EQ(row.size(), 9u);
    ++rows;
    connections = std::max(connections, std::stoi(row[8]));
    const auto truth_row = frames.find({row[1], row[2]});
    ASSERT_NE(truth_row, frames.end()) << "a frame the camera sent: seq " << row[1];
    const std::string& state = truth_row->second[6];
    if (row[3] == "0") {
      EXPECT_NE(state, "seen");
      dropouts += state == "dropout";
      continue;
    }
    ASSERT_EQ(state, "seen");
    EXPECT_EQ(row[4], truth_row->second[7]) << "the pixel the camera sent";
    recorded_errors.Add(std::hypot(std::stod(row[6]) - std::stod(truth_row->second[3]),
                                   std::stod(row[7]) - std::stod(truth_row->second[4])));
  }
  std::cout << "yamorctl track: " << rows << " frames over " << connections << " connections, " << dropouts
            << " dropouts; corrected vs true RMS " << FormatRounded(recorded_errors.Rms() * 1e3) << " mm, max "
            << FormatRounded(recorded_errors.max * 1e3) << " mm\n";
  EXPECT_GT(rows, 500);
  EXPECT_EQ(connections, 2) << "it reconnected to the restarted camera";
  EXPECT_GT(dropouts, 0);
  EXPECT_LT(recorded_errors.max, 0.005);
  std::filesystem::remove_all(dir);
}

// The LED faces up from the central module: a robot turned on its back hides
// it, so the tracked position becomes UNAVAILABLE (never a stale one) and
// the camera logs the frames "hidden". With --frames the camera also writes
// its picture of the frames: the render resampled through its lens.
TEST_F(CamAppEndToEndTest, ARobotOnItsBackHidesTheLedAndTheCameraFilmsPictures) {
  const std::filesystem::path& dir = dir_;
  const int camera_port = camera_port_;
  const int port = port_;
  auto call = [this](auto method, const auto& request, auto* response) { return Call(method, request, response); };
  const std::string truth = (dir / "truth.csv").string();
  const std::filesystem::path pictures = dir / "pictures";
  YamordProcess camera(kCamApp, {"--yamord", "127.0.0.1:" + std::to_string(port), "--listen",
                                 "127.0.0.1:" + std::to_string(camera_port), "--truth", truth, "--noise", "0",
                                 "--latency", "0.002", "--poll-interval", "0.002", "--frames",
                                 pictures.string(), "--frames-every", "3", "--log-level", "warn"});
  ASSERT_EQ(camera.ReadLine(), "yamor-camapp: listening on 127.0.0.1:" + std::to_string(camera_port));

  v1::SleepRequest step;
  step.set_seconds(0.04);
  v1::RobotPositionResponse tracked;
  grpc::Status s;
  for (int k = 0; k < 10; ++k) {
    ASSERT_OK(call(&v1::Host::Stub::Sleep, step, static_cast<v1::SleepResponse*>(nullptr)));
    ASSERT_OK(call(&v1::Host::Stub::RobotPosition, Empty(), &tracked));
  }
  ASSERT_OK(call(&v1::Host::Stub::TurnUpsideDown, Empty(), static_cast<Empty*>(nullptr)));
  for (int k = 0; k < 10; ++k) {
    ASSERT_OK(call(&v1::Host::Stub::Sleep, step, static_cast<v1::SleepResponse*>(nullptr)));
    s = call(&v1::Host::Stub::RobotPosition, Empty(), &tracked);
    ASSERT_EQ(s.error_code(), grpc::StatusCode::UNAVAILABLE) << "step " << k << ": the LED faces the floor";
    EXPECT_NE(s.error_message().find("not seen"), std::string::npos) << s.error_message();
  }
  camera.Signal(SIGTERM);
  ASSERT_EQ(camera.WaitForExit(std::chrono::seconds(20)), 0);

  int seen = 0, hidden = 0;
  for (const auto& row : ReadCsv(truth)) {
    seen += row[6] == "seen";
    hidden += row[6] == "hidden";
    if (row[6] == "hidden") {
      EXPECT_LT(std::stod(row[5]), 0.5) << "on the floor, in the image";
    }
  }
  EXPECT_GE(seen, 10);
  EXPECT_GE(hidden, 10);

  // The pictures: every third frame, the camera's size, an index naming them.
  const auto index = ReadCsv((pictures / "frames.csv").string());
  ASSERT_GE(index.size(), 5u);
  int hidden_pictures = 0;
  for (const auto& row : index) {
    ASSERT_EQ(row.size(), 7u);
    hidden_pictures += row[3] == "hidden";
    std::ifstream png(pictures / row[6], std::ios::binary);
    ASSERT_TRUE(png) << row[6];
    const std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(png)), std::istreambuf_iterator<char>());
    const render::Image image = render::DecodePng(bytes);
    EXPECT_EQ(image.width, 640);
    EXPECT_EQ(image.height, 480);
  }
  EXPECT_GT(hidden_pictures, 0);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace yamor::camapp
