// Number formatting shared by messages and files.
#pragma once

#include <string>

namespace yamor {

/// The shortest text that reads back as exactly `value` ("0.1", "1e-06",
/// "-0.17456107565099988"); "nan", "inf" and "-inf" for non-finite values.
/// Thread-safety: a pure function.
std::string FormatDouble(double value);

}  // namespace yamor
