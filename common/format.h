// Number formatting shared by messages and files.
#pragma once

#include <string>

namespace yamor {

/// The shortest text that reads back as exactly `value` ("0.1", "1e-06",
/// "-0.17456107565099988"); "nan", "inf" and "-inf" for non-finite values.
/// Thread-safety: a pure function.
std::string FormatDouble(double value);

/// At most 6 significant digits ("0.15" for 0.15000000000000002, "2",
/// "1e-06"), for messages where the last bits are noise (times, timeouts).
/// Thread-safety: a pure function.
std::string FormatRounded(double value);

}  // namespace yamor
