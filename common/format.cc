#include "common/format.h"

#include <charconv>
#include <cmath>

namespace yamor {

std::string FormatDouble(double value) {
  if (std::isnan(value)) return "nan";  // not "-nan": a NaN's sign means nothing here
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  return std::string(buffer, result.ptr);
}

}  // namespace yamor
