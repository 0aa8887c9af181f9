// libFuzzer target for the daemon's settings TOML (host/settings.h, thesis
// C.1): a file a user hands yamord --settings. Input: the TOML text. Checks,
// aborting on violation:
//  - ParseSettingsToml never crashes and rejects only with INVALID_ARGUMENT
//    or OUT_OF_RANGE naming the source ("fuzz...");
//  - accepted settings validate, and their TOML (SettingsToToml) parses back
//    to settings that write the same TOML.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "common/status.h"
#include "host/settings.h"
#include "tests/fuzz/fuzz_assert.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  yamor::host::Settings settings;
  try {
    settings = yamor::host::ParseSettingsToml(text, "fuzz");
  } catch (const yamor::Error& e) {
    FUZZ_ASSERT(e.code() == yamor::StatusCode::kInvalidArgument ||
                e.code() == yamor::StatusCode::kOutOfRange);
    FUZZ_ASSERT(std::string_view(e.what()).substr(0, 4) == "fuzz");
    return 0;
  }
  yamor::host::ValidateSettings(settings);
  const std::string toml = yamor::host::SettingsToToml(settings);
  const yamor::host::Settings again = yamor::host::ParseSettingsToml(toml, "written");
  FUZZ_ASSERT(yamor::host::SettingsToToml(again) == toml);
  return 0;
}
