// Internal: the one frame-candidate check shared by DecodeFrame, ValidateFrame
// and FrameDecoder, so every entry point rejects the same bytes with the same
// reason. Not part of the public API.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

#include <fmt/format.h>

#include "proto/snp/decoder.h"

namespace yamor::snp::internal {

/// A fixed-capacity reason text (formatting never allocates).
class ReasonText {
 public:
  /// Replaces the text with the formatted string (cut at capacity).
  template <class... Args>
  void Format(fmt::format_string<Args...> format, Args&&... args) {
    const auto result = fmt::format_to_n(text_.data(), text_.size(), format,
                                         std::forward<Args>(args)...);
    size_ = result.size < text_.size() ? result.size : text_.size();
  }
  /// The text.
  std::string_view view() const { return {text_.data(), size_}; }

 private:
  std::array<char, DecodeError::kMaxReasonSize> text_{};
  std::size_t size_ = 0;
};

/// Outcome of checking the bytes at a start byte.
enum class CandidateStatus { kNeedMore, kError, kFrame };

/// Result of CheckCandidate.
struct CandidateResult {
  CandidateStatus status = CandidateStatus::kNeedMore;  ///< Outcome.
  DecodeErrorKind error = DecodeErrorKind::kTruncated;  ///< For kError.
  std::size_t frame_size = 0;  ///< Total frame size once the length is known.
};

/// Checks `bytes` (bytes[0] is a start byte; more bytes may follow the
/// candidate). Rules are checked in byte order, each only once the bytes it
/// needs are present, so the verdict never depends on how many bytes are
/// available beyond the first failing rule. On kError `reason` is set.
CandidateResult CheckCandidate(std::span<const uint8_t> bytes,
                               ReasonText& reason);

/// Writes the truncation reason for an incomplete candidate of `have` bytes.
void FormatTruncated(std::span<const uint8_t> have, ReasonText& reason);

/// Writes "payload size N invalid for T: expects ..." for `rule`.
void FormatSizeRule(const PayloadSizeRule& rule, std::size_t size,
                    std::string_view type_name, ReasonText& reason);

/// Builds a Frame from bytes already accepted by CheckCandidate.
Frame ParseCheckedFrame(std::span<const uint8_t> bytes);

}  // namespace yamor::snp::internal
