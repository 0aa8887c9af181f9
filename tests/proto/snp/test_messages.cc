#include "tests/proto/snp/test_messages.h"

#include <string>

namespace yamor::snp::testing {

namespace {

Address ModuleEndpoint(std::mt19937_64& rng, bool allow_broadcast) {
  const uint64_t pick = rng() % 8;
  if (pick == 0) return Address::Host();
  if (pick == 1 && allow_broadcast) return Address::Broadcast();
  return Address::Module(static_cast<uint8_t>(rng() % (kMaxModuleId + 1)));
}

float RandomFloat(std::mt19937_64& rng) {
  // Mix ordinary values with edge cases that must survive bit-exactly.
  switch (rng() % 6) {
    case 0: return 0.0f;
    case 1: return -0.0f;
    case 2: return 3.4e38f;
    case 3: return 1e-45f;  // smallest subnormal
    default:
      return static_cast<float>(static_cast<int64_t>(rng() % 2000001) -
                                1000000) / 1000.0f;
  }
}

double RandomDouble(std::mt19937_64& rng) {
  switch (rng() % 5) {
    case 0: return 0.0;
    case 1: return -1.7e308;
    case 2: return 4.9e-324;
    default:
      return static_cast<double>(static_cast<int64_t>(rng() % 20000001) -
                                 10000000) / 1e4;
  }
}

uint8_t RandomModule(std::mt19937_64& rng) {
  return static_cast<uint8_t>(rng() % (kMaxModuleId + 1));
}

template <class E>
E RandomEnum(std::mt19937_64& rng, E max) {
  return static_cast<E>(rng() % (static_cast<uint64_t>(max) + 1));
}

MessageType RandomTypeOfClass(std::mt19937_64& rng, MessageClass cls) {
  std::vector<MessageType> types;
  for (MessageType type : kAllMessageTypes) {
    if (ClassOf(type) == cls) types.push_back(type);
  }
  return types[rng() % types.size()];
}

StatusCode RandomStatus(std::mt19937_64& rng, bool allow_ok) {
  return static_cast<StatusCode>((allow_ok ? 0 : 1) + rng() % (allow_ok ? 17 : 16));
}

Message RandomOfType(MessageType type, std::mt19937_64& rng) {
  switch (type) {
    case MessageType::kConnectRequest: return ConnectRequest{RandomModule(rng)};
    case MessageType::kConnectAck:
      return ConnectAck{RandomModule(rng), RandomEnum(rng, LinkStatus::kFailed)};
    case MessageType::kControl:
      return Control{RandomEnum(rng, Tristate::kOff),
                     RandomEnum(rng, Tristate::kOff),
                     RandomEnum(rng, Tristate::kOff)};
    case MessageType::kSetOscillator: {
      SetOscillator m;
      const uint64_t mask = 1 + rng() % 7;
      if (mask & 1) m.amplitude = RandomFloat(rng);
      if (mask & 2) m.offset = RandomFloat(rng);
      if (mask & 4) m.speed = RandomFloat(rng);
      return m;
    }
    case MessageType::kSetLimits:
      return SetLimits{RandomFloat(rng), RandomFloat(rng)};
    case MessageType::kSetCoupling:
      return SetCoupling{RandomModule(rng), RandomFloat(rng), RandomFloat(rng)};
    case MessageType::kClearCouplings: return ClearCouplings{};
    case MessageType::kReadServoAngle: return ReadServoAngle{};
    case MessageType::kServoAngle: return ServoAngle{RandomFloat(rng)};
    case MessageType::kReadAccelerometer:
      return ReadAccelerometer{static_cast<uint8_t>(1 + rng() % 16)};
    case MessageType::kAccelerometer: {
      Accelerometer m;
      m.samples.resize(1 + rng() % kMaxAccelerometerSamples);
      for (auto& s : m.samples) {
        s = {static_cast<int16_t>(rng() % 1024), static_cast<int16_t>(rng() % 1024),
             static_cast<int16_t>(rng() % 1024)};
      }
      return m;
    }
    case MessageType::kAck:
      return Ack{RandomTypeOfClass(rng, MessageClass::kModule),
                 RandomStatus(rng, true)};
    case MessageType::kGetSimTime: return GetSimTime{};
    case MessageType::kStep: return Step{RandomDouble(rng)};
    case MessageType::kSetTimer:
      return SetTimer{static_cast<uint8_t>(rng()), RandomDouble(rng)};
    case MessageType::kGetRobotPosition: return GetRobotPosition{};
    case MessageType::kSetMasterNode: return SetMasterNode{RandomModule(rng)};
    case MessageType::kConnectModules:
      return ConnectModules{RandomModule(rng), RandomEnum(rng, Connector::kBottom),
                            RandomModule(rng), RandomEnum(rng, Connector::kBottom),
                            static_cast<uint8_t>(rng() % 24)};
    case MessageType::kDisconnectModule:
      return DisconnectModule{RandomModule(rng)};
    case MessageType::kResetSimulation: return ResetSimulation{};
    case MessageType::kSetGround: {
      SetGround m;
      const uint64_t mask = rng() % 8;
      if (mask & 1) m.friction = RandomDouble(rng);
      if (mask & 2) m.slope = RandomDouble(rng);
      if (mask & 4) m.slope_direction = RandomDouble(rng);
      return m;
    }
    case MessageType::kSetMotorFault:
      return SetMotorFault{RandomModule(rng), RandomEnum(rng, MotorFault::kStuck)};
    case MessageType::kSetModuleDefect:
      return SetModuleDefect{RandomModule(rng), rng() % 2 == 0};
    case MessageType::kTurnUpsideDown: return TurnUpsideDown{};
    case MessageType::kGetDivergence: return GetDivergence{};
    case MessageType::kReadMorphology:
      return ReadMorphology{static_cast<uint32_t>(rng()),
                            static_cast<uint8_t>(1 + rng() % kMaxMorphologyChunkSize)};
    case MessageType::kGetSimInfo: return GetSimInfo{};
    case MessageType::kReadScene:
      return ReadScene{static_cast<uint32_t>(rng()),
                       static_cast<uint8_t>(1 + rng() % kMaxSceneChunkSize)};
    case MessageType::kGround:
      return Ground{RandomDouble(rng), RandomDouble(rng), RandomDouble(rng)};
    case MessageType::kDivergence: {
      Divergence m{rng() % 2 == 0, static_cast<uint8_t>(rng()), RandomDouble(rng), {}};
      m.reason.resize(rng() % (kMaxDivergenceTextSize + 1));
      for (char& c : m.reason) c = static_cast<char>(0x20 + rng() % 95);
      return m;
    }
    case MessageType::kMorphologyChunk: {
      MorphologyChunk m;
      m.data.resize(rng() % (kMaxMorphologyChunkSize + 1));
      for (uint8_t& b : m.data) b = static_cast<uint8_t>(rng());
      m.offset = static_cast<uint32_t>(rng() % 100000);
      m.total = m.offset + static_cast<uint32_t>(m.data.size() + rng() % 1000);
      return m;
    }
    case MessageType::kSimInfo:
      return SimInfo{RandomDouble(rng), RandomDouble(rng), RandomDouble(rng)};
    case MessageType::kSceneChunk: {
      SceneChunk m;
      m.data.resize(rng() % (kMaxSceneChunkSize + 1));
      for (uint8_t& b : m.data) b = static_cast<uint8_t>(rng());
      m.offset = static_cast<uint32_t>(rng() % 100000);
      m.total = m.offset + static_cast<uint32_t>(m.data.size() + rng() % 1000);
      return m;
    }
    case MessageType::kSimTime: return SimTime{RandomDouble(rng)};
    case MessageType::kStepDone: return StepDone{RandomDouble(rng)};
    case MessageType::kTimerFired:
      return TimerFired{static_cast<uint8_t>(rng()), RandomDouble(rng)};
    case MessageType::kRobotPosition: {
      RobotPosition m;
      m.time = RandomDouble(rng);
      for (double& v : m.position) v = RandomDouble(rng);
      for (double& v : m.orientation) v = RandomDouble(rng);
      return m;
    }
    case MessageType::kSpecialAck:
      return SpecialAck{RandomTypeOfClass(rng, MessageClass::kBridgeCommand)};
    case MessageType::kSpecialError: {
      SpecialError m{RandomTypeOfClass(rng, MessageClass::kBridgeCommand),
                     RandomStatus(rng, false), {}};
      m.text.resize(rng() % (kMaxErrorTextSize + 1));
      for (char& c : m.text) c = static_cast<char>(0x20 + rng() % 95);
      return m;
    }
  }
  return ClearCouplings{};
}

}  // namespace

std::vector<AddressedMessage> SampleMessages() {
  const Address host = Address::Host();
  const Address bridge = Address::Bridge();
  const Address m3 = Address::Module(3);
  const Address all = Address::Broadcast();
  Accelerometer one_sample{{{512, 0, 1023}}};
  Accelerometer full;
  for (int i = 0; i < 16; ++i) {
    full.samples.push_back({static_cast<int16_t>(i), static_cast<int16_t>(500 + i),
                            static_cast<int16_t>(1023 - i)});
  }
  return {
      {host, Address::Module(0), ConnectRequest{254}},
      {Address::Module(0), host, ConnectAck{254, LinkStatus::kUp}},
      {Address::Module(7), host, ConnectAck{12, LinkStatus::kFailed}},
      {host, all, Control{Tristate::kOn, Tristate::kOn, Tristate::kOn}},
      {host, m3, Control{Tristate::kOff, Tristate::kUnchanged, Tristate::kOn}},
      {host, m3, SetOscillator{0.5f, -0.25f, 1.0f}},
      {host, all, SetOscillator{std::nullopt, 0.125f, std::nullopt}},
      {host, m3, SetLimits{-1.5707964f, 1.5707964f}},
      {host, m3, SetCoupling{12, 3.1415927f, 0.5f}},
      {host, m3, ClearCouplings{}},
      {host, m3, ReadServoAngle{}},
      {m3, host, ServoAngle{-0.75f}},
      {host, m3, ReadAccelerometer{16}},
      {m3, host, one_sample},
      {m3, host, full},
      {m3, host, Ack{MessageType::kSetLimits, StatusCode::kOk}},
      {m3, host, Ack{MessageType::kSetCoupling, StatusCode::kOutOfRange}},
      {Address::Module(4), m3, SetCoupling{4, -0.5f, 2.0f}},
      {host, bridge, GetSimTime{}},
      {host, bridge, Step{0.01}},
      {host, bridge, SetTimer{7, 12.5}},
      {host, bridge, GetRobotPosition{}},
      {host, bridge, SetMasterNode{0}},
      {host, bridge, ConnectModules{1, Connector::kRear, 2, Connector::kTop, 23}},
      {host, bridge, DisconnectModule{254}},
      {host, bridge, ResetSimulation{}},
      {host, bridge, SetGround{0.4, std::nullopt, 1.5}},
      {host, bridge, SetGround{}},
      {host, bridge, SetMotorFault{3, MotorFault::kStuck}},
      {host, bridge, SetModuleDefect{254, true}},
      {host, bridge, TurnUpsideDown{}},
      {host, bridge, GetDivergence{}},
      {host, bridge, ReadMorphology{464, 232}},
      {host, bridge, GetSimInfo{}},
      {host, bridge, ReadScene{232, 232}},
      {bridge, host, SimTime{20.004}},
      {bridge, host, StepDone{20.014}},
      {bridge, host, TimerFired{7, 32.5}},
      {bridge, host, RobotPosition{8.0, {0.25, -1.5, 0.05}, {0.7071067811865476, 0, 0, 0.7071067811865476}}},
      {bridge, host, SpecialAck{MessageType::kResetSimulation}},
      {bridge, host, Ground{1.0, 0.1, -3.0}},
      {bridge, host, Divergence{}},
      {bridge, host, Divergence{true, 4, 12.5, "non-finite body state"}},
      {bridge, host, MorphologyChunk{5, 0, {'<', 'r', '/', '>', '\n'}}},
      {bridge, host, MorphologyChunk{300, 68, std::vector<uint8_t>(kMaxMorphologyChunkSize, 0x00)}},
      {bridge, host, SimInfo{0.001, 512.0, 0.0395}},
      {bridge, host, SceneChunk{4, 0, {1, 0, 4, 2}}},
      {bridge, host, SceneChunk{900, 464, std::vector<uint8_t>(kMaxSceneChunkSize, 0xff)}},
      {bridge, host, SpecialError{MessageType::kConnectModules, StatusCode::kUnimplemented,
                                  "manual assembly required"}},
      {bridge, host, SpecialError{MessageType::kStep, StatusCode::kInvalidArgument,
                                  std::string(kMaxErrorTextSize, 'x')}},
  };
}

AddressedMessage RandomMessage(std::mt19937_64& rng) {
  const MessageType type = kAllMessageTypes[rng() % std::size(kAllMessageTypes)];
  AddressedMessage out{Address::Host(), Address::Bridge(), RandomOfType(type, rng)};
  switch (ClassOf(type)) {
    case MessageClass::kModule:
      out.source = ModuleEndpoint(rng, false);
      out.destination = ModuleEndpoint(rng, true);
      break;
    case MessageClass::kBridgeCommand:
      break;
    case MessageClass::kBridgeReply:
      out.source = Address::Bridge();
      out.destination = Address::Host();
      break;
  }
  return out;
}

std::vector<uint8_t> EncodeMessage(const AddressedMessage& message) {
  return EncodeFrame(MakeFrame(message.source, message.destination, message.message));
}

}  // namespace yamor::snp::testing
