// libFuzzer target for the scene snapshot decoder (proto/snp/scene.h): the
// bytes a peer (yamor-bridge on a serial line or TCP) serves in SceneChunk
// replies. Checks, aborting on violation:
//  - DecodeSceneSnapshot never crashes and rejects only with INVALID_ARGUMENT;
//  - accepted bytes re-encode to exactly the same bytes.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <algorithm>
#include <cstdlib>
#include <span>
#include <vector>

#include "common/status.h"
#include "proto/snp/scene.h"

#define FUZZ_ASSERT(condition)                                                            \
  do {                                                                                    \
    if (!(condition)) {                                                                   \
      std::fprintf(stderr, "scene_snapshot_fuzzer: %s failed at line %d\n", #condition,   \
                   __LINE__);                                                             \
      std::abort();                                                                       \
    }                                                                                     \
  } while (false)

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  const std::span<const uint8_t> bytes(data, size);
  yamor::snp::SceneSnapshot scene;
  try {
    scene = yamor::snp::DecodeSceneSnapshot(bytes);
  } catch (const yamor::Error& e) {
    FUZZ_ASSERT(e.code() == yamor::StatusCode::kInvalidArgument);
    return 0;
  }
  const std::vector<uint8_t> again = yamor::snp::EncodeSceneSnapshot(scene);
  FUZZ_ASSERT(again.size() == size);
  FUZZ_ASSERT(std::equal(again.begin(), again.end(), bytes.begin()));
  return 0;
}
