#include "proto/snp/recording.h"

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <ctime>
#include <fstream>
#include <sstream>

#include "common/log.h"
#include "common/status.h"

namespace yamor::snp {
namespace {

constexpr char kHex[] = "0123456789ABCDEF";

bool IsKeyChar(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
         c == '_' || c == '.' || c == '-';
}

void CheckKey(std::string_view key) {
  if (key.empty()) throw Error(StatusCode::kInvalidArgument, "empty recording attribute key");
  for (char c : key) {
    if (!IsKeyChar(c)) {
      throw Error(StatusCode::kInvalidArgument,
                  "recording attribute key '" + std::string(key) +
                      "' has a character outside [A-Za-z0-9_.-]");
    }
  }
}

// Printable ASCII except '%' stays; everything else becomes %XX.
std::string EscapeValue(std::string_view value) {
  std::string out;
  for (char c : value) {
    const auto b = static_cast<unsigned char>(c);
    if (b > 0x20 && b < 0x7F && c != '%') {
      out.push_back(c);
    } else {
      out.push_back('%');
      out.push_back(kHex[b >> 4]);
      out.push_back(kHex[b & 0x0F]);
    }
  }
  return out;
}

int HexValue(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;
}

// Short, printable excerpt of a bad token for messages.
std::string Excerpt(std::string_view token) {
  std::string out;
  for (char c : token.substr(0, 40)) {
    const auto b = static_cast<unsigned char>(c);
    out += (b >= 0x20 && b < 0x7F) ? std::string(1, c) : "\\x" + std::string{kHex[b >> 4], kHex[b & 15]};
  }
  if (token.size() > 40) out += "...";
  return out;
}

std::string UnescapeValue(std::string_view value) {
  std::string out;
  for (std::size_t i = 0; i < value.size(); ++i) {
    if (value[i] != '%') {
      out.push_back(value[i]);
      continue;
    }
    const bool complete = i + 2 < value.size();
    const int hi = complete ? HexValue(value[i + 1]) : -1;
    const int lo = complete ? HexValue(value[i + 2]) : -1;
    if (hi < 0 || lo < 0) {
      throw Error(StatusCode::kInvalidArgument,
                  "bad %-escape in value '" + Excerpt(value) + "' (expected %XX)");
    }
    out.push_back(static_cast<char>(hi * 16 + lo));
    i += 2;
  }
  return out;
}

std::string FormatAttributes(const RecordAttributes& attributes) {
  std::string out;
  for (const auto& [key, value] : attributes) {
    CheckKey(key);
    out += ' ' + key + '=' + EscapeValue(value);
  }
  return out;
}

std::vector<std::string_view> SplitFields(std::string_view line) {
  std::vector<std::string_view> fields;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    const std::size_t begin = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
    if (i > begin) fields.push_back(line.substr(begin, i - begin));
  }
  return fields;
}

RecordAttributes ParseAttributes(const std::vector<std::string_view>& fields, std::size_t first) {
  RecordAttributes attributes;
  for (std::size_t i = first; i < fields.size(); ++i) {
    const std::size_t eq = fields[i].find('=');
    if (eq == std::string_view::npos) {
      throw Error(StatusCode::kInvalidArgument,
                  "attribute '" + Excerpt(fields[i]) + "' is not key=value");
    }
    const std::string_view key = fields[i].substr(0, eq);
    CheckKey(key);
    if (FindAttribute(attributes, key)) {
      throw Error(StatusCode::kInvalidArgument, "attribute '" + std::string(key) + "' repeated");
    }
    attributes.emplace_back(std::string(key), UnescapeValue(fields[i].substr(eq + 1)));
  }
  return attributes;
}

// Longest recording [s] (about 31 years): a bound that keeps every time's
// text short and exact, so formatting never truncates it.
constexpr double kMaxRecordingTime = 1e9;

// Decimal seconds: digits, optionally '.' and digits.
double ParseTime(std::string_view token) {
  std::size_t i = 0;
  while (i < token.size() && token[i] >= '0' && token[i] <= '9') ++i;
  const std::size_t integer_digits = i;
  bool ok = integer_digits > 0;
  if (ok && i < token.size()) {
    ok = token[i] == '.';
    ++i;
    const std::size_t fraction_begin = i;
    while (i < token.size() && token[i] >= '0' && token[i] <= '9') ++i;
    ok = ok && i > fraction_begin && i == token.size();
  }
  double value = 0.0;
  if (ok) {
    const auto result = std::from_chars(token.data(), token.data() + token.size(), value);
    ok = result.ec == std::errc() && std::isfinite(value);
  }
  if (!ok) {
    throw Error(StatusCode::kInvalidArgument,
                "bad time '" + Excerpt(token) + "' (expected decimal seconds like 1.250000)");
  }
  if (value > kMaxRecordingTime) {
    throw Error(StatusCode::kInvalidArgument,
                "time '" + Excerpt(token) + "' is beyond the longest recording (1e9 s)");
  }
  return value;
}

Frame ParseFrameHex(std::string_view hex) {
  if (hex.size() % 2 != 0) {
    throw Error(StatusCode::kInvalidArgument,
                "frame hex has an odd number of digits (" + std::to_string(hex.size()) + ")");
  }
  if (hex.size() > 2 * kMaxFrameSize) {
    throw Error(StatusCode::kInvalidArgument, "frame hex of " + std::to_string(hex.size() / 2) +
                                                  " bytes exceeds the largest frame (" +
                                                  std::to_string(kMaxFrameSize) + " bytes)");
  }
  std::vector<uint8_t> bytes;
  bytes.reserve(hex.size() / 2);
  for (std::size_t i = 0; i < hex.size(); i += 2) {
    const int hi = HexValue(hex[i]);
    const int lo = HexValue(hex[i + 1]);
    if (hi < 0 || lo < 0) {
      throw Error(StatusCode::kInvalidArgument,
                  "frame hex has a non-hex digit in '" + Excerpt(hex.substr(i, 2)) + "' at digit " +
                      std::to_string(i + (hi < 0 ? 0 : 1)));
    }
    bytes.push_back(static_cast<uint8_t>(hi * 16 + lo));
  }
  try {
    return DecodeFrame(bytes);
  } catch (const Error& e) {
    throw Error(StatusCode::kInvalidArgument, std::string("bad frame: ") + e.what());
  }
}

void CheckDirection(Direction direction, const Frame& frame) {
  if (direction == Direction::kHostToRobot && frame.source.kind != NodeKind::kHost) {
    throw Error(StatusCode::kInvalidArgument,
                "frame marked '>' (host to robot) comes from " + ToString(frame.source));
  }
  if (direction == Direction::kRobotToHost && frame.destination.kind != NodeKind::kHost) {
    throw Error(StatusCode::kInvalidArgument,
                "frame marked '<' (robot to host) goes to " + ToString(frame.destination));
  }
}

std::string FormatTime(double time) {
  if (!std::isfinite(time) || time < 0.0 || time > kMaxRecordingTime) {
    throw Error(StatusCode::kInvalidArgument,
                "recording time must be finite and in [0, 1e9] s, got " + std::to_string(time));
  }
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.6f", time);
  return buffer;
}

std::string WallClockNow() {
  const auto now = std::chrono::system_clock::now();
  const std::time_t seconds = std::chrono::system_clock::to_time_t(now);
  const auto micros = std::chrono::duration_cast<std::chrono::microseconds>(
                          now.time_since_epoch()).count() % 1000000;
  std::tm utc{};
  gmtime_r(&seconds, &utc);
  char buffer[64];
  std::strftime(buffer, sizeof buffer, "%Y-%m-%dT%H:%M:%S", &utc);
  char out[96];
  std::snprintf(out, sizeof out, "%s.%06lldZ", buffer, static_cast<long long>(micros));
  return out;
}

}  // namespace

std::optional<std::string> FindAttribute(const RecordAttributes& attributes,
                                         std::string_view key) {
  for (const auto& [k, v] : attributes) {
    if (k == key) return v;
  }
  return std::nullopt;
}

std::string FormatRecordHeader(const RecordAttributes& attributes) {
  return std::string(kRecordingMagic) + ' ' + std::to_string(kRecordingVersion) +
         FormatAttributes(attributes);
}

std::string FormatRecordLine(const RecordEntry& entry) {
  if (const auto* f = std::get_if<RecordedFrame>(&entry)) {
    CheckDirection(f->direction, f->frame);
    std::string line = FormatTime(f->time);
    line += f->direction == Direction::kHostToRobot ? " > " : " < ";
    for (uint8_t b : EncodeFrame(f->frame)) {
      line.push_back(kHex[b >> 4]);
      line.push_back(kHex[b & 0x0F]);
    }
    return line;
  }
  const auto& open = std::get<RecordedOpen>(entry);
  return FormatTime(open.time) + " open" + FormatAttributes(open.attributes);
}

Recording ParseRecording(std::string_view text, std::string_view source) {
  Recording recording;
  bool have_header = false;
  double last_time = 0.0;
  std::size_t line_number = 0;
  std::size_t pos = 0;
  while (pos < text.size()) {
    ++line_number;
    const std::size_t newline = text.find('\n', pos);
    if (newline == std::string_view::npos) {
      // The writer ends every line with '\n': without it the line was torn.
      ++recording.torn_lines;
      Log().warn("{}:{}: skipping a torn last line ({} bytes without a newline)", source,
                 line_number, text.size() - pos);
      break;
    }
    std::string_view line = text.substr(pos, newline - pos);
    pos = newline + 1;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    try {
      const std::vector<std::string_view> fields = SplitFields(line);
      if (!have_header) {
        if (fields.empty() || fields[0] != kRecordingMagic) {
          throw Error(StatusCode::kInvalidArgument,
                      "not a recording: the first line must start with '" +
                          std::string(kRecordingMagic) + "'");
        }
        if (fields.size() < 2 || fields[1] != std::to_string(kRecordingVersion)) {
          throw Error(StatusCode::kInvalidArgument,
                      "unsupported recording version '" +
                          (fields.size() < 2 ? std::string() : Excerpt(fields[1])) +
                          "' (this reader knows version " + std::to_string(kRecordingVersion) +
                          ")");
        }
        recording.header = ParseAttributes(fields, 2);
        for (const char* key : {"start", "backend"}) {
          if (!FindAttribute(recording.header, key)) {
            throw Error(StatusCode::kInvalidArgument,
                        std::string("header lacks the '") + key + "' attribute");
          }
        }
        have_header = true;
        continue;
      }
      if (fields.empty() || fields[0].front() == '#') continue;
      if (fields.size() < 2) {
        throw Error(StatusCode::kInvalidArgument,
                    "expected 'TIME > HEX', 'TIME < HEX' or 'TIME open ...', got '" +
                        Excerpt(line) + "'");
      }
      const double time = ParseTime(fields[0]);
      if (time < last_time) {
        throw Error(StatusCode::kInvalidArgument, "time " + std::string(fields[0]) +
                                                      " is before the previous line's " +
                                                      FormatTime(last_time));
      }
      last_time = time;
      if (fields[1] == "open") {
        recording.entries.push_back(RecordedOpen{time, ParseAttributes(fields, 2)});
        continue;
      }
      if (fields[1] != ">" && fields[1] != "<") {
        throw Error(StatusCode::kInvalidArgument, "bad direction '" + Excerpt(fields[1]) +
                                                      "' (expected '>', '<' or 'open')");
      }
      if (fields.size() != 3) {
        throw Error(StatusCode::kInvalidArgument,
                    "a frame line has 3 fields (time, direction, hex), got " +
                        std::to_string(fields.size()));
      }
      RecordedFrame frame{.time = time,
                          .direction = fields[1] == ">" ? Direction::kHostToRobot
                                                        : Direction::kRobotToHost,
                          .frame = ParseFrameHex(fields[2])};
      CheckDirection(frame.direction, frame.frame);
      recording.entries.push_back(std::move(frame));
    } catch (const Error& e) {
      throw Error(StatusCode::kInvalidArgument,
                  std::string(source) + ":" + std::to_string(line_number) + ": " + e.what());
    }
  }
  if (!have_header) {
    throw Error(StatusCode::kInvalidArgument,
                std::string(source) + ":1: empty recording (no complete header line)");
  }
  return recording;
}

Recording LoadRecordingFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(StatusCode::kNotFound, "cannot read recording " + path);
  std::ostringstream text;
  text << in.rdbuf();
  return ParseRecording(text.str(), path);
}

RecordingWriter::RecordingWriter(const std::string& path, const RecordAttributes& attributes)
    : path_(path), start_(std::chrono::steady_clock::now()) {
  RecordAttributes header{{"start", WallClockNow()}};
  header.insert(header.end(), attributes.begin(), attributes.end());
  const std::string line = FormatRecordHeader(header);
  file_ = std::fopen(path.c_str(), "wb");
  if (file_ == nullptr) {
    throw Error(StatusCode::kNotFound,
                "cannot create recording " + path + ": " + std::strerror(errno));
  }
  std::lock_guard<std::mutex> lock(mutex_);
  WriteLocked(line);
  lines_ = 0;
}

RecordingWriter::~RecordingWriter() {
  if (file_ != nullptr) std::fclose(file_);
}

void RecordingWriter::WriteFrame(Direction direction, const Frame& frame) {
  std::lock_guard<std::mutex> lock(mutex_);
  const double time =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  WriteLocked(FormatRecordLine(RecordedFrame{time, direction, frame}));
}

void RecordingWriter::WriteOpen(const RecordAttributes& attributes) {
  std::lock_guard<std::mutex> lock(mutex_);
  const double time =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  WriteLocked(FormatRecordLine(RecordedOpen{time, attributes}));
}

uint64_t RecordingWriter::lines() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return lines_;
}

void RecordingWriter::WriteLocked(const std::string& line) {
  const std::string text = line + '\n';
  if (std::fwrite(text.data(), 1, text.size(), file_) != text.size() ||
      std::fflush(file_) != 0) {
    throw Error(StatusCode::kUnavailable,
                "cannot write recording " + path_ + ": " + std::strerror(errno));
  }
  ++lines_;
}

}  // namespace yamor::snp
