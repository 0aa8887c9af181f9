// libFuzzer target for the morphology XML (physics/morphology.h,
// docs/module.md): a file a user hands yamord --world, OpenWorld or
// yamor-optimize --morphology. Input: the XML text. Checks, aborting on
// violation:
//  - Morphology::Parse never crashes and rejects only with INVALID_ARGUMENT
//    naming the source ("fuzz...");
//  - an accepted morphology's canonical XML parses back to the same XML;
//  - an accepted morphology builds an ODE world (or is refused with
//    INVALID_ARGUMENT for a static box the robot starts in) that steps (validation
//    happens before ODE: an ODE error, which would end the daemon, is a
//    finding), and whose state stays finite or is reported as diverged.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "common/log.h"
#include "common/status.h"
#include "physics/morphology.h"
#include "physics/ode_runtime.h"
#include "physics/world.h"
#include "tests/fuzz/fuzz_assert.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const bool quiet = [] {
    yamor::SetLogLevel("off");
    return true;
  }();
  (void)quiet;
  const std::string_view xml(reinterpret_cast<const char*>(data), size);
  std::optional<yamor::physics::Morphology> morphology;
  try {
    morphology.emplace(yamor::physics::Morphology::Parse(xml, "fuzz"));
  } catch (const yamor::Error& e) {
    FUZZ_ASSERT(e.code() == yamor::StatusCode::kInvalidArgument);
    FUZZ_ASSERT(std::string_view(e.what()).substr(0, 4) == "fuzz");
    return 0;
  }
  const std::string canonical = morphology->ToXml();
  const auto again = yamor::physics::Morphology::Parse(canonical, "canonical");
  FUZZ_ASSERT(again.ToXml() == canonical);
  FUZZ_ASSERT(again.modules().size() == morphology->modules().size());

  std::optional<yamor::physics::World> world_slot;
  try {
    world_slot.emplace(*morphology);
  } catch (const yamor::Error& e) {
    // The one refusal left to the world: a static box the robot starts in.
    FUZZ_ASSERT(e.code() == yamor::StatusCode::kInvalidArgument);
    FUZZ_ASSERT(std::string_view(e.what()).find("box") != std::string_view::npos);
    return 0;
  }
  try {
    yamor::physics::World& world = *world_slot;
    world.Step(25);
    if (!world.Diverged()) {
      FUZZ_ASSERT(world.CentralPosition().allFinite());
    }
  } catch (const yamor::physics::OdeFailure& e) {
    std::fprintf(stderr, "morphology_fuzzer: ODE failed on an accepted morphology: %s\n",
                 e.what());
    std::abort();
  }
  return 0;
}
