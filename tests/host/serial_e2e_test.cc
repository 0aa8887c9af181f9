// End to end over a real link: yamord --backend serial driving yamor-bridge
// on a pseudo-terminal and on TCP, compared bit for bit with the in-process
// backend; link faults (bridge killed mid-Sleep and restarted); and a peer
// that answers like the real robot's modules and never like a bridge.
#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <stdlib.h>
#include <sys/socket.h>
#include <termios.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "proto/snp/snp.h"
#include "tests/support/host_call.h"
#include "tests/support/yamord_process.h"
#include "yamor/v1/host.grpc.pb.h"

namespace yamor::host {
namespace {

namespace v1 = yamor::v1;
using google::protobuf::Empty;
using Clock = std::chrono::steady_clock;
using ::yamor::testing::YamordProcess;

const std::string kYamord = YAMORD_PATH;
const std::string kBridge = YAMOR_BRIDGE_PATH;
const std::string kSourceDir = YAMOR_SOURCE_DIR;

// A fresh directory for the pty symlinks of one test.
std::filesystem::path TempDir() {
  std::string pattern = (std::filesystem::temp_directory_path() / "yamor-serial-XXXXXX").string();
  if (mkdtemp(pattern.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
  return pattern;
}

// yamor-bridge as a child: its first stdout line is "yamor-bridge: pty
// /dev/pts/N" or "yamor-bridge: tcp 127.0.0.1:PORT".
struct Bridge {
  explicit Bridge(std::vector<std::string> args) {
    args.insert(args.end(), {"--log-level", "warn", "--worlds-dir", kSourceDir + "/configs/worlds"});
    process = std::make_unique<YamordProcess>(kBridge, std::move(args));
    endpoint = process->ReadLine();
  }
  // The TCP port of "yamor-bridge: tcp 127.0.0.1:PORT", 0 if none.
  int Port() const {
    const auto colon = endpoint.rfind(':');
    return endpoint.find("tcp ") == std::string::npos || colon == std::string::npos
               ? 0
               : std::stoi(endpoint.substr(colon + 1));
  }
  std::unique_ptr<YamordProcess> process;
  std::string endpoint;
};

// A yamord child with a stub.
struct Daemon {
  explicit Daemon(std::vector<std::string> extra) {
    std::vector<std::string> args = {"--listen", "127.0.0.1:0", "--log-level", "warn"};
    args.insert(args.end(), extra.begin(), extra.end());
    process = std::make_unique<YamordProcess>(kYamord, args);
    port = process->WaitForPort();
    channel = grpc::CreateChannel("127.0.0.1:" + std::to_string(port),
                                  grpc::InsecureChannelCredentials());
    stub = v1::Host::NewStub(channel);
  }
  template <typename Request, typename Response>
  grpc::Status Call(grpc::Status (v1::Host::Stub::*method)(grpc::ClientContext*, const Request&,
                                                           Response*),
                    const Request& request, Response* response = nullptr, int deadline_s = 120) {
    return ::yamor::testing::Call(*stub, method, request, response, deadline_s);
  }
  std::unique_ptr<YamordProcess> process;
  int port = 0;
  std::shared_ptr<grpc::Channel> channel;
  std::unique_ptr<v1::Host::Stub> stub;
};

// The thesis session (open, connect, control on, set parameters, sleep 20 s)
// and the lifelong-relevant calls; returns every position seen, in order.
std::vector<v1::RobotPositionResponse> ThesisSession(Daemon& d) {
  std::vector<v1::RobotPositionResponse> positions;
  auto position = [&] {
    v1::RobotPositionResponse p;
    const grpc::Status s = d.Call(&v1::Host::Stub::RobotPosition, Empty(), &p);
    EXPECT_TRUE(s.ok()) << s.error_message();
    positions.push_back(p);
  };
  v1::ConnectRobotResponse connected;
  EXPECT_TRUE(d.Call(&v1::Host::Stub::ConnectRobot, v1::ConnectRobotRequest(), &connected).ok());
  EXPECT_EQ(connected.links(), 8u);
  v1::ControlMessageRequest control;
  control.set_uart(v1::SWITCH_ON);
  control.set_cpg(v1::SWITCH_ON);
  control.set_motors(v1::SWITCH_ON);
  control.set_all(true);
  EXPECT_TRUE(d.Call(&v1::Host::Stub::SendControlMessage, control).ok());
  for (uint32_t hip = 0; hip < 4; ++hip) {
    v1::SetModuleValueRequest speed;
    speed.set_module_id(hip);
    speed.set_value(0.35);
    EXPECT_TRUE(d.Call(&v1::Host::Stub::SetModuleSpeed, speed).ok());
  }
  EXPECT_TRUE(d.Call(&v1::Host::Stub::Flush, Empty()).ok());
  position();
  v1::SleepRequest sleep;
  sleep.set_seconds(20.0);
  v1::SleepResponse slept;
  EXPECT_TRUE(d.Call(&v1::Host::Stub::Sleep, sleep, &slept).ok());
  EXPECT_NEAR(slept.time(), 20.0, 1e-9);
  position();

  // Lifelong-relevant calls: ground, defects, a transformation, readback.
  v1::SetGroundRequest ground;
  ground.set_friction(0.6);
  ground.set_slope(0.05);
  EXPECT_TRUE(d.Call(&v1::Host::Stub::SetGround, ground).ok());
  v1::SetMotorDefectRequest limp;
  limp.set_module_id(5);
  limp.set_defect(v1::MOTOR_LIMP);
  EXPECT_TRUE(d.Call(&v1::Host::Stub::SetMotorDefect, limp).ok());
  sleep.set_seconds(2.0);
  EXPECT_TRUE(d.Call(&v1::Host::Stub::Sleep, sleep).ok());
  position();
  v1::SetModuleDefectRequest broken;
  broken.set_module_id(6);
  broken.set_defective(true);
  EXPECT_TRUE(d.Call(&v1::Host::Stub::SetModuleDefect, broken).ok());
  EXPECT_TRUE(d.Call(&v1::Host::Stub::Sleep, sleep).ok());
  position();
  std::ifstream script_file(kSourceDir + "/configs/scripts/quadruped-transform.xml");
  std::stringstream script;
  script << script_file.rdbuf();
  v1::RunTransformationScriptRequest transform;
  transform.set_script_xml(script.str());
  const grpc::Status transformed = d.Call(&v1::Host::Stub::RunTransformationScript, transform);
  EXPECT_TRUE(transformed.ok()) << transformed.error_message();
  position();
  EXPECT_TRUE(d.Call(&v1::Host::Stub::TurnUpsideDown, Empty()).ok());
  EXPECT_TRUE(d.Call(&v1::Host::Stub::Sleep, sleep).ok());
  position();
  return positions;
}

std::string Morphology(Daemon& d) {
  v1::GetMorphologyResponse m;
  const grpc::Status s = d.Call(&v1::Host::Stub::GetMorphology, Empty(), &m);
  EXPECT_TRUE(s.ok()) << s.error_message();
  return m.morphology_xml();
}

void ExpectBitIdentical(const std::vector<v1::RobotPositionResponse>& serial,
                        const std::vector<v1::RobotPositionResponse>& in_process) {
  ASSERT_EQ(serial.size(), in_process.size());
  for (std::size_t i = 0; i < serial.size(); ++i) {
    EXPECT_EQ(serial[i].time(), in_process[i].time()) << "sample " << i;
    EXPECT_EQ(serial[i].position().x(), in_process[i].position().x()) << "sample " << i;
    EXPECT_EQ(serial[i].position().y(), in_process[i].position().y()) << "sample " << i;
    EXPECT_EQ(serial[i].position().z(), in_process[i].position().z()) << "sample " << i;
    EXPECT_EQ(serial[i].orientation().w(), in_process[i].orientation().w()) << "sample " << i;
    EXPECT_EQ(serial[i].source(), "simulation");
  }
  const double moved = std::hypot(serial[1].position().x() - serial[0].position().x(),
                                  serial[1].position().y() - serial[0].position().y());
  EXPECT_GT(moved, 0.05) << "the quadruped moved " << moved << " m in 20 s";
}

class SerialE2eTest : public ::testing::Test {
 protected:
  // The reference: the same session on the in-process backend, same seed.
  void SetUp() override {
    Daemon reference({"--world", "quadruped", "--seed", "7"});
    ASSERT_GT(reference.port, 0);
    expected_ = ThesisSession(reference);
    expected_morphology_ = Morphology(reference);
  }
  std::vector<v1::RobotPositionResponse> expected_;
  std::string expected_morphology_;
};

TEST_F(SerialE2eTest, ThesisSessionOverAPtyBridgeIsBitIdenticalToInProcess) {
  const std::filesystem::path dir = TempDir();
  const std::string device = (dir / "robot").string();
  Bridge bridge({"--pty", "--link", device, "--world", "quadruped", "--seed", "7"});
  ASSERT_NE(bridge.endpoint.find("yamor-bridge: pty /dev/"), std::string::npos) << bridge.endpoint;
  Daemon serial({"--backend", "serial", "--device", device});
  ASSERT_GT(serial.port, 0) << "yamord --backend serial did not start";
  v1::GetInfoResponse info;
  ASSERT_OK(serial.Call(&v1::Host::Stub::GetInfo, Empty(), &info));
  EXPECT_EQ(info.backend(), "serial");
  v1::SimulationModeEnabledResponse mode;
  ASSERT_OK(serial.Call(&v1::Host::Stub::SimulationModeEnabled, Empty(), &mode));
  EXPECT_TRUE(mode.enabled()) << "the bridge answered the hello";

  ExpectBitIdentical(ThesisSession(serial), expected_);
  EXPECT_EQ(Morphology(serial), expected_morphology_) << "the current morphology, read back";
  serial.process->Signal(SIGTERM);
  EXPECT_EQ(serial.process->WaitForExit(std::chrono::seconds(20)), 0);
  std::filesystem::remove_all(dir);
}

TEST_F(SerialE2eTest, ThesisSessionOverTcpIsBitIdenticalToInProcess) {
  Bridge bridge({"--tcp", "127.0.0.1:0", "--world", "quadruped", "--seed", "7"});
  ASSERT_GT(bridge.Port(), 0) << bridge.endpoint;
  Daemon serial({"--backend", "serial", "--device",
                 "tcp://127.0.0.1:" + std::to_string(bridge.Port())});
  ASSERT_GT(serial.port, 0);
  ExpectBitIdentical(ThesisSession(serial), expected_);
  EXPECT_EQ(Morphology(serial), expected_morphology_);
}

TEST(SerialFaultTest, BridgeKilledMidSleepGivesUnavailableAndRefreshRestoresAfterRestart) {
  const std::filesystem::path dir = TempDir();
  const std::string device = (dir / "robot").string();
  auto bridge = std::make_unique<Bridge>(
      std::vector<std::string>{"--pty", "--link", device, "--world", "quadruped"});
  Daemon d({"--backend", "serial", "--device", device, "--reply-timeout", "1"});
  ASSERT_GT(d.port, 0);
  ASSERT_OK(d.Call(&v1::Host::Stub::ConnectRobot, v1::ConnectRobotRequest()));
  v1::ControlMessageRequest control;
  control.set_cpg(v1::SWITCH_ON);
  control.set_motors(v1::SWITCH_ON);
  control.set_all(true);
  ASSERT_OK(d.Call(&v1::Host::Stub::SendControlMessage, control));

  grpc::Status sleep_status;
  Clock::time_point sleep_ended;
  std::thread sleeper([&] {
    v1::SleepRequest sleep;
    sleep.set_seconds(80000.0);  // far longer than the test
    sleep_status = d.Call(&v1::Host::Stub::Sleep, sleep, static_cast<v1::SleepResponse*>(nullptr), 60);
    sleep_ended = Clock::now();
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(500));  // let it step
  const Clock::time_point killed = Clock::now();
  bridge.reset();  // SIGKILL mid-Sleep
  sleeper.join();
  EXPECT_EQ(sleep_status.error_code(), grpc::StatusCode::UNAVAILABLE) << sleep_status.error_message();
  const double waited = std::chrono::duration<double>(sleep_ended - killed).count();
  EXPECT_LT(waited, 10.0) << "within the link timeout, not the deadline";

  // The daemon is alive, keeps the configuration, and later calls say why.
  v1::SaveConfigResponse config;
  ASSERT_OK(d.Call(&v1::Host::Stub::SaveConfig, Empty(), &config));
  EXPECT_NE(config.config_xml().find("<module"), std::string::npos);
  v1::RobotPositionResponse p;
  EXPECT_EQ(d.Call(&v1::Host::Stub::RobotPosition, Empty(), &p).error_code(),
            grpc::StatusCode::UNAVAILABLE);

  // Restarted at the same path: the next call reopens the link and Refresh
  // links and configures the robot again.
  bridge = std::make_unique<Bridge>(
      std::vector<std::string>{"--pty", "--link", device, "--world", "quadruped"});
  grpc::Status refreshed;
  for (int i = 0; i < 3 && !(refreshed = d.Call(&v1::Host::Stub::Refresh, Empty())).ok(); ++i) {
  }
  ASSERT_OK(refreshed);
  v1::GetInfoResponse info;
  ASSERT_OK(d.Call(&v1::Host::Stub::GetInfo, Empty(), &info));
  EXPECT_TRUE(info.connected());
  v1::RobotPositionResponse start, end;
  ASSERT_OK(d.Call(&v1::Host::Stub::RobotPosition, Empty(), &start));
  v1::SleepRequest sleep;
  sleep.set_seconds(10.0);
  ASSERT_OK(d.Call(&v1::Host::Stub::Sleep, sleep));
  ASSERT_OK(d.Call(&v1::Host::Stub::RobotPosition, Empty(), &end));
  EXPECT_GT(std::hypot(end.position().x() - start.position().x(),
                       end.position().y() - start.position().y()),
            0.02)
      << "after Refresh the robot walks again (switches restored)";
  std::filesystem::remove_all(dir);
}

// A pty whose far side answers like the real robot's modules (acks and
// ConnectAcks) and never like a bridge, or not at all when `silent`.
class FakeRealRobot {
 public:
  explicit FakeRealRobot(bool silent) : silent_(silent) {
    master_ = posix_openpt(O_RDWR | O_NOCTTY);
    if (master_ < 0 || grantpt(master_) != 0 || unlockpt(master_) != 0) {
      throw std::runtime_error("no pty");
    }
    termios t{};
    tcgetattr(master_, &t);
    cfmakeraw(&t);
    tcsetattr(master_, TCSANOW, &t);
    slave_path_ = ptsname(master_);
    // Keep a slave descriptor open so the host may close and reopen.
    slave_ = open(slave_path_.c_str(), O_RDWR | O_NOCTTY);
    thread_ = std::thread([this] { Serve(); });
  }
  ~FakeRealRobot() {
    stop_ = true;
    thread_.join();
    close(slave_);
    close(master_);
  }
  const std::string& path() const { return slave_path_; }
  std::atomic<int> bridge_frames{0};

 private:
  void Serve() {
    snp::FrameDecoder decoder;
    std::vector<snp::DecodeEvent> events;
    while (!stop_) {
      pollfd p{master_, POLLIN, 0};
      if (poll(&p, 1, 50) <= 0) continue;
      uint8_t buffer[512];
      const ssize_t n = read(master_, buffer, sizeof buffer);
      if (n <= 0) continue;
      events.clear();
      decoder.Feed(std::span<const uint8_t>(buffer, static_cast<std::size_t>(n)), events);
      for (const snp::DecodeEvent& e : events) {
        const auto* decoded = std::get_if<snp::DecodedFrame>(&e);
        if (decoded == nullptr) continue;
        const snp::Frame& f = decoded->frame;
        if (f.destination.kind == snp::NodeKind::kBridge) {
          ++bridge_frames;  // a real robot has no bridge: silence
          continue;
        }
        if (silent_ || f.destination.IsBroadcast()) continue;
        const snp::Message m = snp::DecodeMessage(f);
        snp::Message reply = snp::Ack{.acked = f.type, .status = StatusCode::kOk};
        if (const auto* link = std::get_if<snp::ConnectRequest>(&m)) {
          reply = snp::ConnectAck{.child = link->child, .status = snp::LinkStatus::kUp};
        } else if (std::holds_alternative<snp::ReadServoAngle>(m)) {
          reply = snp::ServoAngle{.angle = 0.5f};
        }
        std::vector<uint8_t> out;
        snp::AppendEncodedFrame(snp::MakeFrame(f.destination, snp::Address::Host(), reply), out);
        if (write(master_, out.data(), out.size()) < 0) continue;
      }
    }
  }

  bool silent_;
  int master_ = -1;
  int slave_ = -1;
  std::string slave_path_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

TEST(SerialRealRobotTest, SpecialsAreUnimplementedAndTheRestWorks) {
  FakeRealRobot robot(/*silent=*/false);
  Daemon d({"--backend", "serial", "--device", robot.path()});
  ASSERT_GT(d.port, 0);
  v1::SimulationModeEnabledResponse mode;
  ASSERT_OK(d.Call(&v1::Host::Stub::SimulationModeEnabled, Empty(), &mode));
  EXPECT_FALSE(mode.enabled()) << "nobody answered the bridge hello";
  v1::ConnectRobotResponse connected;
  ASSERT_OK(d.Call(&v1::Host::Stub::ConnectRobot, v1::ConnectRobotRequest(), &connected));
  EXPECT_EQ(connected.links(), 8u);
  v1::ControlMessageRequest control;
  control.set_cpg(v1::SWITCH_ON);
  control.set_all(true);
  ASSERT_OK(d.Call(&v1::Host::Stub::SendControlMessage, control));
  v1::SetModuleValueRequest amplitude;
  amplitude.set_module_id(1);
  amplitude.set_value(0.4);
  ASSERT_OK(d.Call(&v1::Host::Stub::SetModuleAmplitude, amplitude));
  ASSERT_OK(d.Call(&v1::Host::Stub::Flush, Empty()));
  v1::GetServoAnglesResponse angles;
  ASSERT_OK(d.Call(&v1::Host::Stub::GetServoAngles, v1::GetServoAnglesRequest(), &angles));
  EXPECT_EQ(angles.angles_size(), 9);

  const int bridge_frames_before = robot.bridge_frames.load();
  const auto start = Clock::now();
  v1::SetGroundRequest ground;
  ground.set_friction(0.5);
  grpc::Status s = d.Call(&v1::Host::Stub::SetGround, ground);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::UNIMPLEMENTED);
  EXPECT_NE(s.error_message().find("manual assembly"), std::string::npos) << s.error_message();
  v1::SetModuleDefectRequest defect;
  defect.set_module_id(1);
  defect.set_defective(true);
  EXPECT_EQ(d.Call(&v1::Host::Stub::SetModuleDefect, defect).error_code(),
            grpc::StatusCode::UNIMPLEMENTED);
  EXPECT_EQ(d.Call(&v1::Host::Stub::GetMorphology, Empty()).error_code(),
            grpc::StatusCode::UNIMPLEMENTED);
  v1::ModuleRequest disconnect;
  disconnect.set_module_id(5);
  EXPECT_EQ(d.Call(&v1::Host::Stub::DisconnectModule, disconnect).error_code(),
            grpc::StatusCode::UNIMPLEMENTED);
  EXPECT_LT(std::chrono::duration<double>(Clock::now() - start).count(), 2.0)
      << "refused at once, never a hang";
  EXPECT_EQ(robot.bridge_frames.load(), bridge_frames_before)
      << "simulation-only calls are not even sent to a real robot";
}

TEST(SerialRealRobotTest, ALinkThatNeverAnswersTimesOutNamingTheFrameAndModule) {
  FakeRealRobot robot(/*silent=*/true);
  Daemon d({"--backend", "serial", "--device", robot.path(), "--link-timeout", "0.3"});
  ASSERT_GT(d.port, 0);
  const auto start = Clock::now();
  grpc::Status s = d.Call(&v1::Host::Stub::ConnectRobot, v1::ConnectRobotRequest());
  EXPECT_EQ(s.error_code(), grpc::StatusCode::UNAVAILABLE);
  EXPECT_NE(s.error_message().find("link 4 -> 0 timed out after 0.3 s"), std::string::npos)
      << s.error_message();
  EXPECT_LT(std::chrono::duration<double>(Clock::now() - start).count(), 5.0);
  v1::GetInfoResponse info;
  ASSERT_OK(d.Call(&v1::Host::Stub::GetInfo, Empty(), &info));  // the daemon lives on
}

// A CamApp stand-in on an ephemeral loopback port (docs/camapp.md): the
// hello, then the LED at pixel (420, 340) every 20 ms until stopped.
class FakeCamApp {
 public:
  FakeCamApp() {
    listener_ = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t length = sizeof address;
    if (bind(listener_, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0 ||
        listen(listener_, 4) != 0 ||
        getsockname(listener_, reinterpret_cast<sockaddr*>(&address), &length) != 0) {
      throw std::runtime_error("no listener");
    }
    port_ = ntohs(address.sin_port);
    thread_ = std::thread([this] { Serve(); });
  }
  ~FakeCamApp() { Stop(); }
  int port() const { return port_; }
  // Stops sending (and closes the connection): the tracker goes stale.
  void Stop() {
    if (stop_.exchange(true)) return;
    shutdown(listener_, SHUT_RDWR);
    thread_.join();
    close(listener_);
  }

 private:
  void Serve() {
    pollfd p{listener_, POLLIN, 0};
    while (!stop_ && poll(&p, 1, 50) <= 0) {
    }
    if (stop_) return;
    const int client = accept(listener_, nullptr, nullptr);
    if (client < 0) return;
    std::string text = "YAMOR-CAMAPP 1 640 480\n";
    for (uint32_t seq = 1; !stop_; ++seq) {
      text += std::to_string(seq) + " " + std::to_string(seq * 20000) + " 420 340\n";
      if (send(client, text.data(), text.size(), MSG_NOSIGNAL) < 0) break;
      text.clear();
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    close(client);
  }

  int listener_ = -1;
  int port_ = 0;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

TEST(SerialRealRobotTest, PositionComesFromTheLedTrackerAndAStaleTrackerIsUnavailable) {
  // A camera without distortion: 5 mm per pixel about the image centre.
  const std::filesystem::path dir = TempDir();
  const std::string calibration = (dir / "camera.txt").string();
  std::ofstream(calibration) << "image 640 480\nfocal 500 500\nprincipal 320 240\n"
                                "led_height 0.06\n"
                                "point 120 40 -1 -1\npoint 520 40 1 -1\n"
                                "point 520 440 1 1\npoint 120 440 -1 1\npoint 320 240 0 0\n";
  FakeCamApp camera;
  FakeRealRobot robot(/*silent=*/false);
  Daemon d({"--backend", "serial", "--device", robot.path(), "--led-tracker",
            "127.0.0.1:" + std::to_string(camera.port()), "--tracker-calibration", calibration,
            "--tracker-max-age", "0.3"});
  ASSERT_GT(d.port, 0);
  v1::RobotPositionResponse p;
  grpc::Status s;
  for (int i = 0; i < 100; ++i) {  // until the tracker has its first sample
    s = d.Call(&v1::Host::Stub::RobotPosition, Empty(), &p);
    if (s.ok()) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ASSERT_OK(s);
  EXPECT_EQ(p.source(), "led-tracker");
  EXPECT_NEAR(p.position().x(), 0.5, 1e-6);
  EXPECT_NEAR(p.position().y(), 0.5, 1e-6);
  EXPECT_DOUBLE_EQ(p.position().z(), 0.06);

  camera.Stop();
  std::this_thread::sleep_for(std::chrono::milliseconds(600));
  s = d.Call(&v1::Host::Stub::RobotPosition, Empty(), &p);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::UNAVAILABLE) << "never a stale value passed off";
  EXPECT_NE(s.error_message().find("led-tracker 127.0.0.1"), std::string::npos)
      << s.error_message();
  std::filesystem::remove_all(dir);
}

TEST(SerialRealRobotTest, ATrackerWithoutCalibrationIsAClearStartError) {
  YamordProcess d(kYamord, {"--listen", "127.0.0.1:0", "--led-tracker", "127.0.0.1:2225"});
  EXPECT_EQ(d.WaitForExit(std::chrono::seconds(20)), 2);
}

}  // namespace
}  // namespace yamor::host
