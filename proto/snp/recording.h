// Recorded SNP sessions: a line format holding every frame a host exchanged
// with a robot, with its time and direction ("Recorded sessions" in
// docs/snp.md). `yamord --record FILE` writes it; `yamor-bridge --replay
// FILE` re-drives a simulation from it.
//
//   yamor-snp-recording 1 start=2026-12-02T06:34:53.123456Z backend=sim
//   0.000412 open backend=simulation world=quadruped seed=0 time_step=0.002 master=4
//   0.000530 > A5000900004E714B
//   0.000547 < A51806000069FCA9F1D24D62603F0000000000008040D34D62105839A43F00C4
#pragma once

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

#include "proto/snp/frame.h"

namespace yamor::snp {

/// First word of a recording's header line.
inline constexpr std::string_view kRecordingMagic = "yamor-snp-recording";
/// Version of the line format this code reads and writes.
inline constexpr int kRecordingVersion = 1;

/// Ordered key=value pairs (header and `open` lines). Keys are non-empty
/// and made of [A-Za-z0-9_.-]; values are any bytes (escaped on the line).
using RecordAttributes = std::vector<std::pair<std::string, std::string>>;

/// The value of `key` in `attributes`, or nullopt.
std::optional<std::string> FindAttribute(const RecordAttributes& attributes,
                                         std::string_view key);

/// Which way a recorded frame went.
enum class Direction : uint8_t {
  kHostToRobot = 0,  ///< Sent by the host (`>` on the line).
  kRobotToHost = 1,  ///< Received by the host (`<` on the line).
};

/// One frame with its time.
struct RecordedFrame {
  double time = 0.0;  ///< Monotonic seconds since the recording started.
  Direction direction = Direction::kHostToRobot;  ///< Which way it went.
  Frame frame;        ///< The frame (valid, see ValidateFrame).
  friend bool operator==(const RecordedFrame&, const RecordedFrame&) = default;
};

/// The host started talking to a new robot link (a simulation opened, a
/// backend attached): frames after it belong to that link until the next.
struct RecordedOpen {
  double time = 0.0;          ///< Monotonic seconds since the recording started.
  RecordAttributes attributes;  ///< What was opened (backend, world, seed, ...).
  friend bool operator==(const RecordedOpen&, const RecordedOpen&) = default;
};

/// One entry of a recording, in file order.
using RecordEntry = std::variant<RecordedFrame, RecordedOpen>;

/// A parsed recording.
struct Recording {
  int version = kRecordingVersion;  ///< Format version from the header.
  RecordAttributes header;          ///< Header attributes (start, backend, ...).
  std::vector<RecordEntry> entries; ///< Frames and opens in file order.
  /// Torn last lines skipped (0 or 1): a final line without its newline.
  int torn_lines = 0;
};

/// The line for `entry` without the newline, e.g. "1.250000 > A5...";
/// throws yamor::Error(INVALID_ARGUMENT) for a negative or non-finite time,
/// an invalid frame or a bad attribute key.
std::string FormatRecordLine(const RecordEntry& entry);

/// The header line without the newline; INVALID_ARGUMENT for a bad key.
std::string FormatRecordHeader(const RecordAttributes& attributes);

/// Parses a whole recording. Malformed lines throw yamor::Error
/// (INVALID_ARGUMENT) naming `source:line` and the reason; a final line
/// without a newline (a write torn by a kill) is skipped and counted in
/// torn_lines, with a warning in the log.
Recording ParseRecording(std::string_view text, std::string_view source);

/// Reads and parses a recording file: NOT_FOUND when it cannot be read,
/// otherwise as ParseRecording with the path as source.
Recording LoadRecordingFile(const std::string& path);

/// Writes a recording file line by line, flushing each line so a killed
/// process loses at most the line being written.
///
/// Thread-safety: thread-safe; every method may be called from any thread
/// (lines from concurrent callers never interleave, times never decrease).
class RecordingWriter {
 public:
  /// Creates (truncates) `path` and writes the header with `start=` (UTC
  /// wall clock now) followed by `attributes`. NOT_FOUND when the file
  /// cannot be created, INVALID_ARGUMENT for a bad attribute key.
  RecordingWriter(const std::string& path, const RecordAttributes& attributes);
  /// Closes the file.
  ~RecordingWriter();
  RecordingWriter(const RecordingWriter&) = delete;
  RecordingWriter& operator=(const RecordingWriter&) = delete;

  /// Appends a frame line stamped with the time now. Throws yamor::Error
  /// (INVALID_ARGUMENT) for an invalid frame, UNAVAILABLE when the write fails.
  void WriteFrame(Direction direction, const Frame& frame);
  /// Appends an `open` line stamped with the time now (errors as WriteFrame).
  void WriteOpen(const RecordAttributes& attributes);
  /// The recording's path.
  const std::string& path() const { return path_; }
  /// Lines written after the header.
  uint64_t lines() const;

 private:
  void WriteLocked(const std::string& line);

  const std::string path_;
  const std::chrono::steady_clock::time_point start_;
  mutable std::mutex mutex_;
  std::FILE* file_ = nullptr;  // guarded by mutex_
  uint64_t lines_ = 0;         // guarded by mutex_
};

}  // namespace yamor::snp
