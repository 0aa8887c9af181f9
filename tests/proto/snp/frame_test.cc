// Frame-level tests: CRC, pinned byte layouts (docs/snp.md shows the same
// bytes), one-shot DecodeFrame rejections with their reasons.
#include "proto/snp/frame.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string_view>
#include <vector>

#include "common/status.h"
#include "proto/snp/messages.h"
#include "tests/proto/snp/test_messages.h"

namespace yamor::snp {
namespace {

using ::testing::HasSubstr;

std::vector<uint8_t> Bytes(std::initializer_list<int> values) {
  std::vector<uint8_t> out;
  for (int v : values) out.push_back(static_cast<uint8_t>(v));
  return out;
}

// Rewrites the CRC of a hand-edited frame so only the intended rule fails.
void FixCrc(std::vector<uint8_t>& frame) {
  const uint16_t crc =
      Crc16CcittFalse(std::span(frame).subspan(1, frame.size() - 3));
  frame[frame.size() - 2] = static_cast<uint8_t>(crc & 0xFF);
  frame[frame.size() - 1] = static_cast<uint8_t>(crc >> 8);
}

// The reason DecodeFrame gives for `bytes` (checks the code too).
std::string DecodeFrameReason(const std::vector<uint8_t>& bytes) {
  try {
    DecodeFrame(bytes);
  } catch (const Error& error) {
    EXPECT_EQ(error.code(), StatusCode::kInvalidArgument);
    return error.what();
  }
  ADD_FAILURE() << "DecodeFrame accepted the bytes";
  return "";
}

std::string ValidateReason(const Frame& frame) {
  try {
    ValidateFrame(frame);
  } catch (const Error& error) {
    EXPECT_EQ(error.code(), StatusCode::kInvalidArgument);
    return error.what();
  }
  ADD_FAILURE() << "ValidateFrame accepted the frame";
  return "";
}

TEST(SnpCrc16Test, CcittFalseCheckValue) {
  const std::string_view check = "123456789";
  EXPECT_EQ(Crc16CcittFalse(std::span(
                reinterpret_cast<const uint8_t*>(check.data()), check.size())),
            0x29B1);
  EXPECT_EQ(Crc16CcittFalse({}), 0xFFFF);
}

TEST(SnpFrameLayoutTest, SetLimitsHostToModuleIsPinned) {
  const Frame frame =
      MakeFrame(Address::Host(), Address::Module(3), SetLimits{-1.0f, 0.5f});
  // start, length 8, flags (src host), src 0, dst 3, type 0x05,
  // -1.0f LE, 0.5f LE, CRC 0xBE7B LE.
  EXPECT_EQ(EncodeFrame(frame),
            Bytes({0xA5, 0x08, 0x01, 0x00, 0x03, 0x05, 0x00, 0x00, 0x80, 0xBF,
                   0x00, 0x00, 0x00, 0x3F, 0x7B, 0xBE}));
}

TEST(SnpFrameLayoutTest, BroadcastControlIsPinned) {
  const Frame frame = MakeFrame(Address::Host(), Address::Broadcast(),
                                Control{Tristate::kOn, Tristate::kOn, Tristate::kOff});
  EXPECT_EQ(EncodeFrame(frame),
            Bytes({0xA5, 0x01, 0x01, 0x00, 0xFF, 0x03, 0x25, 0x16, 0x0F}));
}

TEST(SnpFrameLayoutTest, BridgeStepIsPinned) {
  const Frame frame = MakeFrame(Address::Host(), Address::Bridge(), Step{0.01});
  EXPECT_EQ(EncodeFrame(frame),
            Bytes({0xA5, 0x08, 0x09, 0x00, 0x00, 0x41, 0x7B, 0x14, 0xAE, 0x47,
                   0xE1, 0x7A, 0x84, 0x3F, 0x2F, 0xF5}));
}

TEST(SnpFrameLayoutTest, BridgeSetMotorFaultIsPinned) {
  const Frame frame =
      MakeFrame(Address::Host(), Address::Bridge(), SetMotorFault{3, MotorFault::kStuck});
  EXPECT_EQ(EncodeFrame(frame), Bytes({0xA5, 0x02, 0x09, 0x00, 0x00, 0x49, 0x03, 0x02, 0xE2, 0x2F}));
}

TEST(SnpFrameLayoutTest, BridgeReadMorphologyIsPinned) {
  const Frame frame =
      MakeFrame(Address::Host(), Address::Bridge(), ReadMorphology{232, 232});
  EXPECT_EQ(EncodeFrame(frame), Bytes({0xA5, 0x05, 0x09, 0x00, 0x00, 0x4D, 0xE8, 0x00, 0x00, 0x00, 0xE8, 0xC1, 0x80}));
}

TEST(SnpFrameLayoutTest, BridgeMorphologyChunkIsPinned) {
  const Frame frame = MakeFrame(Address::Bridge(), Address::Host(),
                                MorphologyChunk{300, 232, {'<', '/', 'r', '>'}});
  EXPECT_EQ(EncodeFrame(frame), Bytes({0xA5, 0x0C, 0x06, 0x00, 0x00, 0x68, 0x2C, 0x01, 0x00, 0x00, 0xE8, 0x00, 0x00, 0x00, 0x3C, 0x2F, 0x72, 0x3E, 0xD1, 0x01}));
}

TEST(SnpFrameLayoutTest, BridgeReadSceneIsPinned) {
  const Frame frame = MakeFrame(Address::Host(), Address::Bridge(), ReadScene{0, 232});
  EXPECT_EQ(EncodeFrame(frame), Bytes({0xA5, 0x05, 0x09, 0x00, 0x00, 0x4F, 0x00, 0x00, 0x00, 0x00, 0xE8, 0xA0, 0x32}));
}

TEST(SnpFrameTest, EveryFrameRoundTripsThroughBytes) {
  for (const auto& sample : testing::SampleMessages()) {
    const Frame frame =
        MakeFrame(sample.source, sample.destination, sample.message);
    const std::vector<uint8_t> bytes = EncodeFrame(frame);
    EXPECT_EQ(bytes.size(), kFrameOverhead + frame.payload.size());
    EXPECT_EQ(DecodeFrame(bytes), frame) << MessageTypeName(frame.type);
  }
}

TEST(SnpFrameTest, AppendEncodedFrameAppends) {
  std::vector<uint8_t> out = {1, 2};
  const Frame frame =
      MakeFrame(Address::Host(), Address::Bridge(), ResetSimulation{});
  AppendEncodedFrame(frame, out);
  ASSERT_EQ(out.size(), 2 + kFrameOverhead);
  EXPECT_EQ(std::vector<uint8_t>(out.begin() + 2, out.end()), EncodeFrame(frame));
}

TEST(SnpDecodeFrameTest, RejectsEmptyAndMissingStartByte) {
  EXPECT_EQ(DecodeFrameReason({}), "truncated frame: have 0 of at least 8 bytes");
  EXPECT_EQ(DecodeFrameReason(Bytes({0x00, 0xA5})),
            "missing start byte: first byte is 0x00, expected 0xa5");
}

TEST(SnpDecodeFrameTest, RejectsTruncatedFrame) {
  std::vector<uint8_t> bytes = EncodeFrame(
      MakeFrame(Address::Host(), Address::Module(3), SetLimits{-1.0f, 0.5f}));
  bytes.resize(5);
  EXPECT_EQ(DecodeFrameReason(bytes), "truncated frame: have 5 of 16 bytes");
  bytes.resize(1);
  EXPECT_EQ(DecodeFrameReason(bytes), "truncated frame: have 1 of at least 8 bytes");
}

TEST(SnpDecodeFrameTest, RejectsTrailingBytes) {
  std::vector<uint8_t> bytes =
      EncodeFrame(MakeFrame(Address::Host(), Address::Bridge(), GetSimTime{}));
  bytes.push_back(0);
  bytes.push_back(0);
  EXPECT_EQ(DecodeFrameReason(bytes), "2 trailing bytes after the 8-byte frame");
}

TEST(SnpDecodeFrameTest, RejectsBadCrc) {
  std::vector<uint8_t> bytes = EncodeFrame(
      MakeFrame(Address::Host(), Address::Module(3), SetLimits{-1.0f, 0.5f}));
  bytes[8] ^= 0x01;
  EXPECT_THAT(DecodeFrameReason(bytes),
              HasSubstr("CRC mismatch: frame has 0xbe7b, computed 0x"));
}

TEST(SnpDecodeFrameTest, RejectsOversizedLength) {
  std::vector<uint8_t> bytes(kMaxFrameSize + 1, 0);
  bytes[0] = kStartByte;
  bytes[1] = 241;
  EXPECT_EQ(DecodeFrameReason(bytes),
            "length 241 exceeds the maximum payload of 240 bytes");
}

TEST(SnpDecodeFrameTest, RejectsUnknownType) {
  std::vector<uint8_t> bytes = Bytes({0xA5, 0x00, 0x01, 0x00, 0x03, 0x7F, 0, 0});
  FixCrc(bytes);
  EXPECT_EQ(DecodeFrameReason(bytes), "unknown message type 0x7f");
  bytes[5] = 0x00;
  FixCrc(bytes);
  EXPECT_EQ(DecodeFrameReason(bytes), "unknown message type 0x00");
}

TEST(SnpDecodeFrameTest, RejectsWrongPayloadSize) {
  std::vector<uint8_t> bytes =
      Bytes({0xA5, 0x03, 0x01, 0x00, 0x03, 0x05, 1, 2, 3, 0, 0});
  FixCrc(bytes);
  EXPECT_EQ(DecodeFrameReason(bytes),
            "payload size 3 invalid for SetLimits: expects 8 bytes");
  std::vector<uint8_t> accel(kFrameOverhead + 7, 0);
  accel[0] = kStartByte;
  accel[1] = 7;
  accel[2] = 0x04;  // module 3 -> host
  accel[3] = 3;
  accel[5] = 0x0B;
  FixCrc(accel);
  EXPECT_EQ(DecodeFrameReason(accel),
            "payload size 7 invalid for Accelerometer: expects a multiple of 6 "
            "from 6 to 96 bytes");
  std::vector<uint8_t> error = Bytes({0xA5, 0x01, 0x06, 0x00, 0x00, 0x65, 0x40, 0, 0});
  FixCrc(error);
  EXPECT_EQ(DecodeFrameReason(error),
            "payload size 1 invalid for SpecialError: expects 2 to 240 bytes");
}

TEST(SnpDecodeFrameTest, RejectsBadAddressing) {
  auto reason_for = [](std::initializer_list<int> header) {
    std::vector<uint8_t> bytes = Bytes(header);
    bytes.push_back(0);
    bytes.push_back(0);
    FixCrc(bytes);
    return DecodeFrameReason(bytes);
  };
  EXPECT_EQ(reason_for({0xA5, 0, 0x11, 0, 3, 0x07}),
            "reserved flag bits set: flags 0x11");
  EXPECT_EQ(reason_for({0xA5, 0, 0x03, 0, 3, 0x07}),
            "reserved node kind 3 for the source in flags 0x03");
  EXPECT_EQ(reason_for({0xA5, 0, 0x0D, 0, 3, 0x07}),
            "reserved node kind 3 for the destination in flags 0x0d");
  EXPECT_EQ(reason_for({0xA5, 0, 0x00, 255, 3, 0x07}),
            "broadcast address 255 used as source");
  EXPECT_EQ(reason_for({0xA5, 0, 0x01, 9, 3, 0x07}),
            "source host address byte must be 0, got 9");
  EXPECT_EQ(reason_for({0xA5, 0, 0x09, 0, 4, 0x40}),
            "destination bridge address byte must be 0, got 4");
  EXPECT_EQ(reason_for({0xA5, 0, 0x01, 0, 3, 0x40}),
            "GetSimTime is a bridge command (host to bridge) but goes from the "
            "host to a module");
  EXPECT_EQ(reason_for({0xA5, 0, 0x02, 0, 3, 0x07}),
            "ClearCouplings is a module message but the source is the bridge");
  EXPECT_EQ(reason_for({0xA5, 0, 0x02, 0, 3, 0x60}),
            "SimTime is a bridge reply (bridge to host) but goes from the "
            "bridge to a module");
  // Module to host and module to module are fine for module messages.
  std::vector<uint8_t> module_to_host = Bytes({0xA5, 0, 0x04, 5, 0, 0x07, 0, 0});
  FixCrc(module_to_host);
  EXPECT_EQ(DecodeFrame(module_to_host).source, Address::Module(5));
  std::vector<uint8_t> module_to_module = Bytes({0xA5, 0, 0x00, 5, 6, 0x07, 0, 0});
  FixCrc(module_to_module);
  EXPECT_EQ(DecodeFrame(module_to_module).destination, Address::Module(6));
}

TEST(SnpValidateFrameTest, RejectsInvalidFramesOnEncode) {
  Frame frame;
  frame.source = Address::Host();
  frame.destination = Address::Module(3);
  frame.type = MessageType::kSetLimits;
  frame.payload = Payload(Bytes({1, 2, 3}));
  EXPECT_EQ(ValidateReason(frame),
            "payload size 3 invalid for SetLimits: expects 8 bytes");
  EXPECT_THROW(EncodeFrame(frame), Error);

  frame.type = static_cast<MessageType>(0x30);
  EXPECT_EQ(ValidateReason(frame), "unknown message type 0x30");

  frame.type = MessageType::kClearCouplings;
  frame.payload.Clear();
  frame.source = Address::Broadcast();
  EXPECT_EQ(ValidateReason(frame), "broadcast address 255 used as source");

  frame.source = {static_cast<NodeKind>(5), 0};
  EXPECT_EQ(ValidateReason(frame), "invalid source node kind 5");

  frame.source = Address::Host();
  frame.destination = Address::Bridge();
  EXPECT_EQ(ValidateReason(frame),
            "ClearCouplings is a module message but the destination is the "
            "bridge");

  frame.destination = Address::Module(3);
  EXPECT_NO_THROW(ValidateFrame(frame));
  std::vector<uint8_t> out = {9};
  frame.type = MessageType::kSetLimits;
  EXPECT_THROW(AppendEncodedFrame(frame, out), Error);
  EXPECT_EQ(out, Bytes({9})) << "a rejected frame must not be half-written";
}

TEST(SnpPayloadTest, CapacityIsEnforced) {
  Payload payload(std::vector<uint8_t>(kMaxPayloadSize, 7));
  EXPECT_EQ(payload.size(), kMaxPayloadSize);
  try {
    payload.PushBack(1);
    FAIL() << "overflow accepted";
  } catch (const Error& error) {
    EXPECT_EQ(error.code(), StatusCode::kInvalidArgument);
    EXPECT_THAT(error.what(), HasSubstr("payload would exceed 240 bytes"));
  }
  EXPECT_EQ(payload.size(), kMaxPayloadSize);
  EXPECT_THROW(Payload(std::vector<uint8_t>(kMaxPayloadSize + 1)), Error);
}

TEST(SnpPayloadTest, EqualityIgnoresUnusedCapacity) {
  Payload a(Bytes({1, 2, 3}));
  Payload b(Bytes({1, 2, 3, 4}));
  EXPECT_NE(a, b);
  b.Clear();
  b.Append(Bytes({1, 2, 3}));
  EXPECT_EQ(a, b);
}

TEST(SnpAddressTest, NamesAndBroadcast) {
  EXPECT_EQ(ToString(Address::Module(3)), "module 3");
  EXPECT_EQ(ToString(Address::Broadcast()), "broadcast");
  EXPECT_EQ(ToString(Address::Host()), "host");
  EXPECT_EQ(ToString(Address::Bridge()), "bridge");
  EXPECT_TRUE(Address::Broadcast().IsBroadcast());
  EXPECT_FALSE(Address::Module(254).IsBroadcast());
  EXPECT_NE(Address::Host(), Address::Module(0));
}

}  // namespace
}  // namespace yamor::snp
