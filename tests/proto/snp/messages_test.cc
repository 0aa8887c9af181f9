// Typed message tests: every type round-trips, encode and decode reject
// values the wire cannot carry (naming the field), payloads are canonical.
#include "proto/snp/messages.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <limits>
#include <set>
#include <string>

#include "common/status.h"
#include "tests/proto/snp/test_messages.h"

namespace yamor::snp {
namespace {

using ::testing::HasSubstr;

template <class F>
std::string ErrorOf(F&& action) {
  try {
    action();
  } catch (const Error& error) {
    EXPECT_EQ(error.code(), StatusCode::kInvalidArgument) << error.what();
    return error.what();
  }
  ADD_FAILURE() << "no yamor::Error thrown";
  return "";
}

std::string EncodeError(const Message& message) {
  return ErrorOf([&] { EncodePayload(message); });
}

std::string DecodeError(MessageType type, std::vector<uint8_t> payload) {
  return ErrorOf([&] { DecodePayload(type, payload); });
}

std::vector<uint8_t> PayloadBytes(const Message& message) {
  const Payload payload = EncodePayload(message);
  return {payload.bytes().begin(), payload.bytes().end()};
}

template <std::size_t... I>
std::set<MessageType> VariantTypes(std::index_sequence<I...>) {
  return {std::variant_alternative_t<I, Message>::kType...};
}

TEST(SnpMessageTypeTest, VariantCoversEveryTypeOnce) {
  const std::set<MessageType> in_variant =
      VariantTypes(std::make_index_sequence<std::variant_size_v<Message>>());
  const std::set<MessageType> listed(std::begin(kAllMessageTypes),
                                     std::end(kAllMessageTypes));
  EXPECT_EQ(in_variant.size(), std::variant_size_v<Message>) << "duplicate kType";
  EXPECT_EQ(in_variant, listed);
}

TEST(SnpMessageTypeTest, NamesAndCodes) {
  std::set<std::string_view> names;
  int known = 0;
  for (int code = 0; code < 256; ++code) {
    if (!IsKnownMessageType(static_cast<uint8_t>(code))) {
      EXPECT_EQ(MessageTypeName(static_cast<MessageType>(code)), "Unknown");
      continue;
    }
    ++known;
    const auto type = static_cast<MessageType>(code);
    names.insert(MessageTypeName(type));
    // The class follows from the code range (docs/snp.md).
    const MessageClass expected = code < 0x40   ? MessageClass::kModule
                                  : code < 0x60 ? MessageClass::kBridgeCommand
                                                : MessageClass::kBridgeReply;
    EXPECT_EQ(ClassOf(type), expected) << MessageTypeName(type);
  }
  EXPECT_EQ(known, static_cast<int>(std::size(kAllMessageTypes)));
  EXPECT_EQ(names.size(), std::size(kAllMessageTypes));
  EXPECT_EQ(MessageTypeName(MessageType::kSetLimits), "SetLimits");
  EXPECT_EQ(MessageTypeName(MessageType::kSpecialError), "SpecialError");
  EXPECT_FALSE(IsKnownMessageType(0));
}

TEST(SnpMessageTest, SamplesCoverEveryType) {
  std::set<MessageType> covered;
  for (const auto& sample : testing::SampleMessages()) {
    covered.insert(TypeOf(sample.message));
  }
  EXPECT_EQ(covered.size(), std::size(kAllMessageTypes));
}

TEST(SnpMessageTest, EverySampleRoundTrips) {
  for (const auto& sample : testing::SampleMessages()) {
    const MessageType type = TypeOf(sample.message);
    SCOPED_TRACE(std::string(MessageTypeName(type)));
    const Frame frame =
        MakeFrame(sample.source, sample.destination, sample.message);
    EXPECT_EQ(frame.type, type);
    EXPECT_TRUE(PayloadSizeRuleOf(type).Allows(frame.payload.size()));
    const Frame decoded_frame = DecodeFrame(EncodeFrame(frame));
    EXPECT_EQ(decoded_frame.source, sample.source);
    EXPECT_EQ(decoded_frame.destination, sample.destination);
    EXPECT_EQ(DecodeMessage(decoded_frame), sample.message);
  }
}

TEST(SnpMessageTest, RandomMessagesRoundTripBitExactly) {
  std::mt19937_64 rng(20240501);
  for (int i = 0; i < 5000; ++i) {
    const testing::AddressedMessage sample = testing::RandomMessage(rng);
    const std::vector<uint8_t> bytes = testing::EncodeMessage(sample);
    const Frame frame = DecodeFrame(bytes);
    const Message decoded = DecodeMessage(frame);
    ASSERT_EQ(decoded, sample.message) << MessageTypeName(frame.type);
    // Canonical: re-encoding gives the same bytes (-0.0 keeps its sign).
    ASSERT_EQ(EncodeFrame(MakeFrame(frame.source, frame.destination, decoded)),
              bytes);
  }
}

TEST(SnpMessageTest, NegativeZeroKeepsItsSign) {
  const Message decoded = DecodePayload(
      MessageType::kServoAngle, PayloadBytes(ServoAngle{-0.0f}));
  EXPECT_TRUE(std::signbit(std::get<ServoAngle>(decoded).angle));
}

TEST(SnpMessageTest, PayloadLayoutsArePinned) {
  EXPECT_EQ(PayloadBytes(ConnectAck{12, LinkStatus::kFailed}),
            (std::vector<uint8_t>{12, 1}));
  EXPECT_EQ(PayloadBytes(Control{Tristate::kOff, Tristate::kUnchanged, Tristate::kOn}),
            (std::vector<uint8_t>{0x02 | (0 << 2) | (1 << 4)}));
  EXPECT_EQ(PayloadBytes(SetOscillator{std::nullopt, 1.0f, std::nullopt}),
            (std::vector<uint8_t>{0x02, 0, 0, 0, 0, 0, 0, 0x80, 0x3F, 0, 0, 0, 0}));
  EXPECT_EQ(PayloadBytes(SetCoupling{7, 0.5f, 2.0f}),
            (std::vector<uint8_t>{7, 0, 0, 0, 0x3F, 0, 0, 0, 0x40}));
  EXPECT_EQ(PayloadBytes(Accelerometer{{{0x0201, 0x03FF, 0}}}),
            (std::vector<uint8_t>{0x01, 0x02, 0xFF, 0x03, 0, 0}));
  EXPECT_EQ(PayloadBytes(Ack{MessageType::kSetLimits, StatusCode::kOutOfRange}),
            (std::vector<uint8_t>{0x05, 11}));
  EXPECT_EQ(PayloadBytes(SetTimer{9, 1.0}),
            (std::vector<uint8_t>{9, 0, 0, 0, 0, 0, 0, 0xF0, 0x3F}));
  EXPECT_EQ(PayloadBytes(ConnectModules{1, Connector::kRear, 2, Connector::kBottom, 23}),
            (std::vector<uint8_t>{1, 1, 2, 5, 23}));
  EXPECT_EQ(PayloadBytes(SpecialError{MessageType::kStep, StatusCode::kUnimplemented, "no"}),
            (std::vector<uint8_t>{0x41, 12, 'n', 'o'}));
  EXPECT_EQ(PayloadBytes(RobotPosition{}).size(), 64u);
  // Bridge specials of issue 11 (docs/snp.md).
  EXPECT_EQ(PayloadBytes(SetGround{std::nullopt, 1.0, std::nullopt}),
            (std::vector<uint8_t>{0x02, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0xF0, 0x3F,
                                  0, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(PayloadBytes(SetGround{}), std::vector<uint8_t>(25, 0));
  EXPECT_EQ(PayloadBytes(SetMotorFault{3, MotorFault::kLimp}), (std::vector<uint8_t>{3, 1}));
  EXPECT_EQ(PayloadBytes(SetModuleDefect{3, true}), (std::vector<uint8_t>{3, 1}));
  EXPECT_EQ(PayloadBytes(ReadMorphology{0x01020304, 232}),
            (std::vector<uint8_t>{4, 3, 2, 1, 232}));
  EXPECT_EQ(PayloadBytes(Divergence{true, 4, 2.0, "x"}),
            (std::vector<uint8_t>{1, 4, 0, 0, 0, 0, 0, 0, 0, 0x40, 'x'}));
  EXPECT_EQ(PayloadBytes(MorphologyChunk{3, 1, {'a', 'b'}}),
            (std::vector<uint8_t>{3, 0, 0, 0, 1, 0, 0, 0, 'a', 'b'}));
  EXPECT_EQ(PayloadBytes(Ground{}).size(), 24u);
  EXPECT_EQ(PayloadBytes(SimInfo{}).size(), 24u);
  // Scene readback (issue 14).
  EXPECT_EQ(PayloadBytes(ReadScene{0x01020304, 232}), (std::vector<uint8_t>{4, 3, 2, 1, 232}));
  EXPECT_EQ(PayloadBytes(SceneChunk{3, 1, {'a', 'b'}}),
            (std::vector<uint8_t>{3, 0, 0, 0, 1, 0, 0, 0, 'a', 'b'}));
}

TEST(SnpSpecialsValidationTest, RejectBadValuesNamingTheField) {
  EXPECT_EQ(EncodeError(SetGround{std::numeric_limits<double>::quiet_NaN(), {}, {}}),
            "SetGround.friction is not finite: nan");
  EXPECT_EQ(EncodeError(SetMotorFault{3, static_cast<MotorFault>(3)}),
            "SetMotorFault.fault 3 out of range 0..2");
  EXPECT_EQ(EncodeError(SetModuleDefect{255, false}),
            "SetModuleDefect.module 255 out of range 0..254");
  EXPECT_EQ(EncodeError(ReadMorphology{0, 0}), "ReadMorphology.length 0 out of range 1..232");
  EXPECT_EQ(EncodeError(ReadMorphology{0, 233}), "ReadMorphology.length 233 out of range 1..232");
  EXPECT_EQ(EncodeError(MorphologyChunk{1, 0, {'a', 'b'}}),
            "MorphologyChunk.data ends at 2, past the total of 1 bytes");
  EXPECT_EQ(EncodeError(MorphologyChunk{1000, 0, std::vector<uint8_t>(233, 'a')}),
            "MorphologyChunk.data is 233 bytes long, at most 232 fit");
  EXPECT_EQ(EncodeError(Divergence{true, 1, 0.0, std::string(231, 'a')}),
            "Divergence.reason is 231 bytes long, at most 230 fit");
  EXPECT_EQ(EncodeError(Divergence{true, 1, 0.0, "tab\there"}),
            "Divergence.reason has non-printable byte 0x09 at 3");
  EXPECT_EQ(EncodeError(SimInfo{std::numeric_limits<double>::infinity(), 512, 0.04}),
            "SimInfo.time_step is not finite: inf");

  std::vector<uint8_t> ground(25, 0);
  ground[0] = 0x08;
  EXPECT_EQ(DecodeError(MessageType::kSetGround, ground),
            "SetGround.mask has reserved bits set: 0x08");
  ground[0] = 0x00;
  ground[24] = 0x01;
  EXPECT_EQ(DecodeError(MessageType::kSetGround, ground),
            "SetGround.slope_direction is absent but its bytes are not zero");
  EXPECT_EQ(DecodeError(MessageType::kSetModuleDefect, {3, 2}),
            "SetModuleDefect.defective 2 out of range 0..1");
  EXPECT_EQ(DecodeError(MessageType::kMorphologyChunk, {1, 0, 0, 0, 1, 0, 0, 0, 'a'}),
            "MorphologyChunk.data ends at 2, past the total of 1 bytes");
  EXPECT_EQ(DecodeError(MessageType::kDivergence, {2, 0, 0, 0, 0, 0, 0, 0, 0, 0}),
            "Divergence.diverged 2 out of range 0..1");
  EXPECT_THAT(DecodeError(MessageType::kReadMorphology, {0, 0, 0, 0}),
              HasSubstr("ReadMorphology"));
}

TEST(SnpSpecialsTest, MorphologyChunkCarriesAnyByte) {
  MorphologyChunk chunk{256, 0, {}};
  for (int i = 0; i < 232; ++i) chunk.data.push_back(static_cast<uint8_t>(i));
  const Message decoded =
      DecodeMessage(DecodeFrame(EncodeFrame(MakeFrame(Address::Bridge(), Address::Host(), chunk))));
  EXPECT_EQ(std::get<MorphologyChunk>(decoded), chunk);
}

TEST(SnpEncodeValidationTest, RejectsNonFiniteFloatsNamingTheField) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  EXPECT_EQ(EncodeError(SetOscillator{nan, std::nullopt, std::nullopt}),
            "SetOscillator.amplitude is not finite: nan");
  EXPECT_EQ(EncodeError(SetOscillator{std::nullopt, std::nullopt, -inf}),
            "SetOscillator.speed is not finite: -inf");
  EXPECT_EQ(EncodeError(SetLimits{0.0f, inf}), "SetLimits.max_angle is not finite: inf");
  EXPECT_EQ(EncodeError(SetCoupling{1, nan, 1.0f}), "SetCoupling.phase is not finite: nan");
  EXPECT_EQ(EncodeError(ServoAngle{inf}), "ServoAngle.angle is not finite: inf");
  EXPECT_EQ(EncodeError(Step{std::numeric_limits<double>::quiet_NaN()}),
            "Step.duration is not finite: nan");
  RobotPosition position;
  position.orientation[3] = std::numeric_limits<double>::infinity();
  EXPECT_EQ(EncodeError(position), "RobotPosition.orientation.z is not finite: inf");
}

TEST(SnpEncodeValidationTest, RejectsOutOfRangeValues) {
  EXPECT_EQ(EncodeError(ConnectRequest{255}), "ConnectRequest.child 255 out of range 0..254");
  EXPECT_EQ(EncodeError(SetCoupling{255, 0.0f, 0.0f}), "SetCoupling.to 255 out of range 0..254");
  EXPECT_EQ(EncodeError(ConnectModules{1, Connector::kFront, 2, Connector::kFront, 24}),
            "ConnectModules.angle_index 24 out of range 0..23");
  EXPECT_EQ(EncodeError(ConnectModules{1, static_cast<Connector>(6), 2, Connector::kFront, 0}),
            "ConnectModules.from_connector 6 out of range 0..5");
  EXPECT_EQ(EncodeError(ConnectAck{1, static_cast<LinkStatus>(2)}),
            "ConnectAck.status 2 out of range 0..1");
  EXPECT_EQ(EncodeError(Control{Tristate::kOn, static_cast<Tristate>(3), Tristate::kOn}),
            "Control.cpg has invalid tristate value 3");
  EXPECT_EQ(EncodeError(SetOscillator{}), "SetOscillator.mask sets no field");
  EXPECT_EQ(EncodeError(ReadAccelerometer{0}),
            "ReadAccelerometer.sample_count 0 out of range 1..16");
  EXPECT_EQ(EncodeError(ReadAccelerometer{17}),
            "ReadAccelerometer.sample_count 17 out of range 1..16");
  EXPECT_EQ(EncodeError(Accelerometer{}), "Accelerometer.samples has 0 samples, expects 1..16");
  EXPECT_EQ(EncodeError(Accelerometer{std::vector<AccelerometerSample>(17)}),
            "Accelerometer.samples has 17 samples, expects 1..16");
  EXPECT_EQ(EncodeError(Accelerometer{{{1, 2, 3}, {4, 1024, 6}}}),
            "Accelerometer.samples[1].y 1024 out of range 0..1023");
  EXPECT_EQ(EncodeError(Accelerometer{{{-1, 2, 3}}}),
            "Accelerometer.samples[0].x -1 out of range 0..1023");
  EXPECT_EQ(EncodeError(Ack{MessageType::kStep, StatusCode::kOk}),
            "Ack.acked names Step, which is not a module message");
  EXPECT_EQ(EncodeError(Ack{static_cast<MessageType>(0x3F), StatusCode::kOk}),
            "Ack.acked is not a known message type: 0x3f");
  EXPECT_EQ(EncodeError(Ack{MessageType::kControl, static_cast<StatusCode>(17)}),
            "Ack.status 17 out of range 0..16");
  EXPECT_EQ(EncodeError(SpecialAck{MessageType::kControl}),
            "SpecialAck.acked names Control, which is not a bridge command");
  EXPECT_EQ(EncodeError(SpecialError{MessageType::kStep, StatusCode::kOk, "x"}),
            "SpecialError.code 0 out of range 1..16");
  EXPECT_EQ(EncodeError(SpecialError{MessageType::kStep, StatusCode::kInternal,
                                     std::string(kMaxErrorTextSize + 1, 'a')}),
            "SpecialError.text is 239 bytes long, at most 238 fit");
  EXPECT_EQ(EncodeError(SpecialError{MessageType::kStep, StatusCode::kInternal, "a\nb"}),
            "SpecialError.text has non-printable byte 0x0a at 1");
  EXPECT_EQ(EncodeError(SetMasterNode{255}), "SetMasterNode.module 255 out of range 0..254");
  EXPECT_EQ(EncodeError(DisconnectModule{255}),
            "DisconnectModule.module 255 out of range 0..254");
}

TEST(SnpEncodeValidationTest, MakeFrameChecksEndpoints) {
  EXPECT_EQ(ErrorOf([] { MakeFrame(Address::Module(1), Address::Bridge(), GetSimTime{}); }),
            "GetSimTime is a bridge command (host to bridge) but goes from a "
            "module to the bridge");
  EXPECT_EQ(ErrorOf([] { MakeFrame(Address::Host(), Address::Broadcast(), Step{1.0}); }),
            "Step is a bridge command (host to bridge) but goes from the host "
            "to a module");
  EXPECT_EQ(ErrorOf([] { MakeFrame(Address::Bridge(), Address::Module(3), SimTime{1.0}); }),
            "SimTime is a bridge reply (bridge to host) but goes from the "
            "bridge to a module");
  EXPECT_EQ(ErrorOf([] { MakeFrame(Address::Host(), Address::Bridge(), ClearCouplings{}); }),
            "ClearCouplings is a module message but the destination is the "
            "bridge");
  EXPECT_EQ(ErrorOf([] { MakeFrame(Address::Broadcast(), Address::Host(), ServoAngle{}); }),
            "broadcast address 255 used as source");
  EXPECT_NO_THROW(MakeFrame(Address::Host(), Address::Broadcast(), ClearCouplings{}));
}

TEST(SnpDecodeValidationTest, RejectsNonFiniteFloatBytes) {
  // 0x7FC00000 is a float32 quiet NaN.
  EXPECT_EQ(DecodeError(MessageType::kSetLimits, {0, 0, 0, 0, 0, 0, 0xC0, 0x7F}),
            "SetLimits.max_angle is not finite: nan");
  EXPECT_EQ(DecodeError(MessageType::kSimTime, {0, 0, 0, 0, 0, 0, 0xF0, 0x7F}),
            "SimTime.seconds is not finite: inf");
}

TEST(SnpDecodeValidationTest, RejectsNonCanonicalPayloads) {
  EXPECT_EQ(DecodeError(MessageType::kSetOscillator,
                        {0x01, 0, 0, 0, 0, 0, 0, 0x80, 0x3F, 0, 0, 0, 0}),
            "SetOscillator.offset is absent but its bytes are not zero");
  EXPECT_EQ(DecodeError(MessageType::kSetOscillator, std::vector<uint8_t>(13, 0)),
            "SetOscillator.mask sets no field");
  std::vector<uint8_t> reserved(13, 0);
  reserved[0] = 0x09;
  EXPECT_EQ(DecodeError(MessageType::kSetOscillator, reserved),
            "SetOscillator.mask has reserved bits set: 0x09");
  EXPECT_EQ(DecodeError(MessageType::kControl, {0x40}),
            "Control.flags has reserved bits set: 0x40");
  EXPECT_EQ(DecodeError(MessageType::kControl, {0x0C}),
            "Control.cpg has invalid tristate value 3");
  EXPECT_EQ(DecodeError(MessageType::kConnectAck, {3, 2}), "ConnectAck.status 2 out of range 0..1");
  EXPECT_EQ(DecodeError(MessageType::kAccelerometer, {0, 0, 0, 4, 0, 0}),
            "Accelerometer.samples[0].y 1024 out of range 0..1023");
  EXPECT_EQ(DecodeError(MessageType::kSpecialError, {0x41, 12, 'o', 0}),
            "SpecialError.text has non-printable byte 0x00 at 1");
  EXPECT_EQ(DecodeError(MessageType::kSpecialAck, {0x05}),
            "SpecialAck.acked names SetLimits, which is not a bridge command");
}

TEST(SnpDecodeValidationTest, RejectsUnknownTypeAndWrongSize) {
  EXPECT_EQ(DecodeError(static_cast<MessageType>(0x99), {}), "unknown message type 0x99");
  EXPECT_EQ(DecodeError(MessageType::kServoAngle, {1, 2, 3}),
            "payload size 3 invalid for ServoAngle: expects 4 bytes");
}

TEST(SnpDecodeValidationTest, DecodeMessageValidatesTheFrame) {
  Frame frame;
  frame.source = Address::Host();
  frame.destination = Address::Module(1);
  frame.type = MessageType::kGetSimTime;
  EXPECT_THAT(ErrorOf([&] { DecodeMessage(frame); }), HasSubstr("bridge command"));
}

TEST(SnpConnectorTest, Names) {
  EXPECT_EQ(ConnectorName(Connector::kFront), "front");
  EXPECT_EQ(ConnectorName(Connector::kBottom), "bottom");
  EXPECT_EQ(ConnectorName(static_cast<Connector>(9)), "unknown");
}

}  // namespace
}  // namespace yamor::snp
