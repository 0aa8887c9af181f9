// Streaming decoder tests: chunking, resynchronisation, rejection reasons,
// truncation, counters, and seeded fuzz-style properties.
#include "proto/snp/decoder.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "proto/snp/messages.h"
#include "tests/proto/snp/test_messages.h"

namespace yamor::snp {
namespace {

using testing::AddressedMessage;
using testing::EncodeMessage;

// A comparable digest of an event.
struct Summary {
  bool is_frame = false;
  uint64_t offset = 0;
  DecodeErrorKind kind = DecodeErrorKind::kTruncated;
  std::string text;  // reason, or the frame's bytes

  friend bool operator==(const Summary&, const Summary&) = default;
  friend std::ostream& operator<<(std::ostream& os, const Summary& s) {
    return os << (s.is_frame ? "frame@" : "error@") << s.offset << " "
              << (s.is_frame ? std::to_string(s.text.size()) + " bytes" : s.text);
  }
};

std::vector<Summary> Summarize(const std::vector<DecodeEvent>& events) {
  std::vector<Summary> out;
  for (const DecodeEvent& event : events) {
    if (const auto* frame = std::get_if<DecodedFrame>(&event)) {
      const std::vector<uint8_t> bytes = EncodeFrame(frame->frame);
      out.push_back({true, frame->offset, DecodeErrorKind::kTruncated,
                     std::string(bytes.begin(), bytes.end())});
    } else {
      const auto& error = std::get<DecodeError>(event);
      out.push_back({false, error.offset(), error.kind(), std::string(error.reason())});
    }
  }
  return out;
}

Summary FrameAt(uint64_t offset, const std::vector<uint8_t>& bytes) {
  return {true, offset, DecodeErrorKind::kTruncated, std::string(bytes.begin(), bytes.end())};
}

Summary ErrorAt(uint64_t offset, DecodeErrorKind kind, std::string reason) {
  return {false, offset, kind, std::move(reason)};
}

// Feeds `stream` in chunks of the given sizes (the last chunk takes the
// rest), then flushes.
std::vector<DecodeEvent> DecodeInChunks(const std::vector<uint8_t>& stream,
                                        const std::vector<std::size_t>& chunks,
                                        FrameDecoder* decoder_out = nullptr) {
  FrameDecoder local;
  FrameDecoder& decoder = decoder_out ? *decoder_out : local;
  std::vector<DecodeEvent> events;
  std::size_t pos = 0;
  for (std::size_t chunk : chunks) {
    chunk = std::min(chunk, stream.size() - pos);
    decoder.Feed(std::span(stream).subspan(pos, chunk), events);
    pos += chunk;
    const DecoderStats& stats = decoder.stats();
    EXPECT_EQ(stats.frame_bytes + stats.skipped_bytes + decoder.BufferedBytes(),
              stats.bytes_fed);
  }
  decoder.Feed(std::span(stream).subspan(pos), events);
  decoder.Flush(events);
  EXPECT_FALSE(decoder.HasPartialFrame());
  return events;
}

std::vector<DecodeEvent> DecodeWhole(const std::vector<uint8_t>& stream) {
  return DecodeInChunks(stream, {});
}

std::vector<DecodeEvent> DecodeByteByByte(const std::vector<uint8_t>& stream) {
  return DecodeInChunks(stream, std::vector<std::size_t>(stream.size(), 1));
}

std::vector<DecodeEvent> DecodeRandomChunks(const std::vector<uint8_t>& stream,
                                            std::mt19937_64& rng) {
  std::vector<std::size_t> chunks;
  for (std::size_t total = 0; total < stream.size();) {
    chunks.push_back(rng() % 70);  // zero-size chunks included
    total += chunks.back();
  }
  return DecodeInChunks(stream, chunks);
}

std::vector<uint8_t> Frame1() {
  return EncodeMessage({Address::Host(), Address::Module(3), SetLimits{-1.0f, 0.5f}});
}

std::vector<uint8_t> Frame2() {
  Accelerometer accel;
  for (int i = 0; i < 16; ++i) accel.samples.push_back({int16_t(i), 512, 1023});
  return EncodeMessage({Address::Module(3), Address::Host(), accel});
}

std::vector<uint8_t> Frame3() {
  return EncodeMessage({Address::Bridge(), Address::Host(),
                        SpecialError{MessageType::kConnectModules,
                                     StatusCode::kUnimplemented,
                                     "manual assembly required"}});
}

std::vector<uint8_t> Concat(std::initializer_list<std::vector<uint8_t>> parts) {
  std::vector<uint8_t> out;
  for (const auto& part : parts) out.insert(out.end(), part.begin(), part.end());
  return out;
}

std::vector<uint8_t> WithCrc(std::vector<uint8_t> frame) {
  const uint16_t crc = Crc16CcittFalse(std::span(frame).subspan(1, frame.size() - 3));
  frame[frame.size() - 2] = static_cast<uint8_t>(crc & 0xFF);
  frame[frame.size() - 1] = static_cast<uint8_t>(crc >> 8);
  return frame;
}

TEST(SnpFrameDecoderTest, DecodesOneFrame) {
  FrameDecoder decoder;
  const std::vector<uint8_t> bytes = Frame1();
  const std::vector<DecodeEvent> events = decoder.Feed(bytes);
  ASSERT_EQ(events.size(), 1u);
  const auto& decoded = std::get<DecodedFrame>(events[0]);
  EXPECT_EQ(decoded.offset, 0u);
  EXPECT_EQ(decoded.frame.source, Address::Host());
  EXPECT_EQ(decoded.frame.destination, Address::Module(3));
  EXPECT_EQ(DecodeMessage(decoded.frame), Message(SetLimits{-1.0f, 0.5f}));
  EXPECT_FALSE(decoder.HasPartialFrame());
  EXPECT_EQ(decoder.stats().frames, 1u);
  EXPECT_EQ(decoder.stats().frame_bytes, bytes.size());
  EXPECT_EQ(decoder.stats().skipped_bytes, 0u);
  EXPECT_EQ(decoder.stats().TotalErrors(), 0u);
}

TEST(SnpFrameDecoderTest, DecodesSeveralFramesInOneRead) {
  std::vector<uint8_t> stream;
  std::vector<Summary> expected;
  for (const AddressedMessage& sample : testing::SampleMessages()) {
    const std::vector<uint8_t> bytes = EncodeMessage(sample);
    expected.push_back(FrameAt(stream.size(), bytes));
    stream.insert(stream.end(), bytes.begin(), bytes.end());
  }
  FrameDecoder decoder;
  std::vector<DecodeEvent> events;
  decoder.Feed(stream, events);
  EXPECT_FALSE(decoder.HasPartialFrame());
  EXPECT_EQ(Summarize(events), expected);
  EXPECT_EQ(decoder.stats().frames, expected.size());
  EXPECT_EQ(decoder.stats().bytes_fed, stream.size());
}

TEST(SnpFrameDecoderTest, DecodesFramesSplitAtEveryByteBoundary) {
  const std::vector<uint8_t> f1 = Frame1(), f2 = Frame2(), f3 = Frame3();
  const std::vector<uint8_t> stream = Concat({f1, f2, f3});
  const std::vector<Summary> expected = {
      FrameAt(0, f1), FrameAt(f1.size(), f2), FrameAt(f1.size() + f2.size(), f3)};
  for (std::size_t split = 0; split <= stream.size(); ++split) {
    EXPECT_EQ(Summarize(DecodeInChunks(stream, {split})), expected) << "split " << split;
  }
  // Three pieces: every pair of cut points inside the first two frames.
  for (std::size_t a = 0; a <= f1.size() + 10; ++a) {
    for (std::size_t b = a; b <= f1.size() + f2.size(); b += 7) {
      ASSERT_EQ(Summarize(DecodeInChunks(stream, {a, b - a})), expected)
          << "cuts " << a << ", " << b;
    }
  }
  EXPECT_EQ(Summarize(DecodeByteByByte(stream)), expected);
}

TEST(SnpFrameDecoderTest, ReportsPartialFrameWhileWaiting) {
  const std::vector<uint8_t> bytes = Frame1();
  FrameDecoder decoder;
  std::vector<DecodeEvent> events;
  for (std::size_t i = 0; i + 1 < bytes.size(); ++i) {
    decoder.Feed(std::span(bytes).subspan(i, 1), events);
    EXPECT_TRUE(events.empty());
    EXPECT_TRUE(decoder.HasPartialFrame());
    EXPECT_EQ(decoder.BufferedBytes(), i + 1);
  }
  decoder.Feed(std::span(bytes).subspan(bytes.size() - 1), events);
  EXPECT_EQ(events.size(), 1u);
  EXPECT_FALSE(decoder.HasPartialFrame());
}

TEST(SnpFrameDecoderTest, ReportsTruncatedFrameOnFlush) {
  std::vector<uint8_t> bytes = Frame1();
  bytes.pop_back();
  FrameDecoder decoder;
  EXPECT_TRUE(decoder.Feed(bytes).empty());
  EXPECT_TRUE(decoder.HasPartialFrame());
  EXPECT_EQ(decoder.BufferedBytes(), 15u);
  EXPECT_EQ(Summarize(decoder.Flush()),
            std::vector<Summary>{ErrorAt(0, DecodeErrorKind::kTruncated,
                                         "truncated frame: have 15 of 16 bytes")});
  EXPECT_FALSE(decoder.HasPartialFrame());
  EXPECT_EQ(decoder.stats().ErrorCount(DecodeErrorKind::kTruncated), 1u);
  EXPECT_EQ(decoder.stats().skipped_bytes, 15u);

  // The stream goes on after a flush; offsets continue.
  const std::vector<uint8_t> lone = {0x00, kStartByte};
  EXPECT_TRUE(decoder.Feed(lone).empty());
  EXPECT_EQ(Summarize(decoder.Flush()),
            std::vector<Summary>{ErrorAt(16, DecodeErrorKind::kTruncated,
                                         "truncated frame: have 1 of at least 8 bytes")});
}

TEST(SnpFrameDecoderTest, SkipsGarbageBeforeAFrame) {
  const std::vector<uint8_t> frame = Frame2();
  for (uint64_t seed = 0; seed < 300; ++seed) {
    std::mt19937_64 rng(seed);
    std::vector<uint8_t> garbage(rng() % 300);
    for (uint8_t& b : garbage) b = static_cast<uint8_t>(rng());
    for (int i = 0; i < 8 && !garbage.empty(); ++i) {
      garbage[rng() % garbage.size()] = kStartByte;  // many false starts
    }
    const std::vector<uint8_t> stream = Concat({garbage, frame});
    const std::vector<DecodeEvent> events = DecodeRandomChunks(stream, rng);
    const std::vector<Summary> summaries = Summarize(events);
    ASSERT_FALSE(summaries.empty());
    EXPECT_EQ(summaries.back(), FrameAt(garbage.size(), frame)) << "seed " << seed;
    for (const Summary& s : summaries) {
      ASSERT_LT(s.offset, stream.size());
      EXPECT_EQ(stream[s.offset], kStartByte) << s;
    }
  }
}

// A candidate header that passes every header rule and claims 64 payload
// bytes (RobotPosition, bridge -> host).
std::vector<uint8_t> LongCandidateHeader() {
  return {kStartByte, 64, 0x06, 0x00, 0x00, 0x63};
}

TEST(SnpFrameDecoderTest, FindsFrameHiddenInsideBadCrcCandidate) {
  const std::vector<uint8_t> header = LongCandidateHeader();
  const std::vector<uint8_t> frame = Frame1();
  std::vector<uint8_t> stream = Concat({header, frame});
  stream.resize(header.size() + 64 + 2 + 5, 0x00);  // the candidate's claim and more
  const std::vector<DecodeEvent> events = DecodeWhole(stream);
  const std::vector<Summary> summaries = Summarize(events);
  ASSERT_EQ(summaries.size(), 2u);
  EXPECT_FALSE(summaries[0].is_frame);
  EXPECT_EQ(summaries[0].offset, 0u);
  EXPECT_EQ(summaries[0].kind, DecodeErrorKind::kBadCrc);
  EXPECT_THAT(summaries[0].text, ::testing::StartsWith("CRC mismatch: frame has 0x0000, computed 0x"));
  EXPECT_EQ(summaries[1], FrameAt(header.size(), frame));
  EXPECT_EQ(Summarize(DecodeByteByByte(stream)), summaries);
}

TEST(SnpFrameDecoderTest, FindsFrameHiddenInsideTruncatedCandidate) {
  const std::vector<uint8_t> header = LongCandidateHeader();
  const std::vector<uint8_t> frame = Frame1();
  const std::vector<uint8_t> stream = Concat({header, frame});
  FrameDecoder decoder;
  EXPECT_TRUE(decoder.Feed(stream).empty()) << "still waiting for 72 bytes";
  EXPECT_TRUE(decoder.HasPartialFrame());
  EXPECT_EQ(Summarize(decoder.Flush()),
            (std::vector<Summary>{
                ErrorAt(0, DecodeErrorKind::kTruncated, "truncated frame: have 22 of 72 bytes"),
                FrameAt(header.size(), frame)}));
}

TEST(SnpFrameDecoderTest, RejectsWithReasonsAndCounts) {
  const std::vector<uint8_t> good = Frame1();
  std::vector<uint8_t> bad_crc = Frame1();
  bad_crc[7] ^= 0x80;
  const std::vector<uint8_t> oversized = {kStartByte, 241};
  const std::vector<uint8_t> unknown_type =
      WithCrc({kStartByte, 0, 0x01, 0x00, 0x03, 0x7F, 0, 0});
  const std::vector<uint8_t> wrong_size =
      WithCrc({kStartByte, 2, 0x01, 0x00, 0x03, 0x09, 1, 2, 0, 0});
  const std::vector<uint8_t> bad_header =
      WithCrc({kStartByte, 0, 0x01, 0x00, 0x03, 0x40, 0, 0});
  const std::vector<uint8_t> stream =
      Concat({bad_crc, good, oversized, good, unknown_type, good, wrong_size,
              good, bad_header, good});
  std::size_t at = 0;
  std::vector<Summary> expected;
  auto add = [&](const std::vector<uint8_t>& part, std::optional<Summary> summary) {
    if (summary) {
      summary->offset = at;
      expected.push_back(*summary);
    }
    at += part.size();
  };
  add(bad_crc, ErrorAt(0, DecodeErrorKind::kBadCrc, ""));
  add(good, FrameAt(0, good));
  add(oversized, ErrorAt(0, DecodeErrorKind::kOversizedLength,
                         "length 241 exceeds the maximum payload of 240 bytes"));
  add(good, FrameAt(0, good));
  add(unknown_type, ErrorAt(0, DecodeErrorKind::kUnknownType, "unknown message type 0x7f"));
  add(good, FrameAt(0, good));
  add(wrong_size, ErrorAt(0, DecodeErrorKind::kBadPayloadSize,
                          "payload size 2 invalid for ServoAngle: expects 4 bytes"));
  add(good, FrameAt(0, good));
  add(bad_header, ErrorAt(0, DecodeErrorKind::kBadHeader,
                          "GetSimTime is a bridge command (host to bridge) but "
                          "goes from the host to a module"));
  add(good, FrameAt(0, good));

  FrameDecoder decoder;
  std::vector<Summary> got = Summarize(DecodeInChunks(stream, {}, &decoder));
  ASSERT_EQ(got.size(), expected.size());
  EXPECT_THAT(got[0].text, ::testing::MatchesRegex(
                               "CRC mismatch: frame has 0x[0-9a-f]{4}, computed 0x[0-9a-f]{4}"));
  got[0].text.clear();
  EXPECT_EQ(got, expected);

  const DecoderStats& stats = decoder.stats();
  EXPECT_EQ(stats.frames, 5u);
  EXPECT_EQ(stats.ErrorCount(DecodeErrorKind::kBadCrc), 1u);
  EXPECT_EQ(stats.ErrorCount(DecodeErrorKind::kOversizedLength), 1u);
  EXPECT_EQ(stats.ErrorCount(DecodeErrorKind::kUnknownType), 1u);
  EXPECT_EQ(stats.ErrorCount(DecodeErrorKind::kBadPayloadSize), 1u);
  EXPECT_EQ(stats.ErrorCount(DecodeErrorKind::kBadHeader), 1u);
  EXPECT_EQ(stats.ErrorCount(DecodeErrorKind::kTruncated), 0u);
  EXPECT_EQ(stats.TotalErrors(), 5u);
  EXPECT_EQ(stats.frame_bytes + stats.skipped_bytes, stream.size());
  EXPECT_EQ(stats.bytes_fed, stream.size());
}

TEST(SnpFrameDecoderTest, ResetForgetsEverything) {
  FrameDecoder decoder;
  std::vector<uint8_t> partial = Frame1();
  partial.resize(4);
  decoder.Feed(Frame1());
  decoder.Feed(partial);
  EXPECT_TRUE(decoder.HasPartialFrame());
  decoder.Reset();
  EXPECT_FALSE(decoder.HasPartialFrame());
  EXPECT_EQ(decoder.stats().frames, 0u);
  EXPECT_EQ(decoder.stats().bytes_fed, 0u);
  const std::vector<DecodeEvent> events = decoder.Feed(Frame1());
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(std::get<DecodedFrame>(events[0]).offset, 0u);
}

TEST(SnpDecodeErrorTest, LongReasonsAreCut) {
  const DecodeError error(DecodeErrorKind::kBadCrc, 7, std::string(500, 'r'));
  EXPECT_EQ(error.reason().size(), DecodeError::kMaxReasonSize);
  EXPECT_EQ(error.offset(), 7u);
  EXPECT_EQ(DecodeErrorKindName(DecodeErrorKind::kTruncated), "truncated frame");
}

// A random stream: garbage, intact frames, corrupted frames and cut-off
// frames. Intact frames are recorded with their offsets.
struct RandomStream {
  std::vector<uint8_t> bytes;
  std::map<uint64_t, std::vector<uint8_t>> intact;  // offset -> frame bytes
};

RandomStream MakeRandomStream(std::mt19937_64& rng) {
  RandomStream stream;
  const int segments = 1 + static_cast<int>(rng() % 8);
  for (int i = 0; i < segments; ++i) {
    const uint64_t kind = rng() % 10;
    if (kind < 3) {  // garbage, rich in start bytes
      const std::size_t size = rng() % 40;
      for (std::size_t j = 0; j < size; ++j) {
        stream.bytes.push_back(rng() % 4 == 0 ? kStartByte : static_cast<uint8_t>(rng()));
      }
      continue;
    }
    std::vector<uint8_t> frame = EncodeMessage(testing::RandomMessage(rng));
    if (kind < 7) {
      stream.intact[stream.bytes.size()] = frame;
    } else if (kind < 9) {  // one byte changed
      frame[rng() % frame.size()] ^= static_cast<uint8_t>(1 + rng() % 255);
    } else {  // cut off
      frame.resize(rng() % frame.size());
    }
    stream.bytes.insert(stream.bytes.end(), frame.begin(), frame.end());
  }
  return stream;
}

TEST(SnpFrameDecoderPropertyTest, EventsDoNotDependOnChunking) {
  std::mt19937_64 rng(77);
  for (int i = 0; i < 500; ++i) {
    const RandomStream stream = MakeRandomStream(rng);
    const std::vector<Summary> whole = Summarize(DecodeWhole(stream.bytes));
    ASSERT_EQ(Summarize(DecodeByteByByte(stream.bytes)), whole) << "stream " << i;
    ASSERT_EQ(Summarize(DecodeRandomChunks(stream.bytes, rng)), whole) << "stream " << i;
  }
}

TEST(SnpFrameDecoderPropertyTest, RandomStreamsFindEveryIntactFrame) {
  std::mt19937_64 rng(4242);
  int spurious_frames = 0;
  int intact_frames = 0;
  for (int i = 0; i < 10000; ++i) {
    const RandomStream stream = MakeRandomStream(rng);
    FrameDecoder decoder;
    std::vector<std::size_t> chunks;
    for (std::size_t total = 0; total < stream.bytes.size(); total += chunks.back()) {
      chunks.push_back(1 + rng() % 64);
    }
    const std::vector<DecodeEvent> events = DecodeInChunks(stream.bytes, chunks, &decoder);

    std::map<uint64_t, std::vector<uint8_t>> found;
    std::vector<std::pair<uint64_t, uint64_t>> spurious;  // [begin, end)
    std::size_t errors = 0;
    for (const DecodeEvent& event : events) {
      if (const auto* decoded = std::get_if<DecodedFrame>(&event)) {
        const std::vector<uint8_t> bytes = EncodeFrame(decoded->frame);
        ASSERT_LE(decoded->offset + bytes.size(), stream.bytes.size());
        // Every decoded frame is exactly the bytes it came from.
        ASSERT_TRUE(std::equal(bytes.begin(), bytes.end(),
                               stream.bytes.begin() + static_cast<std::ptrdiff_t>(decoded->offset)))
            << "stream " << i;
        found[decoded->offset] = bytes;
        if (!stream.intact.contains(decoded->offset)) {
          spurious.emplace_back(decoded->offset, decoded->offset + bytes.size());
        }
      } else {
        const auto& error = std::get<DecodeError>(event);
        ASSERT_EQ(stream.bytes[error.offset()], kStartByte);
        ASSERT_FALSE(error.reason().empty());
        ++errors;
      }
    }
    spurious_frames += static_cast<int>(spurious.size());
    for (const auto& [offset, bytes] : stream.intact) {
      ++intact_frames;
      const auto it = found.find(offset);
      if (it != found.end()) {
        ASSERT_EQ(it->second, bytes);
        continue;
      }
      // Only a frame that (by a CRC coincidence) decoded over it may hide it.
      const bool hidden = std::any_of(spurious.begin(), spurious.end(), [&](auto range) {
        return range.first < offset + bytes.size() && offset < range.second;
      });
      ASSERT_TRUE(hidden) << "stream " << i << ": intact frame at " << offset << " lost";
    }
    const DecoderStats& stats = decoder.stats();
    ASSERT_EQ(stats.frame_bytes + stats.skipped_bytes, stream.bytes.size());
    ASSERT_EQ(stats.frames, found.size());
    ASSERT_EQ(stats.TotalErrors(), errors);
  }
  EXPECT_GT(intact_frames, 10000);
  // A corrupted or cut-off frame decodes only by a 1-in-65536 CRC accident.
  EXPECT_LE(spurious_frames, 3);
}

}  // namespace
}  // namespace yamor::snp
