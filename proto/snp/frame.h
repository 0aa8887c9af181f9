// SNP frames: addresses, the fixed-capacity payload, the CRC, and encoding /
// one-shot decoding of a single frame. Byte layout: docs/snp.md.
//
//   offset 0      1       2      3       4            5     6..6+L-1  6+L..7+L
//          start  length  flags  source  destination  type  payload   CRC-16 (LE)
//
// Thread-safety: every function here is pure (no shared state) and safe to
// call from any thread; the value types have no internal synchronisation.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "proto/snp/message_type.h"

namespace yamor::snp {

/// First byte of every frame.
inline constexpr uint8_t kStartByte = 0xA5;
/// Largest payload in bytes (the length byte's maximum).
inline constexpr std::size_t kMaxPayloadSize = 240;
/// Bytes before the payload: start, length, flags, source, destination, type.
inline constexpr std::size_t kHeaderSize = 6;
/// Bytes of the trailing CRC.
inline constexpr std::size_t kCrcSize = 2;
/// Header plus CRC: the size of a frame with an empty payload.
inline constexpr std::size_t kFrameOverhead = kHeaderSize + kCrcSize;
/// Largest frame in bytes.
inline constexpr std::size_t kMaxFrameSize = kFrameOverhead + kMaxPayloadSize;
/// Highest module id; module ids are 0..254.
inline constexpr uint8_t kMaxModuleId = 254;
/// Module address byte meaning "every module" (destination only).
inline constexpr uint8_t kBroadcastId = 255;

/// What kind of node an address names (two bits of the flags byte each for
/// source and destination; kind 3 is reserved and rejected).
enum class NodeKind : uint8_t {
  kModule = 0,  ///< A module; the address byte is its id (255 = broadcast).
  kHost = 1,    ///< The host (driver); the address byte must be 0.
  kBridge = 2,  ///< The simulation bridge; the address byte must be 0.
};

/// A frame endpoint. Host and bridge live outside the one-byte module id
/// space, so all 255 module ids stay usable.
struct Address {
  NodeKind kind = NodeKind::kModule;  ///< Kind of node.
  uint8_t id = 0;  ///< Module id 0..254 or kBroadcastId; 0 for host/bridge.

  /// The module with `module_id` (0..254; 255 is the broadcast address).
  static constexpr Address Module(uint8_t module_id) {
    return {NodeKind::kModule, module_id};
  }
  /// Every module (valid as destination only).
  static constexpr Address Broadcast() {
    return {NodeKind::kModule, kBroadcastId};
  }
  /// The host.
  static constexpr Address Host() { return {NodeKind::kHost, 0}; }
  /// The simulation bridge.
  static constexpr Address Bridge() { return {NodeKind::kBridge, 0}; }

  /// True for the module broadcast address.
  constexpr bool IsBroadcast() const {
    return kind == NodeKind::kModule && id == kBroadcastId;
  }
  friend bool operator==(const Address&, const Address&) = default;
};

/// "module 3", "broadcast", "host" or "bridge" (for logs and errors).
std::string ToString(const Address& address);

/// A payload of up to kMaxPayloadSize bytes stored inline, so frames never
/// allocate. Thread-safety: a plain value; no internal synchronisation.
class Payload {
 public:
  /// An empty payload.
  Payload() = default;
  /// A copy of `bytes`; throws yamor::Error(INVALID_ARGUMENT) above 240 bytes.
  explicit Payload(std::span<const uint8_t> bytes);

  /// Appends `bytes`; throws yamor::Error(INVALID_ARGUMENT) if the payload
  /// would exceed kMaxPayloadSize (the payload is then unchanged).
  void Append(std::span<const uint8_t> bytes);
  /// Appends one byte (same overflow rule as Append).
  void PushBack(uint8_t byte);
  /// Removes every byte.
  void Clear() { size_ = 0; }

  /// The stored bytes.
  std::span<const uint8_t> bytes() const { return {bytes_.data(), size_}; }
  /// Pointer to the first byte.
  const uint8_t* data() const { return bytes_.data(); }
  /// Number of bytes.
  std::size_t size() const { return size_; }
  /// True when there are no bytes.
  bool empty() const { return size_ == 0; }

  /// Byte-wise equality of the stored bytes.
  friend bool operator==(const Payload& a, const Payload& b);

 private:
  std::array<uint8_t, kMaxPayloadSize> bytes_{};
  uint8_t size_ = 0;
};

/// One frame: header fields plus raw payload. A Frame produced by
/// DecodeFrame, FrameDecoder or MakeFrame is always valid (see ValidateFrame).
struct Frame {
  Address source;       ///< Sender.
  Address destination;  ///< Receiver (may be broadcast for module messages).
  MessageType type = MessageType::kAck;  ///< Message type.
  Payload payload;      ///< Payload bytes (layout depends on `type`).

  friend bool operator==(const Frame&, const Frame&) = default;
};

/// CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, no reflection, no final
/// xor) of `bytes`; "123456789" gives 0x29B1.
uint16_t Crc16CcittFalse(std::span<const uint8_t> bytes);

/// Throws yamor::Error(INVALID_ARGUMENT) with the reason if `frame` breaks a
/// framing rule: unknown type, payload size not allowed for the type,
/// broadcast or non-zero host/bridge address bytes, or endpoints that do not
/// fit the type's class (bridge commands go host -> bridge, bridge replies
/// bridge -> host, module messages never involve the bridge).
void ValidateFrame(const Frame& frame);

/// Appends the wire bytes of `frame` to `out` (validating it first; throws
/// yamor::Error(INVALID_ARGUMENT) and leaves `out` unchanged if invalid).
void AppendEncodedFrame(const Frame& frame, std::vector<uint8_t>& out);

/// The wire bytes of `frame` (validated; throws like AppendEncodedFrame).
std::vector<uint8_t> EncodeFrame(const Frame& frame);

/// Decodes exactly one frame occupying all of `bytes`; throws
/// yamor::Error(INVALID_ARGUMENT) naming the reason (missing start byte,
/// truncated frame, trailing bytes, oversized length, bad header, unknown
/// type, wrong payload size, CRC mismatch).
Frame DecodeFrame(std::span<const uint8_t> bytes);

}  // namespace yamor::snp
