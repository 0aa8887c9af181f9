// The serial backend against a real yamor-bridge: a BridgeServer (the
// emulated quadruped) behind a BridgeTransport on a pty it creates, or on
// loopback TCP, served on a thread; the host side is SerialBackend + SnpLink,
// exactly what yamord --backend serial uses.
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <memory>
#include <string>
#include <thread>
#include <utility>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "bridge/bridge_server.h"
#include "bridge/bridge_transport.h"
#include "common/status.h"
#include "host/serial_backend.h"
#include "host/snp_link.h"
#include "physics/morphology.h"

namespace yamor::host {
namespace {

using bridge::TransportOptions;
using ::testing::HasSubstr;

physics::Morphology Quadruped() {
  return physics::Morphology::LoadFile(std::string(YAMOR_SOURCE_DIR) +
                                       "/configs/worlds/quadruped.xml");
}

// yamor-bridge in-process: the transport's Run on its own thread.
class BridgeOnThread {
 public:
  explicit BridgeOnThread(TransportOptions::Kind kind)
      : BridgeOnThread(TransportOptions{.kind = kind, .tcp_port = 0}) {}
  explicit BridgeOnThread(TransportOptions options)
      : server_(Quadruped()),
        transport_(server_, std::move(options)),
        thread_([this] { transport_.Run(/*stop_on_signals=*/false); }) {}
  ~BridgeOnThread() {
    transport_.Stop();
    thread_.join();
  }

  // The TCP port (0 for a pty).
  uint16_t Port() const { return transport_.Port(); }
  // The device for SerialBackend: the pty slave or tcp://127.0.0.1:PORT.
  std::string Device() const {
    return transport_.Port() != 0 ? "tcp://127.0.0.1:" + std::to_string(transport_.Port())
                                  : transport_.SlavePath();
  }
  // The emulated robot's server.
  bridge::BridgeServer& server() { return server_; }

 private:
  bridge::BridgeServer server_;
  bridge::BridgeTransport transport_;
  std::thread thread_;
};

class SerialBridgeTest : public ::testing::TestWithParam<TransportOptions::Kind> {};

TEST_P(SerialBridgeTest, SnpLinkDrivesTheBridgeThroughTheSerialBackend) {
  BridgeOnThread bridge(GetParam());
  SerialOptions options;
  options.device = bridge.Device();
  options.hello_timeout = 2.0;  // a loaded machine; a bridge answers in microseconds
  SerialBackend backend(options);
  ASSERT_TRUE(backend.IsSimulation()) << "the hello was not answered";
  ASSERT_TRUE(backend.sim_info().has_value());
  EXPECT_DOUBLE_EQ(backend.sim_info()->time_step, bridge.server().TimeStep());

  SnpLink link(backend, IdMap(), SnpLinkOptions{.reply_timeout = 5.0});
  EXPECT_EQ(std::get<snp::SimTime>(link.BridgeRequest(snp::GetSimTime{},
                                                      snp::MessageType::kSimTime))
                .seconds,
            0.0);
  const double step = 20 * bridge.server().TimeStep();
  const auto done = std::get<snp::StepDone>(
      link.BridgeRequest(snp::Step{.duration = step}, snp::MessageType::kStepDone));
  EXPECT_NEAR(done.time, step, 1e-9);
  const auto pose = std::get<snp::RobotPosition>(
      link.BridgeRequest(snp::GetRobotPosition{}, snp::MessageType::kRobotPosition));
  EXPECT_NEAR(pose.time, step, 1e-9);
  EXPECT_TRUE(std::isfinite(pose.position[0]) && std::isfinite(pose.position[1]));
  EXPECT_GT(pose.position[2], 0.0);

  const int master = Quadruped().central();
  EXPECT_TRUE(std::holds_alternative<snp::ServoAngle>(
      link.ModuleCall(master, snp::ReadServoAngle{}, snp::MessageType::kServoAngle)));
  try {
    link.ModuleCall(master, snp::SetLimits{.min_angle = 1.0f, .max_angle = 0.0f},
                    snp::MessageType::kAck);
    ADD_FAILURE() << "SetLimits min > max was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kOutOfRange);
  }
  EXPECT_THAT(link.ReadMorphologyXml(), HasSubstr("<module"));

  const SerialStats stats = backend.stats();
  EXPECT_EQ(stats.skipped_bytes, 0u);
  EXPECT_EQ(stats.decode_errors, 0u);
  EXPECT_EQ(stats.frames_in, stats.frames_out);  // one reply per frame, the hello included
  EXPECT_EQ(bridge.server().stats().decoder.skipped_bytes, 0u);
}

TEST_P(SerialBridgeTest, AKilledBridgeIsUnavailableNamingTheDevice) {
  auto bridge = std::make_unique<BridgeOnThread>(GetParam());
  SerialOptions options;
  options.device = bridge->Device();
  options.hello_timeout = 2.0;
  SerialBackend backend(options);
  ASSERT_TRUE(backend.IsSimulation());
  SnpLink link(backend, IdMap(), SnpLinkOptions{.reply_timeout = 5.0});
  link.BridgeRequest(snp::GetSimTime{}, snp::MessageType::kSimTime);
  bridge.reset();  // the pty master or the listening socket and connection close

  const auto start = std::chrono::steady_clock::now();
  try {
    link.BridgeRequest(snp::GetSimTime{}, snp::MessageType::kSimTime);
    ADD_FAILURE() << "a request to a killed bridge succeeded";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kUnavailable);
    EXPECT_THAT(e.what(), HasSubstr(options.device));
  }
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 4.0)
      << "the loss was not noticed before the reply timeout";
  EXPECT_FALSE(backend.IsOpen());
}

TEST_P(SerialBridgeTest, ARestartedBridgeIsReopenedAndTheLinkSaysSo) {
  // The same device before and after: a pty symlink, or the same TCP port.
  const std::string link = ::testing::TempDir() + "/yamor_serial_bridge_" +
                           std::to_string(::getpid());
  TransportOptions transport{.kind = GetParam(), .tcp_port = 0};
  if (GetParam() == TransportOptions::Kind::kPty) transport.link = link;
  auto bridge = std::make_unique<BridgeOnThread>(transport);
  transport.tcp_port = bridge->Port();
  SerialOptions options;
  options.device = GetParam() == TransportOptions::Kind::kPty ? link : bridge->Device();
  options.hello_timeout = 2.0;
  SerialBackend backend(options);
  SnpLink snp_link(backend, IdMap(), SnpLinkOptions{.reply_timeout = 5.0});
  int reopened = 0;
  snp_link.SetReopenedHandler([&] { ++reopened; });
  snp_link.BridgeRequest(snp::Step{.duration = 0.01}, snp::MessageType::kStepDone);

  bridge.reset();
  try {
    snp_link.BridgeRequest(snp::GetSimTime{}, snp::MessageType::kSimTime);
    ADD_FAILURE() << "a killed bridge answered";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kUnavailable) << e.what();
  }
  bridge = std::make_unique<BridgeOnThread>(transport);  // a fresh world at t = 0
  try {
    snp_link.BridgeRequest(snp::GetSimTime{}, snp::MessageType::kSimTime);
    ADD_FAILURE() << "the call on the reopened link did not say so";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kUnavailable);
    EXPECT_THAT(e.what(), HasSubstr("reopened"));
  }
  EXPECT_EQ(reopened, 1);
  EXPECT_EQ(backend.Generation(), 2u);
  EXPECT_TRUE(backend.IsSimulation());
  // The next call goes through, to the new world.
  EXPECT_EQ(std::get<snp::SimTime>(
                snp_link.BridgeRequest(snp::GetSimTime{}, snp::MessageType::kSimTime))
                .seconds,
            0.0);
}

INSTANTIATE_TEST_SUITE_P(Transports, SerialBridgeTest,
                         ::testing::Values(TransportOptions::Kind::kPty,
                                           TransportOptions::Kind::kTcp),
                         [](const ::testing::TestParamInfo<TransportOptions::Kind>& info) {
                           return info.param == TransportOptions::Kind::kPty ? "Pty" : "Tcp";
                         });

}  // namespace
}  // namespace yamor::host
