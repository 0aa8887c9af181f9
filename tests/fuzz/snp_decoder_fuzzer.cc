// libFuzzer target for the SNP decoders (proto/snp). Input: byte 0 seeds the
// chunk sizes, the rest is the byte stream. Checks, aborting on violation:
//  - the streaming decoder never crashes and gives the same events whether
//    fed in one piece or in chunks;
//  - every decoded frame re-encodes to exactly the bytes it came from;
//  - a frame whose message decodes re-encodes from the message to the same
//    bytes (payloads are canonical); decoding errors are INVALID_ARGUMENT;
//  - counters add up, nothing stays buffered after Flush;
//  - one-shot DecodeFrame accepts the stream only if it is one frame, and
//    then agrees with the streaming decoder.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <span>
#include <vector>

#include "common/status.h"
#include "proto/snp/snp.h"

namespace {

using namespace yamor::snp;  // NOLINT: fuzzer-local brevity

#define FUZZ_ASSERT(condition)                                            \
  do {                                                                    \
    if (!(condition)) {                                                   \
      std::fprintf(stderr, "snp_decoder_fuzzer: %s failed at line %d\n", \
                   #condition, __LINE__);                                 \
      std::abort();                                                       \
    }                                                                     \
  } while (false)

bool SameEvent(const DecodeEvent& a, const DecodeEvent& b) {
  if (a.index() != b.index()) return false;
  if (const auto* fa = std::get_if<DecodedFrame>(&a)) {
    const auto& fb = std::get<DecodedFrame>(b);
    return fa->offset == fb.offset && fa->frame == fb.frame;
  }
  const auto& ea = std::get<DecodeError>(a);
  const auto& eb = std::get<DecodeError>(b);
  return ea.kind() == eb.kind() && ea.offset() == eb.offset() &&
         ea.reason() == eb.reason();
}

void CheckFrame(const DecodedFrame& decoded, std::span<const uint8_t> stream) {
  const std::vector<uint8_t> bytes = EncodeFrame(decoded.frame);
  FUZZ_ASSERT(decoded.offset + bytes.size() <= stream.size());
  FUZZ_ASSERT(std::equal(bytes.begin(), bytes.end(),
                         stream.begin() + static_cast<std::ptrdiff_t>(decoded.offset)));
  FUZZ_ASSERT(DecodeFrame(bytes) == decoded.frame);
  try {
    const Message message = DecodeMessage(decoded.frame);
    FUZZ_ASSERT(TypeOf(message) == decoded.frame.type);
    const Frame again = MakeFrame(decoded.frame.source,
                                  decoded.frame.destination, message);
    FUZZ_ASSERT(EncodeFrame(again) == bytes);
  } catch (const yamor::Error& error) {
    FUZZ_ASSERT(error.code() == yamor::StatusCode::kInvalidArgument);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  uint32_t chunk_state = data[0];
  const std::span<const uint8_t> stream(data + 1, size - 1);

  FrameDecoder chunked;
  std::vector<DecodeEvent> events;
  for (std::size_t pos = 0; pos < stream.size();) {
    chunk_state = chunk_state * 1103515245u + 12345u;
    const std::size_t chunk =
        std::min<std::size_t>((chunk_state >> 16) % 300, stream.size() - pos);
    chunked.Feed(stream.subspan(pos, chunk), events);
    pos += chunk;
  }
  chunked.Flush(events);
  FUZZ_ASSERT(!chunked.HasPartialFrame());

  FrameDecoder whole;
  std::vector<DecodeEvent> whole_events = whole.Feed(stream);
  whole.Flush(whole_events);
  FUZZ_ASSERT(whole_events.size() == events.size());
  for (std::size_t i = 0; i < events.size(); ++i) {
    FUZZ_ASSERT(SameEvent(events[i], whole_events[i]));
  }

  std::size_t frames = 0;
  for (const DecodeEvent& event : events) {
    if (const auto* decoded = std::get_if<DecodedFrame>(&event)) {
      ++frames;
      CheckFrame(*decoded, stream);
    } else {
      const auto& error = std::get<DecodeError>(event);
      FUZZ_ASSERT(error.offset() < stream.size());
      FUZZ_ASSERT(stream[error.offset()] == kStartByte);
      FUZZ_ASSERT(!error.reason().empty());
    }
  }
  const DecoderStats& stats = chunked.stats();
  FUZZ_ASSERT(stats.bytes_fed == stream.size());
  FUZZ_ASSERT(stats.frame_bytes + stats.skipped_bytes == stream.size());
  FUZZ_ASSERT(stats.frames == frames);
  FUZZ_ASSERT(stats.TotalErrors() == events.size() - frames);

  try {
    const Frame frame = DecodeFrame(stream);
    FUZZ_ASSERT(EncodeFrame(frame) == std::vector<uint8_t>(stream.begin(), stream.end()));
    FUZZ_ASSERT(frames >= 1);
    const auto* first = std::get_if<DecodedFrame>(&events.front());
    FUZZ_ASSERT(first != nullptr && first->offset == 0 && first->frame == frame);
  } catch (const yamor::Error& error) {
    FUZZ_ASSERT(error.code() == yamor::StatusCode::kInvalidArgument);
  }
  return 0;
}
