#include "bridge/robot.h"
#include "host/config_frames.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <set>
#include <string>

#include "common/status.h"
#include "cpg/config_xml.h"
#include "bridge/scene.h"
#include "physics/render/snapshot.h"
#include "proto/snp/snp.h"

namespace yamor::bridge {
namespace {

// The host builds configuration frames (host/config_frames.h).
using host::ConfigurationFrames;
using host::IsInactive;

using snp::Address;

const std::string kSourceDir = YAMOR_SOURCE_DIR;

physics::Morphology SnakeMorphology() {
  return physics::Morphology::LoadFile(kSourceDir + "/configs/worlds/snake.xml");
}

cpg::RobotConfig SnakeConfig() {
  return cpg::LoadConfigFile(kSourceDir + "/configs/robots/snake.xml");
}

snp::Frame ToModule(int id, const snp::Message& m) {
  return snp::MakeFrame(Address::Host(), Address::Module(static_cast<uint8_t>(id)), m);
}
snp::Frame ToBridge(const snp::Message& m) {
  return snp::MakeFrame(Address::Host(), Address::Bridge(), m);
}
snp::Frame Broadcast(const snp::Message& m) {
  return snp::MakeFrame(Address::Host(), Address::Broadcast(), m);
}

// Sends one frame and returns the replies.
std::vector<snp::Frame> Send(Robot& robot, const snp::Frame& frame) {
  std::vector<snp::Frame> out;
  robot.HandleFrame(frame, out);
  return out;
}

// Sends one frame that must be answered by exactly one message of type T.
template <typename T>
T SendExpect(Robot& robot, const snp::Frame& frame) {
  auto out = Send(robot, frame);
  EXPECT_EQ(out.size(), 1u) << snp::MessageTypeName(frame.type);
  if (out.empty()) return T{};
  snp::Message message = snp::DecodeMessage(out.back());
  EXPECT_TRUE(std::holds_alternative<T>(message))
      << "got " << snp::MessageTypeName(out.back().type);
  if (!std::holds_alternative<T>(message)) return T{};
  return std::get<T>(message);
}

// Links the whole snake chain 0 -> 1 -> ... -> 8.
void LinkSnake(Robot& robot) {
  for (int parent = 0; parent < 8; ++parent) {
    auto ack = SendExpect<snp::ConnectAck>(
        robot, ToModule(parent, snp::ConnectRequest{.child = static_cast<uint8_t>(parent + 1)}));
    ASSERT_EQ(ack.status, snp::LinkStatus::kUp) << "link " << parent << "->" << parent + 1;
  }
}

void Configure(Robot& robot, const cpg::RobotConfig& config) {
  for (const snp::Frame& frame : ConfigurationFrames(config)) {
    for (const snp::Frame& reply : Send(robot, frame)) {
      snp::Message m = snp::DecodeMessage(reply);
      if (const auto* ack = std::get_if<snp::Ack>(&m)) {
        ASSERT_EQ(ack->status, StatusCode::kOk) << snp::MessageTypeName(ack->acked);
      }
      if (const auto* ack = std::get_if<snp::ConnectAck>(&m)) {
        ASSERT_EQ(ack->status, snp::LinkStatus::kUp) << "child " << int(ack->child);
      }
    }
  }
}

TEST(BridgeRobotTest, OnlyTheMasterIsReachableAtPowerOn) {
  Robot robot(SnakeMorphology());
  EXPECT_EQ(robot.master(), 0);  // the central module by default
  EXPECT_TRUE(robot.Reachable(0));
  for (int id = 1; id <= 8; ++id) EXPECT_FALSE(robot.Reachable(id)) << id;
  // A frame for an unlinked module is dropped: the host would time out.
  EXPECT_TRUE(Send(robot, ToModule(3, snp::Control{.cpg = snp::Tristate::kOn})).empty());
  EXPECT_EQ(robot.stats().dropped_unreachable, 1u);
  EXPECT_FALSE(robot.Firmware(3).cpg);
}

TEST(BridgeRobotTest, BluetoothLinksFollowTheTree) {
  Robot robot(SnakeMorphology());
  // Module 1 is not reachable yet, so it cannot open a link for us.
  EXPECT_TRUE(Send(robot, ToModule(1, snp::ConnectRequest{.child = 2})).empty());
  auto ack = SendExpect<snp::ConnectAck>(robot, ToModule(0, snp::ConnectRequest{.child = 1}));
  EXPECT_EQ(ack.child, 1);
  EXPECT_EQ(ack.status, snp::LinkStatus::kUp);
  EXPECT_TRUE(robot.Reachable(1));
  EXPECT_FALSE(robot.Reachable(2));
  // Idempotent for the same parent; refused for another parent, for the
  // master itself and for a module that does not exist.
  EXPECT_EQ(SendExpect<snp::ConnectAck>(robot, ToModule(0, snp::ConnectRequest{.child = 1})).status,
            snp::LinkStatus::kUp);
  EXPECT_EQ(SendExpect<snp::ConnectAck>(robot, ToModule(1, snp::ConnectRequest{.child = 0})).status,
            snp::LinkStatus::kFailed);
  EXPECT_EQ(SendExpect<snp::ConnectAck>(robot, ToModule(1, snp::ConnectRequest{.child = 42})).status,
            snp::LinkStatus::kFailed);
  LinkSnake(robot);
  EXPECT_EQ(SendExpect<snp::ConnectAck>(robot, ToModule(0, snp::ConnectRequest{.child = 5})).status,
            snp::LinkStatus::kFailed);
  for (int id = 0; id <= 8; ++id) EXPECT_TRUE(robot.Reachable(id)) << id;
  EXPECT_EQ(robot.Firmware(3).links, std::vector<int>{4});
}

TEST(BridgeRobotTest, ControlFlagsAreTristate) {
  Robot robot(SnakeMorphology());
  auto ack = SendExpect<snp::Ack>(
      robot, ToModule(0, snp::Control{.uart = snp::Tristate::kOn, .cpg = snp::Tristate::kOn,
                                      .motors = snp::Tristate::kOn}));
  EXPECT_EQ(ack.acked, snp::MessageType::kControl);
  EXPECT_EQ(ack.status, StatusCode::kOk);
  EXPECT_TRUE(robot.Firmware(0).uart && robot.Firmware(0).cpg && robot.Firmware(0).motors);
  EXPECT_TRUE(robot.world().MotorEnabled(0));
  SendExpect<snp::Ack>(robot, ToModule(0, snp::Control{.cpg = snp::Tristate::kOff}));
  EXPECT_TRUE(robot.Firmware(0).uart);
  EXPECT_FALSE(robot.Firmware(0).cpg);
  EXPECT_TRUE(robot.Firmware(0).motors);
  SendExpect<snp::Ack>(robot, ToModule(0, snp::Control{.motors = snp::Tristate::kOff}));
  EXPECT_FALSE(robot.world().MotorEnabled(0));
  EXPECT_TRUE(robot.Firmware(0).uart);
}

TEST(BridgeRobotTest, ParametersOutsideTheFirmwareRangeAreRefused) {
  Robot robot(SnakeMorphology());
  auto ack = SendExpect<snp::Ack>(robot, ToModule(0, snp::SetOscillator{.amplitude = -0.5f}));
  EXPECT_EQ(ack.status, StatusCode::kOutOfRange);
  ack = SendExpect<snp::Ack>(robot, ToModule(0, snp::SetOscillator{.speed = 100.0f}));
  EXPECT_EQ(ack.status, StatusCode::kOutOfRange);
  EXPECT_EQ(robot.Firmware(0).amplitude, 0.0f);
  EXPECT_EQ(robot.Firmware(0).speed, 0.0f);
  ack = SendExpect<snp::Ack>(robot, ToModule(0, snp::SetLimits{.min_angle = 0.5f, .max_angle = 0.5f}));
  EXPECT_EQ(ack.acked, snp::MessageType::kSetLimits);
  EXPECT_EQ(ack.status, StatusCode::kOutOfRange);
  ack = SendExpect<snp::Ack>(robot, ToModule(0, snp::SetCoupling{.to = 0, .phase = 1, .weight = 1}));
  EXPECT_EQ(ack.status, StatusCode::kInvalidArgument);

  ack = SendExpect<snp::Ack>(robot, ToModule(0, snp::SetOscillator{.amplitude = 0.4f, .speed = 0.5f}));
  EXPECT_EQ(ack.status, StatusCode::kOk);
  EXPECT_EQ(robot.Firmware(0).amplitude, 0.4f);
  EXPECT_EQ(robot.Firmware(0).offset, 0.0f);  // absent field left alone
  EXPECT_EQ(robot.Firmware(0).speed, 0.5f);
  SendExpect<snp::Ack>(robot, ToModule(0, snp::SetCoupling{.to = 1, .phase = 1.5f, .weight = 1}));
  SendExpect<snp::Ack>(robot, ToModule(0, snp::SetCoupling{.to = 1, .phase = -1.5f, .weight = 2}));
  ASSERT_EQ(robot.Firmware(0).couplings.size(), 1u);
  EXPECT_EQ(robot.Firmware(0).couplings.at(1), (FirmwareCoupling{-1.5f, 2.0f}));
  SendExpect<snp::Ack>(robot, ToModule(0, snp::ClearCouplings{}));
  EXPECT_TRUE(robot.Firmware(0).couplings.empty());
}

TEST(BridgeRobotTest, BroadcastReachesLinkedModulesAndIsNotAnswered) {
  Robot robot(SnakeMorphology());
  SendExpect<snp::ConnectAck>(robot, ToModule(0, snp::ConnectRequest{.child = 1}));
  EXPECT_TRUE(Send(robot, Broadcast(snp::Control{.cpg = snp::Tristate::kOn})).empty());
  EXPECT_TRUE(robot.Firmware(0).cpg);
  EXPECT_TRUE(robot.Firmware(1).cpg);
  EXPECT_FALSE(robot.Firmware(2).cpg);  // not linked: never heard it
}

TEST(BridgeRobotTest, BridgeCommands) {
  Robot robot(SnakeMorphology());
  EXPECT_EQ(SendExpect<snp::SimTime>(robot, ToBridge(snp::GetSimTime{})).seconds, 0.0);

  SendExpect<snp::SpecialAck>(robot, ToBridge(snp::SetTimer{.timer_id = 7, .delay = 0.05}));
  auto out = Send(robot, ToBridge(snp::Step{.duration = 0.1}));
  ASSERT_EQ(out.size(), 2u);  // TimerFired during the step, then StepDone
  auto fired = std::get<snp::TimerFired>(snp::DecodeMessage(out[0]));
  EXPECT_EQ(fired.timer_id, 7);
  EXPECT_NEAR(fired.time, 0.05, 1e-9);
  auto done = std::get<snp::StepDone>(snp::DecodeMessage(out[1]));
  EXPECT_NEAR(done.time, 0.1, 1e-9);
  EXPECT_NEAR(robot.Time(), 0.1, 1e-9);

  auto error = SendExpect<snp::SpecialError>(robot, ToBridge(snp::Step{.duration = -1.0}));
  EXPECT_EQ(error.acked, snp::MessageType::kStep);
  EXPECT_EQ(error.code, StatusCode::kOutOfRange);
  EXPECT_NE(error.text.find("-1"), std::string::npos) << error.text;

  auto pose = SendExpect<snp::RobotPosition>(robot, ToBridge(snp::GetRobotPosition{}));
  const Eigen::Vector3d p = robot.world().CentralPosition();
  EXPECT_EQ(pose.position[0], p.x());
  EXPECT_EQ(pose.position[2], p.z());
  EXPECT_GT(pose.position[2], 0.0);

  error = SendExpect<snp::SpecialError>(robot, ToBridge(snp::SetMasterNode{.module = 99}));
  EXPECT_EQ(error.code, StatusCode::kNotFound);
  SendExpect<snp::ConnectAck>(robot, ToModule(0, snp::ConnectRequest{.child = 1}));
  SendExpect<snp::SpecialAck>(robot, ToBridge(snp::SetMasterNode{.module = 4}));
  EXPECT_EQ(robot.master(), 4);
  EXPECT_FALSE(robot.Reachable(1));  // the old network is gone
  EXPECT_TRUE(robot.Reachable(4));

  SendExpect<snp::SpecialAck>(robot, ToBridge(snp::ResetSimulation{}));
  EXPECT_EQ(robot.Time(), 0.0);
}

TEST(BridgeRobotTest, PhysicalLinksThroughSpecialCommands) {
  Robot robot(SnakeMorphology());
  Configure(robot, SnakeConfig());  // UARTs on: sensors are sampled
  SendExpect<snp::SpecialAck>(robot, ToBridge(snp::DisconnectModule{.module = 8}));
  EXPECT_FALSE(robot.world().IsConnected(8));
  // The robot runs on without the module; its sensor is gone.
  std::vector<snp::Frame> events;
  robot.Advance(0.5, events);
  auto refused = SendExpect<snp::Ack>(robot, ToModule(8, snp::ReadAccelerometer{.sample_count = 1}));
  EXPECT_EQ(refused.status, StatusCode::kFailedPrecondition);
  // The central module cannot be taken off.
  auto error = SendExpect<snp::SpecialError>(robot, ToBridge(snp::DisconnectModule{.module = 0}));
  EXPECT_EQ(error.code, StatusCode::kFailedPrecondition);
  // Put it back where it was: tail handle into module 7's rear.
  SendExpect<snp::SpecialAck>(
      robot, ToBridge(snp::ConnectModules{.from = 8, .from_connector = snp::Connector::kFront,
                                          .to = 7, .to_connector = snp::Connector::kRear,
                                          .angle_index = 0}));
  EXPECT_TRUE(robot.world().IsConnected(8));
  // A connector in use is refused with the reason.
  SendExpect<snp::SpecialAck>(robot, ToBridge(snp::DisconnectModule{.module = 8}));
  error = SendExpect<snp::SpecialError>(
      robot, ToBridge(snp::ConnectModules{.from = 8, .from_connector = snp::Connector::kFront,
                                          .to = 6, .to_connector = snp::Connector::kRear,
                                          .angle_index = 0}));
  EXPECT_EQ(error.acked, snp::MessageType::kConnectModules);
  EXPECT_EQ(error.code, StatusCode::kFailedPrecondition);
  EXPECT_FALSE(error.text.empty());
  error = SendExpect<snp::SpecialError>(robot, ToBridge(snp::DisconnectModule{.module = 77}));
  EXPECT_EQ(error.code, StatusCode::kNotFound);
}

TEST(BridgeRobotTest, BytesInBytesOut) {
  Robot robot(SnakeMorphology());
  std::vector<uint8_t> in = {0x00, 0xA5, 0x13, 0x37};  // garbage, incl. a start byte
  snp::AppendEncodedFrame(ToBridge(snp::GetSimTime{}), in);
  snp::AppendEncodedFrame(ToModule(0, snp::ReadServoAngle{}), in);
  std::vector<uint8_t> out;
  // Split the stream mid-frame: the robot must reassemble it.
  const std::size_t half = in.size() / 2 + 3;
  robot.HandleBytes(std::span(in).first(half), out);
  robot.HandleBytes(std::span(in).subspan(half), out);
  snp::FrameDecoder decoder;
  auto events = decoder.Feed(out);
  ASSERT_EQ(events.size(), 2u);
  auto first = snp::DecodeMessage(std::get<snp::DecodedFrame>(events[0]).frame);
  auto second = std::get<snp::DecodedFrame>(events[1]).frame;
  EXPECT_TRUE(std::holds_alternative<snp::SimTime>(first));
  EXPECT_EQ(second.source, Address::Module(0));
  EXPECT_TRUE(std::holds_alternative<snp::ServoAngle>(snp::DecodeMessage(second)));
  EXPECT_GE(robot.stats().decode_errors, 1u);
}

TEST(BridgeRobotTest, ConfiguredSnakeOscillatesWithinItsLimits) {
  Robot robot(SnakeMorphology());
  cpg::RobotConfig config = SnakeConfig();
  Configure(robot, config);
  for (const auto& m : config.modules) {
    const ModuleFirmware& fw = robot.Firmware(m.id);
    EXPECT_EQ(fw.amplitude, static_cast<float>(m.amplitude));
    EXPECT_TRUE(fw.cpg && fw.uart);
    // The passive head (module 0) is inactive: configured, motor off.
    EXPECT_EQ(fw.motors, m.id != 0) << m.id;
  }
  std::vector<snp::Frame> events;
  double min_angle = 0, max_angle = 0;
  for (int i = 0; i < 3000; ++i) {
    robot.StepOnce(events);
    const double a = robot.world().ServoTarget(4);
    min_angle = std::min(min_angle, a);
    max_angle = std::max(max_angle, a);
  }
  // Amplitude 0.6 after the critically damped ramp; targets respect limits.
  EXPECT_GT(max_angle, 0.4);
  EXPECT_LT(min_angle, -0.4);
  EXPECT_LE(max_angle, robot.Firmware(4).max_angle + 1e-6);
  EXPECT_GE(min_angle, robot.Firmware(4).min_angle - 1e-6);
  // The servo follows its target.
  const double angle = SendExpect<snp::ServoAngle>(robot, ToModule(4, snp::ReadServoAngle{})).angle;
  EXPECT_NEAR(angle, robot.world().ServoAngle(4), 1e-6);
}

TEST(BridgeRobotTest, ModuleWithCpgOffHoldsItsTarget) {
  Robot robot(SnakeMorphology());
  Configure(robot, SnakeConfig());
  std::vector<snp::Frame> events;
  robot.Advance(1.0, events);
  SendExpect<snp::Ack>(robot, ToModule(3, snp::Control{.cpg = snp::Tristate::kOff}));
  const double held = robot.world().ServoTarget(3);
  const double other = robot.world().ServoTarget(5);
  robot.Advance(1.0, events);
  EXPECT_EQ(robot.world().ServoTarget(3), held);
  EXPECT_NE(robot.world().ServoTarget(5), other);
}

TEST(BridgeRobotTest, DefectModuleStopsOscillating) {
  Robot robot(SnakeMorphology());
  Configure(robot, SnakeConfig());
  std::vector<snp::Frame> events;
  robot.Advance(1.0, events);
  robot.SetModuleDefect(6, true);
  EXPECT_TRUE(robot.Firmware(6).oscillator_dead);
  const double held = robot.world().ServoTarget(6);
  robot.Advance(0.5, events);
  EXPECT_EQ(robot.world().ServoTarget(6), held);
  EXPECT_TRUE(robot.world().ModuleDefective(6));
  robot.Reset();  // defects are hardware: they survive a power cycle
  EXPECT_TRUE(robot.Firmware(6).oscillator_dead);
}

TEST(BridgeRobotTest, AccelerometerNeedsTheUart) {
  Robot robot(SnakeMorphology());
  auto ack = SendExpect<snp::Ack>(robot, ToModule(0, snp::ReadAccelerometer{.sample_count = 4}));
  EXPECT_EQ(ack.status, StatusCode::kFailedPrecondition);
  SendExpect<snp::Ack>(robot, ToModule(0, snp::Control{.uart = snp::Tristate::kOn}));
  std::vector<snp::Frame> events;
  robot.Advance(0.2, events);  // 20 samples at 100 Hz
  auto reply = SendExpect<snp::Accelerometer>(robot, ToModule(0, snp::ReadAccelerometer{.sample_count = 4}));
  ASSERT_EQ(reply.samples.size(), 4u);
  for (const auto& s : reply.samples) {
    EXPECT_GE(s.z, 0);
    EXPECT_LE(s.z, 1023);
  }
}

TEST(BridgeRobotTest, SameSeedSameTrajectory) {
  auto run = [] {
    Robot robot(SnakeMorphology());
    Configure(robot, SnakeConfig());
    std::vector<snp::Frame> events;
    robot.Advance(3.0, events);
    return robot.world().CentralPosition();
  };
  const Eigen::Vector3d a = run();
  const Eigen::Vector3d b = run();
  EXPECT_EQ(a.x(), b.x());
  EXPECT_EQ(a.y(), b.y());
  EXPECT_EQ(a.z(), b.z());
}

TEST(BridgeRobotTest, InactiveModulesAreConfiguredWithTheirMotorsOff) {
  const cpg::RobotConfig config = cpg::LoadConfigFile(kSourceDir + "/configs/robots/wheel.xml");
  std::map<int, snp::Tristate> motors;
  for (const snp::Frame& f : ConfigurationFrames(config)) {
    snp::Message m = snp::DecodeMessage(f);
    if (const auto* c = std::get_if<snp::Control>(&m)) motors[f.destination.id] = c->motors;
  }
  // Module 1 (amplitude, offset and speed 0) is the master but inactive.
  EXPECT_TRUE(IsInactive(config.modules[0]));
  EXPECT_EQ(motors.at(1), snp::Tristate::kOff);
  for (int id : {6, 7, 12}) EXPECT_EQ(motors.at(id), snp::Tristate::kOn) << id;
  cpg::ModuleParams held{.id = 4, .offset = 0.2};  // no oscillation but a set-point
  EXPECT_FALSE(IsInactive(held));

  Robot robot(physics::Morphology::LoadFile(kSourceDir + "/configs/worlds/wheel.xml"),
              {.master = 1});
  Configure(robot, config);
  EXPECT_TRUE(robot.Firmware(1).cpg);
  EXPECT_FALSE(robot.Firmware(1).motors);
  EXPECT_FALSE(robot.world().MotorEnabled(1));
  EXPECT_TRUE(robot.world().MotorEnabled(6));
  // 2 and 3 are not in the configuration: never powered.
  EXPECT_FALSE(robot.world().MotorEnabled(2));
  EXPECT_FALSE(robot.world().MotorEnabled(3));
}

TEST(BridgeRobotTest, PoweredModuleWithCpgOffHoldsItsStartingAngle) {
  const physics::Morphology wheel =
      physics::Morphology::LoadFile(kSourceDir + "/configs/worlds/wheel.xml");
  Robot robot(wheel);
  const std::vector<int> ids = robot.world().ModuleIds();
  for (int id : ids) {
    if (id == 1) continue;
    ASSERT_EQ(SendExpect<snp::ConnectAck>(robot, ToModule(1, snp::ConnectRequest{
                                                               .child = static_cast<uint8_t>(id)}))
                  .status,
              snp::LinkStatus::kUp);
  }
  // Every motor on (none oscillating): the hexagon keeps its starting pose
  // rather than snapping to 0.
  for (int id : ids) {
    SendExpect<snp::Ack>(robot, ToModule(id, snp::Control{.motors = snp::Tristate::kOn}));
  }
  std::vector<snp::Frame> events;
  robot.Advance(1.0, events);
  for (int id : ids) {
    EXPECT_EQ(robot.world().ServoTarget(id), wheel.Module(id).StartAngle()) << id;
    EXPECT_NEAR(robot.world().ServoAngle(id), wheel.Module(id).StartAngle(), 0.02) << id;
  }
  robot.Reset();
  EXPECT_EQ(robot.world().ServoTarget(6), wheel.Module(6).StartAngle());
}

TEST(BridgeRobotTest, ConfigurationFramesLinkParentsFirst) {
  cpg::RobotConfig config = cpg::LoadConfigFile(kSourceDir + "/configs/robots/quadruped.xml");
  auto frames = ConfigurationFrames(config);
  std::set<int> linked = {config.master_id};
  std::size_t connects = 0;
  for (const snp::Frame& f : frames) {
    snp::Message m = snp::DecodeMessage(f);
    if (const auto* c = std::get_if<snp::ConnectRequest>(&m)) {
      EXPECT_TRUE(linked.count(f.destination.id)) << "parent " << int(f.destination.id);
      linked.insert(c->child);
      ++connects;
    }
  }
  EXPECT_EQ(connects, config.bluetooth_parent.size());
  EXPECT_EQ(linked.size(), config.modules.size());
}

// ---- Bridge specials of issue 11 (docs/snp.md 0x48-0x4E) -------------------

TEST(BridgeSpecialsTest, GroundKeepsAbsentFieldsAndAnswersTheGroundNow) {
  Robot robot(SnakeMorphology());
  auto g = SendExpect<snp::Ground>(robot, ToBridge(snp::SetGround{.friction = 0.4}));
  EXPECT_EQ(g, (snp::Ground{0.4, 0.0, 0.0}));
  EXPECT_EQ(robot.world().GroundFriction(), 0.4);
  g = SendExpect<snp::Ground>(robot, ToBridge(snp::SetGround{.slope = 0.2}));
  EXPECT_EQ(g, (snp::Ground{0.4, 0.2, 0.0}));
  g = SendExpect<snp::Ground>(robot, ToBridge(snp::SetGround{.slope_direction = 1.0}));
  EXPECT_EQ(g, (snp::Ground{0.4, 0.2, 1.0}));
  g = SendExpect<snp::Ground>(robot, ToBridge(snp::SetGround{}));  // read only
  EXPECT_EQ(g, (snp::Ground{0.4, 0.2, 1.0}));
  auto error = SendExpect<snp::SpecialError>(robot, ToBridge(snp::SetGround{.slope = 2.0}));
  EXPECT_EQ(error.code, StatusCode::kOutOfRange);
  error = SendExpect<snp::SpecialError>(robot, ToBridge(snp::SetGround{.friction = 0.0}));
  EXPECT_EQ(error.code, StatusCode::kOutOfRange);
  SendExpect<snp::SpecialAck>(robot, ToBridge(snp::ResetSimulation{}));
  g = SendExpect<snp::Ground>(robot, ToBridge(snp::SetGround{}));
  EXPECT_EQ(g.slope, 0.0);
}

TEST(BridgeSpecialsTest, MotorAndModuleDefectsReachTheWorld) {
  Robot robot(SnakeMorphology());
  SendExpect<snp::SpecialAck>(
      robot, ToBridge(snp::SetMotorFault{.module = 3, .fault = snp::MotorFault::kLimp}));
  EXPECT_EQ(robot.world().GetMotorFault(3), physics::MotorFault::kLimp);
  SendExpect<snp::SpecialAck>(
      robot, ToBridge(snp::SetMotorFault{.module = 3, .fault = snp::MotorFault::kNone}));
  EXPECT_EQ(robot.world().GetMotorFault(3), physics::MotorFault::kNone);
  SendExpect<snp::SpecialAck>(robot,
                              ToBridge(snp::SetModuleDefect{.module = 4, .defective = true}));
  EXPECT_TRUE(robot.Firmware(4).oscillator_dead);
  EXPECT_TRUE(robot.world().ModuleDefective(4));
  auto error = SendExpect<snp::SpecialError>(
      robot, ToBridge(snp::SetMotorFault{.module = 77, .fault = snp::MotorFault::kStuck}));
  EXPECT_EQ(error.code, StatusCode::kNotFound);
  error = SendExpect<snp::SpecialError>(robot,
                                        ToBridge(snp::SetModuleDefect{.module = 77}));
  EXPECT_EQ(error.code, StatusCode::kNotFound);
}

TEST(BridgeSpecialsTest, UpsideDownDivergenceAndSimInfo) {
  Robot robot(SnakeMorphology());
  SendExpect<snp::SpecialAck>(robot, ToBridge(snp::TurnUpsideDown{}));
  auto d = SendExpect<snp::Divergence>(robot, ToBridge(snp::GetDivergence{}));
  EXPECT_FALSE(d.diverged);
  EXPECT_EQ(d.module, snp::kNoModule);
  EXPECT_TRUE(d.reason.empty());
  robot.world().InjectNonFiniteForTesting(2);
  std::vector<snp::Frame> events;
  robot.StepOnce(events);
  d = SendExpect<snp::Divergence>(robot, ToBridge(snp::GetDivergence{}));
  EXPECT_TRUE(d.diverged);
  EXPECT_FALSE(d.reason.empty());
  EXPECT_EQ(d.time, robot.Time());
  const auto info = SendExpect<snp::SimInfo>(robot, ToBridge(snp::GetSimInfo{}));
  EXPECT_EQ(info.time_step, robot.world().options().time_step);
  EXPECT_EQ(info.accelerometer_zero, robot.world().options().accelerometer.zero_count);
  EXPECT_EQ(info.accelerometer_count, robot.world().options().accelerometer.count_size);
}

TEST(BridgeSpecialsTest, MorphologyReadbackIsChunkedFromOneSnapshot) {
  Robot robot(SnakeMorphology());
  const std::string expected = robot.world().CurrentMorphology().ToXml();
  ASSERT_GT(expected.size(), snp::kMaxMorphologyChunkSize);
  std::string text;
  uint32_t total = 0;
  do {
    const auto chunk = SendExpect<snp::MorphologyChunk>(
        robot, ToBridge(snp::ReadMorphology{.offset = static_cast<uint32_t>(text.size()),
                                            .length = snp::kMaxMorphologyChunkSize}));
    ASSERT_EQ(chunk.offset, text.size());
    ASSERT_FALSE(chunk.data.empty());
    total = chunk.total;
    text.append(chunk.data.begin(), chunk.data.end());
    // The robot changes mid-read: later chunks still come from the snapshot.
    if (text.size() == snp::kMaxMorphologyChunkSize) {
      SendExpect<snp::SpecialAck>(robot, ToBridge(snp::DisconnectModule{.module = 8}));
    }
  } while (text.size() < total);
  EXPECT_EQ(text, expected);
  const auto end = SendExpect<snp::MorphologyChunk>(
      robot, ToBridge(snp::ReadMorphology{.offset = total + 10, .length = 1}));
  EXPECT_EQ(end.offset, total);
  EXPECT_TRUE(end.data.empty());
  // A new read from 0 sees the robot as it is now.
  const auto first = SendExpect<snp::MorphologyChunk>(
      robot, ToBridge(snp::ReadMorphology{.offset = 0, .length = 10}));
  EXPECT_EQ(first.total, robot.world().CurrentMorphology().ToXml().size());
  EXPECT_NE(first.total, total);
}

TEST(BridgeSpecialsTest, MorphologyReadPastZeroNeedsASnapshot) {
  Robot robot(SnakeMorphology());
  const auto error = SendExpect<snp::SpecialError>(
      robot, ToBridge(snp::ReadMorphology{.offset = 5, .length = 5}));
  EXPECT_EQ(error.code, StatusCode::kFailedPrecondition);
}

// Reads the whole scene snapshot with ReadScene chunks.
snp::SceneSnapshot ReadWholeScene(Robot& robot) {
  std::vector<uint8_t> bytes;
  uint32_t total = 0;
  do {
    const auto chunk = SendExpect<snp::SceneChunk>(
        robot, ToBridge(snp::ReadScene{.offset = static_cast<uint32_t>(bytes.size()),
                                       .length = snp::kMaxSceneChunkSize}));
    EXPECT_EQ(chunk.offset, bytes.size());
    if (chunk.data.empty()) break;
    total = chunk.total;
    bytes.insert(bytes.end(), chunk.data.begin(), chunk.data.end());
  } while (bytes.size() < total);
  return snp::DecodeSceneSnapshot(bytes);
}

TEST(BridgeSpecialsTest, ReadSceneServesEveryModulePoseInChunks) {
  Robot robot(SnakeMorphology());
  robot.world().Step(100);
  const snp::SceneSnapshot scene = ReadWholeScene(robot);
  EXPECT_DOUBLE_EQ(scene.time, robot.Time());
  ASSERT_EQ(scene.modules.size(), robot.world().ModuleIds().size());
  ASSERT_GT(snp::EncodeSceneSnapshot(scene).size(), snp::kMaxSceneChunkSize);  // several chunks
  EXPECT_EQ(scene.shape.size(), physics::ModuleBoxes().size());
  for (const snp::SceneModule& m : scene.modules) {
    const Eigen::Isometry3d body = robot.world().ModulePose(m.id);
    const Eigen::Isometry3d handle = robot.world().HandlePose(m.id);
    for (int i = 0; i < 3; ++i) {
      EXPECT_NEAR(m.body.position[i], body.translation()[i], 1e-6) << m.id;
      EXPECT_NEAR(m.handle.position[i], handle.translation()[i], 1e-6) << m.id;
    }
    EXPECT_EQ((m.flags & snp::kSceneModuleCentral) != 0, m.id == robot.world().CentralModule());
  }
  // The same scene as bridge::SceneOf, through the snapshot.
  const render::Scene direct = SceneOf(robot.world());
  const render::Scene via = render::FromSnapshot(scene);
  ASSERT_EQ(via.modules.size(), direct.modules.size());
  EXPECT_TRUE(via.modules[2].body.position.isApprox(direct.modules[2].body.position, 1e-6));
  EXPECT_EQ(via.Central()->id, direct.Central()->id);
}

// The LED is drawn on the central module's face that is up as built, also
// for the quadruped whose central body is built on its side.
TEST(BridgeSpecialsTest, TheSceneLedSitsOnTheFaceThatIsUpAsBuilt) {
  for (const char* robot_name : {"snake", "quadruped"}) {
    Robot robot(physics::Morphology::LoadFile(kSourceDir + "/configs/worlds/" + robot_name + ".xml"));
    const render::Scene scene = SceneOf(robot.world());
    const Eigen::Vector3d led_world = robot.world().ModulePose(robot.world().CentralModule()) * scene.led;
    const Eigen::Vector3d centre = robot.world().ModulePose(robot.world().CentralModule()).translation();
    EXPECT_GT(led_world.z() - centre.z(), 0.02) << robot_name << ": above the module's centre";
    EXPECT_LT(std::hypot(led_world.x() - centre.x(), led_world.y() - centre.y()), 0.01) << robot_name;
  }
}

TEST(BridgeSpecialsTest, ReadSceneLeavesPutAwayModulesOutAndShowsTheSlope) {
  Robot robot(SnakeMorphology());
  SendExpect<snp::SpecialAck>(robot, ToBridge(snp::DisconnectModule{.module = 8}));
  SendExpect<snp::Ground>(robot, ToBridge(snp::SetGround{.slope = 0.2, .slope_direction = 1.0}));
  const snp::SceneSnapshot scene = ReadWholeScene(robot);
  for (const snp::SceneModule& m : scene.modules) EXPECT_NE(m.id, 8);
  EXPECT_NEAR(scene.slope, 0.2, 1e-6);
  EXPECT_NEAR(scene.slope_direction, 1.0, 1e-6);
}

TEST(BridgeSpecialsTest, ReadSceneOfADivergedWorldFailsAndPastZeroNeedsASnapshot) {
  Robot robot(SnakeMorphology());
  const auto early = SendExpect<snp::SpecialError>(
      robot, ToBridge(snp::ReadScene{.offset = 5, .length = 5}));
  EXPECT_EQ(early.code, StatusCode::kFailedPrecondition);
  robot.world().InjectNonFiniteForTesting(3);
  robot.world().Step();
  ASSERT_TRUE(robot.world().Diverged());
  const auto error = SendExpect<snp::SpecialError>(
      robot, ToBridge(snp::ReadScene{.offset = 0, .length = 10}));
  EXPECT_EQ(error.code, StatusCode::kFailedPrecondition);
  EXPECT_NE(error.text.find("diverged"), std::string::npos) << error.text;
}

}  // namespace
}  // namespace yamor::bridge
