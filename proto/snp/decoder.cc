#include "proto/snp/decoder.h"

#include <algorithm>
#include <cstring>
#include <numeric>

#include "common/status.h"
#include "proto/snp/frame_check.h"

namespace yamor::snp {

std::string_view DecodeErrorKindName(DecodeErrorKind kind) {
  switch (kind) {
    case DecodeErrorKind::kOversizedLength: return "oversized length";
    case DecodeErrorKind::kBadHeader: return "bad header";
    case DecodeErrorKind::kUnknownType: return "unknown type";
    case DecodeErrorKind::kBadPayloadSize: return "bad payload size";
    case DecodeErrorKind::kBadCrc: return "bad CRC";
    case DecodeErrorKind::kTruncated: return "truncated frame";
  }
  return "unknown error";
}

DecodeError::DecodeError(DecodeErrorKind kind, uint64_t offset,
                         std::string_view reason)
    : kind_(kind), offset_(offset) {
  reason_size_ =
      static_cast<uint8_t>(std::min(reason.size(), reason_.size()));
  std::copy_n(reason.begin(), reason_size_, reason_.begin());
}

uint64_t DecoderStats::TotalErrors() const {
  return std::accumulate(errors.begin(), errors.end(), uint64_t{0});
}

FrameDecoder::FrameDecoder() { buffer_.reserve(kMaxFrameSize); }

void FrameDecoder::Reset() {
  buffer_.clear();
  buffer_offset_ = 0;
  stats_ = DecoderStats{};
}

std::size_t FrameDecoder::Process(std::span<const uint8_t> data, uint64_t base,
                                  bool end_of_stream,
                                  std::vector<DecodeEvent>& events) {
  internal::ReasonText reason;
  std::size_t pos = 0;
  while (pos < data.size()) {
    const void* found =
        std::memchr(data.data() + pos, kStartByte, data.size() - pos);
    const std::size_t start =
        found ? static_cast<std::size_t>(static_cast<const uint8_t*>(found) -
                                         data.data())
              : data.size();
    stats_.skipped_bytes += start - pos;
    pos = start;
    if (pos == data.size()) break;

    const std::span<const uint8_t> candidate = data.subspan(pos);
    const internal::CandidateResult result =
        internal::CheckCandidate(candidate, reason);
    if (result.status == internal::CandidateStatus::kFrame) {
      events.emplace_back(
          DecodedFrame{internal::ParseCheckedFrame(candidate), base + pos});
      ++stats_.frames;
      stats_.frame_bytes += result.frame_size;
      pos += result.frame_size;
      continue;
    }
    DecodeErrorKind kind = result.error;
    if (result.status == internal::CandidateStatus::kNeedMore) {
      if (!end_of_stream) return pos;  // keep the candidate for more bytes
      internal::FormatTruncated(candidate, reason);
      kind = DecodeErrorKind::kTruncated;
    }
    events.emplace_back(std::in_place_type<DecodeError>, kind, base + pos,
                        reason.view());
    ++stats_.errors[static_cast<std::size_t>(kind)];
    // Resume right after the rejected start byte: a real frame may begin
    // inside the bytes the bad candidate claimed.
    ++stats_.skipped_bytes;
    ++pos;
  }
  return pos;
}

void FrameDecoder::Feed(std::span<const uint8_t> bytes,
                        std::vector<DecodeEvent>& events) {
  stats_.bytes_fed += bytes.size();
  if (buffer_.empty()) {
    // Common case: decode straight from the caller's bytes, keep the tail.
    const uint64_t base = buffer_offset_;
    const std::size_t consumed = Process(bytes, base, false, events);
    buffer_.assign(bytes.begin() + static_cast<std::ptrdiff_t>(consumed),
                   bytes.end());
    buffer_offset_ = base + consumed;
  } else {
    buffer_.insert(buffer_.end(), bytes.begin(), bytes.end());
    const std::size_t consumed = Process(buffer_, buffer_offset_, false, events);
    buffer_.erase(buffer_.begin(),
                  buffer_.begin() + static_cast<std::ptrdiff_t>(consumed));
    buffer_offset_ += consumed;
  }
  YAMOR_CHECK(buffer_.size() < kMaxFrameSize,
              "decoder buffers more than one incomplete frame");
}

std::vector<DecodeEvent> FrameDecoder::Feed(std::span<const uint8_t> bytes) {
  std::vector<DecodeEvent> events;
  Feed(bytes, events);
  return events;
}

void FrameDecoder::Flush(std::vector<DecodeEvent>& events) {
  const std::size_t consumed = Process(buffer_, buffer_offset_, true, events);
  YAMOR_CHECK(consumed == buffer_.size(), "flush left bytes buffered");
  buffer_offset_ += consumed;
  buffer_.clear();
}

std::vector<DecodeEvent> FrameDecoder::Flush() {
  std::vector<DecodeEvent> events;
  Flush(events);
  return events;
}

}  // namespace yamor::snp
