// libFuzzer target for transformation scripts (physics/script.h, thesis
// C.2.7): a file a user hands RunScript. Input: the script XML. Checks,
// aborting on violation:
//  - TransformationScript::Parse never crashes and rejects only with
//    INVALID_ARGUMENT naming the source ("fuzz:LINE: ...");
//  - an accepted script with at most kMaxPauseMs of pauses runs against a
//    quadruped with two spare modules: it completes or fails with a caller
//    code (NOT_FOUND, INVALID_ARGUMENT, FAILED_PRECONDITION) naming the
//    script's line, never with an ODE error (validation happens before ODE,
//    whose errors would end the daemon), and the world's robot stays a valid
//    morphology or says why not.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include "common/log.h"
#include "common/status.h"
#include "physics/morphology.h"
#include "physics/ode_runtime.h"
#include "physics/script.h"
#include "physics/world.h"
#include "tests/fuzz/fuzz_assert.h"

namespace {

// configs/worlds/quadruped.xml plus spares 9 and 10.
constexpr std::string_view kWorld = R"(<morphology central="4" orientation="0 -90 0">
  <module id="0"/><module id="1"/><module id="2"/><module id="3"/><module id="4"/>
  <module id="5"/><module id="6"/><module id="7"/><module id="8"/>
  <module id="9" free="true"/><module id="10" free="true"/>
  <connect idfrom="0" connfrom="front" idto="4" connto="bottom" angle="270"/>
  <connect idfrom="1" connfrom="front" idto="4" connto="left" angle="0"/>
  <connect idfrom="2" connfrom="front" idto="4" connto="top" angle="270"/>
  <connect idfrom="3" connfrom="front" idto="4" connto="right" angle="180"/>
  <connect idfrom="5" connfrom="front" idto="0" connto="rear" angle="270"/>
  <connect idfrom="6" connfrom="front" idto="1" connto="rear" angle="270"/>
  <connect idfrom="7" connfrom="front" idto="2" connto="rear" angle="270"/>
  <connect idfrom="8" connfrom="front" idto="3" connto="rear" angle="270"/>
</morphology>)";

// Longer scripts parse but do not run (a day of pauses would stall the fuzzer).
constexpr long kMaxPauseMs = 200;

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static std::unique_ptr<yamor::physics::World> world = [] {
    yamor::SetLogLevel("off");
    return std::make_unique<yamor::physics::World>(
        yamor::physics::Morphology::Parse(kWorld, "script_fuzzer world"));
  }();
  const std::string_view xml(reinterpret_cast<const char*>(data), size);
  std::optional<yamor::physics::TransformationScript> script;
  try {
    script.emplace(yamor::physics::TransformationScript::Parse(xml, "fuzz"));
  } catch (const yamor::Error& e) {
    FUZZ_ASSERT(e.code() == yamor::StatusCode::kInvalidArgument);
    FUZZ_ASSERT(std::string_view(e.what()).substr(0, 5) == "fuzz:");
    return 0;
  }
  long pauses = 0;
  for (const auto& command : script->commands()) {
    if (command.kind == yamor::physics::ScriptCommand::Kind::kPause) pauses += command.delay_ms;
  }
  if (pauses > kMaxPauseMs) return 0;

  world->Reset();
  try {
    yamor::physics::RunScript(*world, *script);
  } catch (const yamor::physics::OdeFailure& e) {
    std::fprintf(stderr, "script_fuzzer: ODE failed running an accepted script: %s\n", e.what());
    std::abort();
  } catch (const yamor::Error& e) {
    FUZZ_ASSERT(e.code() == yamor::StatusCode::kNotFound ||
                e.code() == yamor::StatusCode::kInvalidArgument ||
                e.code() == yamor::StatusCode::kFailedPrecondition);
    FUZZ_ASSERT(std::string_view(e.what()).substr(0, 5) == "fuzz:");
  }
  try {
    (void)world->CurrentMorphology();
  } catch (const yamor::physics::OdeFailure& e) {
    std::abort();
  } catch (const yamor::Error& e) {
    FUZZ_ASSERT(e.code() == yamor::StatusCode::kFailedPrecondition);
  }
  return 0;
}
