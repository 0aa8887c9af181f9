// The recorded-session line format (proto/snp/recording.h, docs/snp.md
// "Recorded sessions"): round trip, torn last line, malformed lines with
// their line numbers, random lines never crash the reader.
#include "proto/snp/recording.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <thread>
#include <unistd.h>

#include "common/log.h"
#include "common/status.h"
#include "proto/snp/messages.h"

namespace yamor::snp {
namespace {

Frame HostToModule() {
  return MakeFrame(Address::Host(), Address::Module(3), SetLimits{-1.0f, 0.5f});
}
Frame HostToBridgeStep() { return MakeFrame(Address::Host(), Address::Bridge(), Step{0.01}); }
Frame BridgePosition() {
  return MakeFrame(Address::Bridge(), Address::Host(),
                   RobotPosition{.time = 1.5, .position = {0.25, -0.125, 0.05}});
}

std::string TempPath(const std::string& name) {
  return (std::filesystem::temp_directory_path() /
          (name + "_" + std::to_string(::getpid()) + "_" +
           ::testing::UnitTest::GetInstance()->current_test_info()->name()))
      .string();
}

std::string ReadAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Expects ParseRecording to throw INVALID_ARGUMENT whose message has `needle`.
void ExpectMalformed(const std::string& text, const std::string& needle) {
  try {
    ParseRecording(text, "rec.txt");
    ADD_FAILURE() << "accepted: " << text;
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kInvalidArgument) << e.what();
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos)
        << "message '" << e.what() << "' lacks '" << needle << "'";
  }
}

const std::string kHeader = "yamor-snp-recording 1 start=2026-12-02T06:34:53.000000Z backend=sim\n";

TEST(RecordingFormatTest, ExampleLinesAreByteExact) {
  // docs/snp.md pins these lines.
  EXPECT_EQ(FormatRecordLine(RecordedFrame{1.25, Direction::kHostToRobot, HostToModule()}),
            "1.250000 > A50801000305000080BF0000003F7BBE");
  EXPECT_EQ(FormatRecordLine(RecordedFrame{0.0, Direction::kHostToRobot, HostToBridgeStep()}),
            "0.000000 > A508090000417B14AE47E17A843F2FF5");
  EXPECT_EQ(FormatRecordLine(RecordedOpen{0.5, {{"backend", "simulation"},
                                                {"world", "my world%1"}}}),
            "0.500000 open backend=simulation world=my%20world%251");
  EXPECT_EQ(FormatRecordHeader({{"start", "2026-12-02T06:34:53.000000Z"}, {"backend", "sim"}}) + "\n",
            kHeader);
}

TEST(RecordingFormatTest, WriterOutputReadsBackAsWritten) {
  const std::string path = TempPath("recording_roundtrip");
  {
    RecordingWriter writer(path, {{"backend", "sim"}, {"note", "a b=c\t%"}});
    writer.WriteOpen({{"backend", "simulation"}, {"world", "quadruped"}, {"seed", "7"}});
    writer.WriteFrame(Direction::kHostToRobot, HostToModule());
    writer.WriteFrame(Direction::kHostToRobot, HostToBridgeStep());
    writer.WriteFrame(Direction::kRobotToHost, BridgePosition());
    EXPECT_EQ(writer.lines(), 4u);
    // Each line is flushed: the file is complete before the writer closes.
    const Recording live = ParseRecording(ReadAll(path), path);
    EXPECT_EQ(live.entries.size(), 4u);
    EXPECT_EQ(live.torn_lines, 0);
  }
  const Recording r = LoadRecordingFile(path);
  EXPECT_EQ(r.version, 1);
  EXPECT_TRUE(FindAttribute(r.header, "start").has_value());
  EXPECT_EQ(FindAttribute(r.header, "backend"), "sim");
  EXPECT_EQ(FindAttribute(r.header, "note"), "a b=c\t%");
  ASSERT_EQ(r.entries.size(), 4u);
  const auto& open = std::get<RecordedOpen>(r.entries[0]);
  EXPECT_EQ(FindAttribute(open.attributes, "world"), "quadruped");
  EXPECT_EQ(FindAttribute(open.attributes, "seed"), "7");
  const auto& a = std::get<RecordedFrame>(r.entries[1]);
  const auto& b = std::get<RecordedFrame>(r.entries[2]);
  const auto& c = std::get<RecordedFrame>(r.entries[3]);
  EXPECT_EQ(a.frame, HostToModule());
  EXPECT_EQ(a.direction, Direction::kHostToRobot);
  EXPECT_EQ(b.frame, HostToBridgeStep());
  EXPECT_EQ(c.frame, BridgePosition());
  EXPECT_EQ(c.direction, Direction::kRobotToHost);
  EXPECT_LE(open.time, a.time);
  EXPECT_LE(a.time, b.time);
  EXPECT_LE(b.time, c.time);
  EXPECT_EQ(std::get<RobotPosition>(DecodeMessage(c.frame)).position[1], -0.125);
  std::filesystem::remove(path);
}

TEST(RecordingFormatTest, ConcurrentWritersNeverInterleaveLines) {
  const std::string path = TempPath("recording_threads");
  {
    RecordingWriter writer(path, {{"backend", "sim"}});
    std::vector<std::thread> threads;
    for (int t = 0; t < 4; ++t) {
      threads.emplace_back([&writer, t] {
        for (int i = 0; i < 200; ++i) {
          writer.WriteFrame(t % 2 ? Direction::kRobotToHost : Direction::kHostToRobot,
                            t % 2 ? BridgePosition() : HostToModule());
        }
      });
    }
    for (std::thread& t : threads) t.join();
  }
  const Recording r = LoadRecordingFile(path);  // times non-decreasing, lines whole
  EXPECT_EQ(r.entries.size(), 800u);
  std::filesystem::remove(path);
}

TEST(RecordingFormatTest, TornLastLineIsSkippedAndCounted) {
  const std::string full = kHeader + "0.100000 > A50801000305000080BF0000003F7BBE\n";
  const std::string torn_line = "0.200000 > A508010003050000";
  for (std::size_t cut = 1; cut <= torn_line.size(); ++cut) {
    const Recording r = ParseRecording(full + torn_line.substr(0, cut), "rec.txt");
    EXPECT_EQ(r.entries.size(), 1u) << cut;
    EXPECT_EQ(r.torn_lines, 1) << cut;
  }
  // Even a torn line that would parse is skipped: the newline marks a whole line.
  const Recording r = ParseRecording(full + "0.300000 > A50801000305000080BF0000003F7BBE", "rec.txt");
  EXPECT_EQ(r.entries.size(), 1u);
  EXPECT_EQ(r.torn_lines, 1);
  const Recording whole = ParseRecording(full, "rec.txt");
  EXPECT_EQ(whole.torn_lines, 0);
  // A torn line in the middle is no torn line: it is malformed.
  ExpectMalformed(full + torn_line + "\n" + "0.400000 > A50801000305000080BF0000003F7BBE\n",
                  "rec.txt:3: bad frame");
}

TEST(RecordingFormatTest, MalformedLinesNameFileLineAndReason) {
  const std::string ok = "0.100000 > A50801000305000080BF0000003F7BBE\n";
  ExpectMalformed("", "rec.txt:1: empty recording");
  ExpectMalformed("hello 1 start=x backend=y\n", "rec.txt:1: not a recording");
  ExpectMalformed("yamor-snp-recording 2 start=x backend=y\n", "rec.txt:1: unsupported recording version '2'");
  ExpectMalformed("yamor-snp-recording 1 backend=y\n", "rec.txt:1: header lacks the 'start'");
  ExpectMalformed("yamor-snp-recording 1 start=x backend=y junk\n", "rec.txt:1: attribute 'junk' is not key=value");
  ExpectMalformed("yamor-snp-recording 1 start=x start=y backend=z\n", "'start' repeated");
  ExpectMalformed(kHeader + ok + "x.5 > A5\n", "rec.txt:3: bad time 'x.5'");
  ExpectMalformed(kHeader + ok + "-1.0 > A5\n", "rec.txt:3: bad time '-1.0'");
  ExpectMalformed(kHeader + ok + "1. > A5\n", "rec.txt:3: bad time '1.'");
  // Found by recording_reader_fuzzer: a 100-digit time was truncated when
  // written back; times are bounded instead.
  ExpectMalformed(kHeader + ok + std::string(100, '8') + ".000300 > A5\n",
                  "rec.txt:3: time '");
  ExpectMalformed(kHeader + ok + "0.050000 > A50801000305000080BF0000003F7BBE\n",
                  "rec.txt:3: time 0.050000 is before the previous line's 0.100000");
  ExpectMalformed(kHeader + ok + "0.200000 = A5\n", "rec.txt:3: bad direction '='");
  ExpectMalformed(kHeader + ok + "0.200000\n", "rec.txt:3: expected 'TIME > HEX'");
  ExpectMalformed(kHeader + ok + "0.200000 >\n", "rec.txt:3: a frame line has 3 fields (time, direction, hex), got 2");
  ExpectMalformed(kHeader + ok + "0.200000 > A5 00\n", "rec.txt:3: a frame line has 3 fields");
  ExpectMalformed(kHeader + ok + "0.200000 > A50\n", "rec.txt:3: frame hex has an odd number");
  ExpectMalformed(kHeader + ok + "0.200000 > A5G8\n", "rec.txt:3: frame hex has a non-hex digit");
  ExpectMalformed(kHeader + "0.200000 > A50801000305000080BF0000003F7BBF\n",
                  "rec.txt:2: bad frame: CRC mismatch");
  ExpectMalformed(kHeader + "0.200000 < A50801000305000080BF0000003F7BBE\n",
                  "rec.txt:2: frame marked '<' (robot to host) goes to module 3");
  ExpectMalformed(kHeader + "\n# note\n0.200000 open world=a%2\n", "rec.txt:4: bad %-escape");
  ExpectMalformed(kHeader + "0.200000 open w@rld=a\n", "rec.txt:2: recording attribute key 'w@rld'");
  // Comments, blank lines and CRLF are fine.
  const Recording r = ParseRecording(kHeader + "\n# a note\r\n" + ok, "rec.txt");
  EXPECT_EQ(r.entries.size(), 1u);
}

TEST(RecordingFormatTest, WriterRefusesBadInputAndUnwritablePaths) {
  EXPECT_THROW(RecordingWriter("/nonexistent-dir/x/rec.txt", {{"backend", "sim"}}), Error);
  EXPECT_THROW(FormatRecordLine(RecordedFrame{-1.0, Direction::kHostToRobot, HostToModule()}),
               Error);
  EXPECT_THROW(FormatRecordLine(RecordedFrame{1.0, Direction::kRobotToHost, HostToModule()}),
               Error);
  EXPECT_THROW(FormatRecordHeader({{"bad key", "x"}}), Error);
}

TEST(RecordingFormatTest, RandomLinesNeverCrashTheReader) {
  std::mt19937_64 rng(20261202);
  const std::string alphabet = "0123456789ABCDEFabcdef .<>=%#open\r\t-xyz\x01\xff";
  const std::string ok = "0.100000 > A50801000305000080BF0000003F7BBE\n";
  int accepted = 0;
  SetLogLevel("error");  // thousands of torn-line warnings
  for (int i = 0; i < 4000; ++i) {
    std::string text = kHeader + ok;
    const int lines = static_cast<int>(rng() % 4);
    for (int l = 0; l < lines; ++l) {
      std::string line = rng() % 2 ? ok.substr(0, rng() % ok.size()) : std::string();
      const int n = static_cast<int>(rng() % 60);
      for (int k = 0; k < n; ++k) line.push_back(alphabet[rng() % alphabet.size()]);
      // Mutate a valid line at a random position sometimes.
      if (!line.empty() && rng() % 3 == 0) line[rng() % line.size()] = alphabet[rng() % alphabet.size()];
      text += line + (rng() % 5 ? "\n" : "");
    }
    try {
      const Recording r = ParseRecording(text, "fuzz");
      ++accepted;
      EXPECT_GE(r.entries.size(), 1u);
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), StatusCode::kInvalidArgument);
      EXPECT_EQ(std::string(e.what()).rfind("fuzz:", 0), 0u) << e.what();
    }
  }
  SetLogLevel("info");
  EXPECT_GT(accepted, 0);
}

}  // namespace
}  // namespace yamor::snp
