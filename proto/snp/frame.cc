#include "proto/snp/frame.h"

#include <algorithm>
#include <string>

#include "common/status.h"
#include "proto/snp/frame_check.h"

namespace yamor::snp {

namespace {

constexpr uint8_t kReservedFlagBits = 0xF0;
constexpr uint8_t kKindMask = 0x03;
constexpr int kDestinationKindShift = 2;

constexpr std::array<uint16_t, 256> MakeCrcTable() {
  std::array<uint16_t, 256> table{};
  for (unsigned byte = 0; byte < 256; ++byte) {
    uint16_t crc = static_cast<uint16_t>(byte << 8);
    for (int bit = 0; bit < 8; ++bit) {
      crc = (crc & 0x8000) ? static_cast<uint16_t>((crc << 1) ^ 0x1021)
                           : static_cast<uint16_t>(crc << 1);
    }
    table[byte] = crc;
  }
  return table;
}

constexpr std::array<uint16_t, 256> kCrcTable = MakeCrcTable();

std::string_view KindPhrase(uint8_t kind) {
  switch (static_cast<NodeKind>(kind)) {
    case NodeKind::kModule: return "a module";
    case NodeKind::kHost: return "the host";
    case NodeKind::kBridge: return "the bridge";
  }
  return "an invalid node";
}

std::string_view KindName(uint8_t kind) {
  switch (static_cast<NodeKind>(kind)) {
    case NodeKind::kModule: return "module";
    case NodeKind::kHost: return "host";
    case NodeKind::kBridge: return "bridge";
  }
  return "invalid";
}

uint8_t FlagsOf(const Frame& frame) {
  return static_cast<uint8_t>(
      static_cast<uint8_t>(frame.source.kind) |
      (static_cast<uint8_t>(frame.destination.kind) << kDestinationKindShift));
}

// The six header bytes of a frame whose fields are known to fit in a byte.
std::array<uint8_t, kHeaderSize> HeaderOf(const Frame& frame) {
  return {kStartByte, static_cast<uint8_t>(frame.payload.size()),
          FlagsOf(frame), frame.source.id, frame.destination.id,
          static_cast<uint8_t>(frame.type)};
}

[[noreturn]] void ThrowInvalid(std::string_view reason) {
  throw Error(StatusCode::kInvalidArgument, std::string(reason));
}

// Checks the class rule: who may send a type to whom.
bool EndpointsFit(MessageClass message_class, uint8_t source_kind,
                  uint8_t destination_kind, internal::ReasonText& reason,
                  std::string_view type_name) {
  const auto bridge = static_cast<uint8_t>(NodeKind::kBridge);
  const auto host = static_cast<uint8_t>(NodeKind::kHost);
  switch (message_class) {
    case MessageClass::kModule:
      if (source_kind == bridge || destination_kind == bridge) {
        reason.Format("{} is a module message but the {} is the bridge",
                      type_name,
                      source_kind == bridge ? "source" : "destination");
        return false;
      }
      return true;
    case MessageClass::kBridgeCommand:
      if (source_kind != host || destination_kind != bridge) {
        reason.Format(
            "{} is a bridge command (host to bridge) but goes from {} to {}",
            type_name, KindPhrase(source_kind), KindPhrase(destination_kind));
        return false;
      }
      return true;
    case MessageClass::kBridgeReply:
      if (source_kind != bridge || destination_kind != host) {
        reason.Format(
            "{} is a bridge reply (bridge to host) but goes from {} to {}",
            type_name, KindPhrase(source_kind), KindPhrase(destination_kind));
        return false;
      }
      return true;
  }
  return false;
}

}  // namespace

std::string ToString(const Address& address) {
  switch (address.kind) {
    case NodeKind::kModule:
      return address.IsBroadcast() ? "broadcast"
                                   : "module " + std::to_string(address.id);
    case NodeKind::kHost: return "host";
    case NodeKind::kBridge: return "bridge";
  }
  return "invalid address kind " +
         std::to_string(static_cast<int>(address.kind));
}

Payload::Payload(std::span<const uint8_t> bytes) { Append(bytes); }

void Payload::Append(std::span<const uint8_t> bytes) {
  if (bytes.size() > kMaxPayloadSize - size_) {
    throw Error(StatusCode::kInvalidArgument,
                "payload would exceed " + std::to_string(kMaxPayloadSize) +
                    " bytes: has " + std::to_string(size_) + ", adding " +
                    std::to_string(bytes.size()));
  }
  std::copy(bytes.begin(), bytes.end(), bytes_.begin() + size_);
  size_ = static_cast<uint8_t>(size_ + bytes.size());
}

void Payload::PushBack(uint8_t byte) { Append(std::span(&byte, 1)); }

bool operator==(const Payload& a, const Payload& b) {
  return std::ranges::equal(a.bytes(), b.bytes());
}

uint16_t Crc16CcittFalse(std::span<const uint8_t> bytes) {
  uint16_t crc = 0xFFFF;
  for (const uint8_t byte : bytes) {
    crc = static_cast<uint16_t>((crc << 8) ^ kCrcTable[(crc >> 8) ^ byte]);
  }
  return crc;
}

namespace internal {

void FormatSizeRule(const PayloadSizeRule& rule, std::size_t size,
                    std::string_view type_name, ReasonText& reason) {
  if (rule.min == rule.max) {
    reason.Format("payload size {} invalid for {}: expects {} bytes", size,
                  type_name, rule.min);
  } else if (rule.step == 1) {
    reason.Format("payload size {} invalid for {}: expects {} to {} bytes",
                  size, type_name, rule.min, rule.max);
  } else {
    reason.Format(
        "payload size {} invalid for {}: expects a multiple of {} from {} to "
        "{} bytes",
        size, type_name, rule.step, rule.min, rule.max);
  }
}

CandidateResult CheckCandidate(std::span<const uint8_t> bytes,
                               ReasonText& reason) {
  YAMOR_CHECK(!bytes.empty() && bytes[0] == kStartByte,
              "CheckCandidate needs a start byte first");
  CandidateResult result;
  const std::size_t have = bytes.size();
  auto fail = [&result](DecodeErrorKind kind) {
    result.status = CandidateStatus::kError;
    result.error = kind;
    return result;
  };
  // Each rule runs only once its bytes are present, in byte order.
  if (have < 2) return result;
  const std::size_t length = bytes[1];
  result.frame_size = kFrameOverhead + length;
  if (length > kMaxPayloadSize) {
    reason.Format("length {} exceeds the maximum payload of {} bytes", length,
                  kMaxPayloadSize);
    return fail(DecodeErrorKind::kOversizedLength);
  }

  if (have < 3) return result;
  const uint8_t flags = bytes[2];
  const uint8_t source_kind = flags & kKindMask;
  const uint8_t destination_kind = (flags >> kDestinationKindShift) & kKindMask;
  if ((flags & kReservedFlagBits) != 0) {
    reason.Format("reserved flag bits set: flags 0x{:02x}", flags);
    return fail(DecodeErrorKind::kBadHeader);
  }
  if (source_kind == kKindMask || destination_kind == kKindMask) {
    reason.Format("reserved node kind 3 for the {} in flags 0x{:02x}",
                  source_kind == kKindMask ? "source" : "destination", flags);
    return fail(DecodeErrorKind::kBadHeader);
  }

  if (have < 4) return result;
  const uint8_t source_id = bytes[3];
  if (source_kind == static_cast<uint8_t>(NodeKind::kModule)) {
    if (source_id == kBroadcastId) {
      reason.Format("broadcast address {} used as source", kBroadcastId);
      return fail(DecodeErrorKind::kBadHeader);
    }
  } else if (source_id != 0) {
    reason.Format("source {} address byte must be 0, got {}",
                  KindName(source_kind), source_id);
    return fail(DecodeErrorKind::kBadHeader);
  }

  if (have < 5) return result;
  const uint8_t destination_id = bytes[4];
  if (destination_kind != static_cast<uint8_t>(NodeKind::kModule) &&
      destination_id != 0) {
    reason.Format("destination {} address byte must be 0, got {}",
                  KindName(destination_kind), destination_id);
    return fail(DecodeErrorKind::kBadHeader);
  }

  if (have < 6) return result;
  const uint8_t type_code = bytes[5];
  if (!IsKnownMessageType(type_code)) {
    reason.Format("unknown message type 0x{:02x}", type_code);
    return fail(DecodeErrorKind::kUnknownType);
  }
  const auto type = static_cast<MessageType>(type_code);
  const std::string_view type_name = MessageTypeName(type);
  if (!EndpointsFit(ClassOf(type), source_kind, destination_kind, reason,
                    type_name)) {
    return fail(DecodeErrorKind::kBadHeader);
  }
  const PayloadSizeRule rule = PayloadSizeRuleOf(type);
  if (!rule.Allows(length)) {
    FormatSizeRule(rule, length, type_name, reason);
    return fail(DecodeErrorKind::kBadPayloadSize);
  }

  if (have < result.frame_size) return result;
  const std::size_t crc_at = kHeaderSize + length;
  const uint16_t computed = Crc16CcittFalse(bytes.subspan(1, crc_at - 1));
  const uint16_t carried =
      static_cast<uint16_t>(bytes[crc_at] | (bytes[crc_at + 1] << 8));
  if (computed != carried) {
    reason.Format("CRC mismatch: frame has 0x{:04x}, computed 0x{:04x}",
                  carried, computed);
    return fail(DecodeErrorKind::kBadCrc);
  }
  result.status = CandidateStatus::kFrame;
  return result;
}

void FormatTruncated(std::span<const uint8_t> have, ReasonText& reason) {
  if (have.size() < 2) {
    reason.Format("truncated frame: have {} of at least {} bytes", have.size(),
                  kFrameOverhead);
  } else {
    reason.Format("truncated frame: have {} of {} bytes", have.size(),
                  kFrameOverhead + have[1]);
  }
}

Frame ParseCheckedFrame(std::span<const uint8_t> bytes) {
  const uint8_t flags = bytes[2];
  Frame frame;
  frame.source = {static_cast<NodeKind>(flags & kKindMask), bytes[3]};
  frame.destination = {
      static_cast<NodeKind>((flags >> kDestinationKindShift) & kKindMask),
      bytes[4]};
  frame.type = static_cast<MessageType>(bytes[5]);
  frame.payload = Payload(bytes.subspan(kHeaderSize, bytes[1]));
  return frame;
}

}  // namespace internal

void ValidateFrame(const Frame& frame) {
  internal::ReasonText reason;
  for (const auto& [address, role] :
       {std::pair{frame.source, "source"},
        std::pair{frame.destination, "destination"}}) {
    const auto kind = static_cast<uint8_t>(address.kind);
    if (kind > static_cast<uint8_t>(NodeKind::kBridge)) {
      reason.Format("invalid {} node kind {}", role, kind);
      ThrowInvalid(reason.view());
    }
  }
  const auto header = HeaderOf(frame);
  const internal::CandidateResult result =
      internal::CheckCandidate(header, reason);
  if (result.status == internal::CandidateStatus::kError) {
    ThrowInvalid(reason.view());
  }
}

void AppendEncodedFrame(const Frame& frame, std::vector<uint8_t>& out) {
  ValidateFrame(frame);
  const auto header = HeaderOf(frame);
  const std::size_t begin = out.size();
  out.reserve(begin + kFrameOverhead + frame.payload.size());
  out.insert(out.end(), header.begin(), header.end());
  out.insert(out.end(), frame.payload.bytes().begin(),
             frame.payload.bytes().end());
  const uint16_t crc =
      Crc16CcittFalse(std::span(out).subspan(begin + 1));
  out.push_back(static_cast<uint8_t>(crc & 0xFF));
  out.push_back(static_cast<uint8_t>(crc >> 8));
}

std::vector<uint8_t> EncodeFrame(const Frame& frame) {
  std::vector<uint8_t> out;
  AppendEncodedFrame(frame, out);
  return out;
}

Frame DecodeFrame(std::span<const uint8_t> bytes) {
  internal::ReasonText reason;
  if (bytes.empty()) {
    internal::FormatTruncated(bytes, reason);
    ThrowInvalid(reason.view());
  }
  if (bytes[0] != kStartByte) {
    reason.Format("missing start byte: first byte is 0x{:02x}, expected 0x{:02x}",
                  bytes[0], kStartByte);
    ThrowInvalid(reason.view());
  }
  const internal::CandidateResult result =
      internal::CheckCandidate(bytes, reason);
  switch (result.status) {
    case internal::CandidateStatus::kNeedMore:
      internal::FormatTruncated(bytes, reason);
      ThrowInvalid(reason.view());
    case internal::CandidateStatus::kError:
      ThrowInvalid(reason.view());
    case internal::CandidateStatus::kFrame:
      break;
  }
  if (bytes.size() > result.frame_size) {
    reason.Format("{} trailing bytes after the {}-byte frame",
                  bytes.size() - result.frame_size, result.frame_size);
    ThrowInvalid(reason.view());
  }
  return internal::ParseCheckedFrame(bytes);
}

}  // namespace yamor::snp
