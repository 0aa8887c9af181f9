#include "tools/characterize/logged_csv.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "common/status.h"

namespace yamor::characterize {

std::vector<LoggedReading> ReadLoggedReadings(const std::filesystem::path& path, int max_count) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(StatusCode::kNotFound, "cannot open " + path.string());
  return ParseLoggedReadings(in, path.string(), max_count);
}

std::vector<LoggedReading> ParseLoggedReadings(std::istream& in, const std::string& file,
                                               int max_count) {
  auto bad = [&](size_t line, const std::string& what) {
    return Error(StatusCode::kInvalidArgument, file + ":" + std::to_string(line) + ": " + what);
  };
  auto split = [](const std::string& line) {
    std::vector<std::string> fields;
    std::string field;
    std::istringstream stream(line);
    while (std::getline(stream, field, ',')) fields.push_back(field);
    if (!line.empty() && line.back() == ',') fields.emplace_back();
    return fields;
  };
  std::string line;
  if (!std::getline(in, line)) throw bad(1, "empty file, expected a header");
  if (!line.empty() && line.back() == '\r') line.pop_back();
  const std::vector<std::string> header = split(line);
  std::array<size_t, 4> column{};
  const std::array<const char*, 4> names{"time", "count_x", "count_y", "count_z"};
  for (size_t i = 0; i < names.size(); ++i) {
    const auto it = std::find(header.begin(), header.end(), names[i]);
    if (it == header.end()) throw bad(1, std::string("header has no column '") + names[i] + "'");
    column[i] = static_cast<size_t>(it - header.begin());
  }
  std::vector<LoggedReading> readings;
  size_t number = 1;
  while (std::getline(in, line)) {
    ++number;
    const bool complete = !in.eof();  // the last line of a whole file ends in a newline
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    const std::vector<std::string> fields = split(line);
    if (fields.size() != header.size()) {
      throw bad(number, std::to_string(fields.size()) + " fields, the header has " +
                            std::to_string(header.size()) +
                            (complete ? "" : " (truncated last line)"));
    }
    LoggedReading r;
    const std::string& t = fields[column[0]];
    char* end = nullptr;
    r.time = std::strtod(t.c_str(), &end);
    if (t.empty() || *end != '\0' || !std::isfinite(r.time)) {
      throw bad(number, "time '" + t + "' is not a finite number");
    }
    if (!readings.empty() && r.time <= readings.back().time) {
      throw bad(number, "time " + t + " does not increase");
    }
    for (size_t axis = 0; axis < 3; ++axis) {
      const std::string& c = fields[column[axis + 1]];
      const long value = std::strtol(c.c_str(), &end, 10);
      if (c.empty() || *end != '\0') throw bad(number, std::string(names[axis + 1]) + " '" + c + "' is not an integer");
      if (value < 0 || value > max_count) {
        throw bad(number, std::string(names[axis + 1]) + " " + c + " outside [0, " +
                              std::to_string(max_count) + "]");
      }
      r.counts[axis] = static_cast<int>(value);
    }
    readings.push_back(r);
  }
  if (readings.empty()) throw bad(number, "no readings after the header");
  return readings;
}

}  // namespace yamor::characterize
