// libFuzzer target for the batch start TOML
// (optimizer-plugins/framework/run_setup.h, thesis D.2.2): a file a user
// hands yamor-optimize --batch. Input: the TOML text. Checks, aborting on
// violation:
//  - ParseBatchToml never crashes and rejects only with INVALID_ARGUMENT
//    naming the source ("fuzz...");
//  - an accepted batch has at least one instance, unique names that are safe
//    results subfolder names ([A-Za-z0-9_.-]+, not "." or ".."), and set
//    fields with non-empty keys.
#include <cstddef>
#include <cstdint>
#include <set>
#include <string>
#include <string_view>

#include "common/status.h"
#include "optimizer-plugins/framework/run_setup.h"
#include "tests/fuzz/fuzz_assert.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  std::vector<yamor::optimizer::BatchInstance> instances;
  try {
    instances = yamor::optimizer::ParseBatchToml(text, "fuzz", 7);
  } catch (const yamor::Error& e) {
    FUZZ_ASSERT(e.code() == yamor::StatusCode::kInvalidArgument);
    FUZZ_ASSERT(std::string_view(e.what()).substr(0, 4) == "fuzz");
    return 0;
  }
  FUZZ_ASSERT(!instances.empty());
  std::set<std::string> names;
  for (const auto& instance : instances) {
    FUZZ_ASSERT(names.insert(instance.name).second);
    FUZZ_ASSERT(!instance.name.empty() && instance.name != "." && instance.name != "..");
    for (char c : instance.name) {
      FUZZ_ASSERT((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                  c == '_' || c == '-' || c == '.');
    }
    for (const auto& [key, value] : instance.set) FUZZ_ASSERT(!key.empty());
  }
  return 0;
}
