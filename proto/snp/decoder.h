// The streaming SNP frame decoder: fed arbitrary byte chunks from a serial
// line or socket, it yields complete frames and reports rejected candidates
// with a reason, resynchronising on the next start byte.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>
#include <variant>
#include <vector>

#include "proto/snp/frame.h"

namespace yamor::snp {

/// Why a frame candidate (a start byte and what follows) was rejected.
enum class DecodeErrorKind : uint8_t {
  kOversizedLength = 0,  ///< Length byte above kMaxPayloadSize.
  kBadHeader = 1,        ///< Reserved flag bits, bad address, wrong endpoints.
  kUnknownType = 2,      ///< Type byte is not a known MessageType.
  kBadPayloadSize = 3,   ///< Length not allowed for the message type.
  kBadCrc = 4,           ///< CRC mismatch.
  kTruncated = 5,        ///< Stream ended inside the candidate (Flush only).
};

/// Number of DecodeErrorKind values.
inline constexpr std::size_t kDecodeErrorKindCount = 6;

/// Short name of a kind ("bad CRC", "truncated frame", ...).
std::string_view DecodeErrorKindName(DecodeErrorKind kind);

/// A rejected candidate. The reason text is stored inline (no allocation).
/// Thread-safety: a plain value; no internal synchronisation.
class DecodeError {
 public:
  /// Maximum stored reason length; longer reasons are cut.
  static constexpr std::size_t kMaxReasonSize = 119;

  /// An error of `kind` for the candidate starting at stream `offset`.
  DecodeError(DecodeErrorKind kind, uint64_t offset, std::string_view reason);

  /// The kind of rejection.
  DecodeErrorKind kind() const { return kind_; }
  /// Stream offset (bytes fed before it) of the candidate's start byte.
  uint64_t offset() const { return offset_; }
  /// Human-readable reason, e.g. "CRC mismatch: frame has 0x1234, computed 0xabcd".
  std::string_view reason() const { return {reason_.data(), reason_size_}; }

 private:
  DecodeErrorKind kind_;
  uint8_t reason_size_ = 0;
  uint64_t offset_ = 0;
  std::array<char, kMaxReasonSize> reason_{};
};

/// A decoded frame and where it started in the stream.
struct DecodedFrame {
  Frame frame;          ///< The frame (always valid, see ValidateFrame).
  uint64_t offset = 0;  ///< Stream offset of its start byte.
};

/// One output of the decoder.
using DecodeEvent = std::variant<DecodedFrame, DecodeError>;

/// Running counters of a decoder (since construction or Reset).
struct DecoderStats {
  uint64_t bytes_fed = 0;      ///< Bytes passed to Feed.
  uint64_t frames = 0;         ///< Frames decoded.
  uint64_t frame_bytes = 0;    ///< Bytes inside decoded frames.
  uint64_t skipped_bytes = 0;  ///< Bytes consumed outside decoded frames.
  /// Rejections per DecodeErrorKind (indexed by its value).
  std::array<uint64_t, kDecodeErrorKindCount> errors{};

  /// Rejections of `kind`.
  uint64_t ErrorCount(DecodeErrorKind kind) const {
    return errors[static_cast<std::size_t>(kind)];
  }
  /// Rejections of every kind.
  uint64_t TotalErrors() const;
};

/// Streaming decoder. Bytes go through Feed in chunks of any size; frames
/// split across chunks and several frames per chunk decode alike, and the
/// events do not depend on how the stream was chunked. Bytes before a start
/// byte are skipped. A rejected candidate is reported and the search resumes
/// at the byte after its start byte, so a frame hidden inside garbage is
/// still found. At most one partial candidate (< kMaxFrameSize bytes) is
/// buffered between calls; steady-state decoding does not allocate once
/// the caller's event vector has grown.
/// Thread-safety: not thread-safe; use one decoder per stream and thread.
class FrameDecoder {
 public:
  /// An empty decoder at stream offset 0.
  FrameDecoder();

  /// Consumes `bytes`, appending events in stream order to `events` (which
  /// is not cleared). A candidate still incomplete stays buffered.
  void Feed(std::span<const uint8_t> bytes, std::vector<DecodeEvent>& events);
  /// As above, returning the events of this call.
  std::vector<DecodeEvent> Feed(std::span<const uint8_t> bytes);

  /// End of stream: a buffered incomplete candidate is reported as
  /// kTruncated ("truncated frame: have N of M bytes") and the bytes after
  /// its start byte are searched again, so nothing stays buffered. Later
  /// Feed calls continue the stream offsets.
  void Flush(std::vector<DecodeEvent>& events);
  /// As above, returning the events of this call.
  std::vector<DecodeEvent> Flush();

  /// True when an incomplete frame candidate is buffered.
  bool HasPartialFrame() const { return !buffer_.empty(); }
  /// Number of buffered bytes (all belong to the incomplete candidate).
  std::size_t BufferedBytes() const { return buffer_.size(); }
  /// Counters since construction or the last Reset.
  const DecoderStats& stats() const { return stats_; }

  /// Drops buffered bytes and counters; offsets restart at 0.
  void Reset();

 private:
  // Decodes from data (starting at stream offset `base`); returns how many
  // leading bytes were consumed. Unconsumed bytes form one incomplete
  // candidate (or none at end of stream).
  std::size_t Process(std::span<const uint8_t> data, uint64_t base,
                      bool end_of_stream, std::vector<DecodeEvent>& events);

  std::vector<uint8_t> buffer_;  // the incomplete candidate, if any
  uint64_t buffer_offset_ = 0;   // stream offset of buffer_[0]
  DecoderStats stats_;
};

}  // namespace yamor::snp
