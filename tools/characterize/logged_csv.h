// Logged accelerometer readings as CSV: what a lab logs from a real sensor
// board (and what `yamor-characterize noise` writes), read back with errors
// naming the file and line. Depends on common/ only (it has a fuzz target).
#pragma once

#include <array>
#include <filesystem>
#include <istream>
#include <string>
#include <vector>

namespace yamor::characterize {

/// One logged raw reading (a real sensor board, or a noise.csv written here).
/// Thread-safety: plain value.
struct LoggedReading {
  double time = 0;              ///< s, strictly increasing.
  std::array<int, 3> counts{};  ///< ADC codes, in [0, max_count].
};

/// Parses logged readings from CSV text whose header names `time`, `count_x`,
/// `count_y` and `count_z` (other columns are ignored; noise.csv qualifies).
/// kInvalidArgument naming "file:line" for a malformed, truncated or
/// out-of-range row, a missing column or no rows; `file` names the source.
std::vector<LoggedReading> ParseLoggedReadings(std::istream& in, const std::string& file,
                                               int max_count = 1023);

/// ParseLoggedReadings() of a file; kNotFound when it cannot be opened.
std::vector<LoggedReading> ReadLoggedReadings(const std::filesystem::path& path,
                                              int max_count = 1023);

}  // namespace yamor::characterize
