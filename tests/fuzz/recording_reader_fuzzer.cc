// libFuzzer target for the recorded-session reader (proto/snp/recording.h).
// Input: the text of a recording file. Checks, aborting on violation:
//  - ParseRecording never crashes and rejects only with INVALID_ARGUMENT
//    naming the source ("fuzz:LINE: ...");
//  - an accepted recording re-formats line by line into a text that parses
//    back to the same header and entries (the writer and reader agree).
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

#include "common/log.h"
#include "common/status.h"
#include "proto/snp/recording.h"

namespace {

using namespace yamor::snp;  // NOLINT: fuzzer-local brevity

#define FUZZ_ASSERT(condition)                                                \
  do {                                                                        \
    if (!(condition)) {                                                       \
      std::fprintf(stderr, "recording_reader_fuzzer: %s failed at line %d\n", \
                   #condition, __LINE__);                                     \
      std::abort();                                                           \
    }                                                                         \
  } while (false)

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  static const bool quiet = [] {
    yamor::SetLogLevel("off");  // torn-line warnings would flood the output
    return true;
  }();
  (void)quiet;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  Recording recording;
  try {
    recording = ParseRecording(text, "fuzz");
  } catch (const yamor::Error& e) {
    FUZZ_ASSERT(e.code() == yamor::StatusCode::kInvalidArgument);
    FUZZ_ASSERT(std::string_view(e.what()).substr(0, 5) == "fuzz:");
    return 0;
  }
  FUZZ_ASSERT(recording.torn_lines == 0 || recording.torn_lines == 1);
  // Re-format: times may lose digits beyond microseconds, so compare entries
  // after one more round trip (formatting is idempotent from then on).
  std::string again = FormatRecordHeader(recording.header) + "\n";
  for (const RecordEntry& entry : recording.entries) again += FormatRecordLine(entry) + "\n";
  const Recording first = ParseRecording(again, "fuzz");
  FUZZ_ASSERT(first.header == recording.header);
  FUZZ_ASSERT(first.entries.size() == recording.entries.size());
  std::string twice = FormatRecordHeader(first.header) + "\n";
  for (const RecordEntry& entry : first.entries) twice += FormatRecordLine(entry) + "\n";
  FUZZ_ASSERT(twice == again);
  for (std::size_t i = 0; i < first.entries.size(); ++i) {
    const auto* a = std::get_if<RecordedFrame>(&first.entries[i]);
    const auto* b = std::get_if<RecordedFrame>(&recording.entries[i]);
    FUZZ_ASSERT((a == nullptr) == (b == nullptr));
    if (a != nullptr) FUZZ_ASSERT(a->frame == b->frame && a->direction == b->direction);
  }
  return 0;
}
