// libFuzzer target for the logged-readings CSV reader
// (tools/characterize/logged_csv.h): a file a lab hands yamor-characterize.
// Input: the CSV text. Checks, aborting on violation:
//  - ParseLoggedReadings never crashes and rejects only with INVALID_ARGUMENT
//    naming the source and a line ("fuzz:LINE: ...");
//  - accepted readings have codes in [0, 1023] and strictly increasing times.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>

#include "common/status.h"
#include "tools/characterize/logged_csv.h"

#define FUZZ_ASSERT(condition)                                                            \
  do {                                                                                    \
    if (!(condition)) {                                                                   \
      std::fprintf(stderr, "logged_csv_fuzzer: %s failed at line %d\n", #condition, __LINE__); \
      std::abort();                                                                       \
    }                                                                                     \
  } while (false)

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  try {
    const auto readings = yamor::characterize::ParseLoggedReadings(in, "fuzz");
    FUZZ_ASSERT(!readings.empty());
    for (std::size_t i = 0; i < readings.size(); ++i) {
      for (int c : readings[i].counts) FUZZ_ASSERT(c >= 0 && c <= 1023);
      if (i > 0) FUZZ_ASSERT(readings[i].time > readings[i - 1].time);
    }
  } catch (const yamor::Error& e) {
    FUZZ_ASSERT(e.code() == yamor::StatusCode::kInvalidArgument);
    FUZZ_ASSERT(std::string(e.what()).rfind("fuzz:", 0) == 0);
  }
  return 0;
}
