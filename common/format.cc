#include "common/format.h"

#include <charconv>
#include <cmath>
#include <sstream>

namespace yamor {

std::string FormatDouble(double value) {
  if (std::isnan(value)) return "nan";  // not "-nan": a NaN's sign means nothing here
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  return std::string(buffer, result.ptr);
}

std::string FormatRounded(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

}  // namespace yamor
