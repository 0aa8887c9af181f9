// libFuzzer target for the robot configuration XML (cpg/config_xml.h, thesis
// C.4): a file a user hands yamord --config, LoadConfig or yamor-cpg-run.
// Input: the XML text. Checks, aborting on violation:
//  - ParseConfigXml never crashes and rejects only with INVALID_ARGUMENT
//    naming the source ("fuzz:LINE: ...");
//  - an accepted configuration is valid, writes to canonical XML that parses
//    back to an equal configuration, and writing that again gives the same
//    text (the writer is a fixed point);
//  - its oscillator network compiles and one simulated second of RK4 steps
//    gives finite set-points inside each module's [min, max] angles.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "common/status.h"
#include "cpg/config_xml.h"
#include "cpg/network.h"
#include "cpg/robot_config.h"
#include "tests/fuzz/fuzz_assert.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view xml(reinterpret_cast<const char*>(data), size);
  yamor::cpg::RobotConfig config;
  try {
    config = yamor::cpg::ParseConfigXml(xml, "fuzz");
  } catch (const yamor::Error& e) {
    FUZZ_ASSERT(e.code() == yamor::StatusCode::kInvalidArgument);
    FUZZ_ASSERT(std::string_view(e.what()).substr(0, 5) == "fuzz:");
    return 0;
  }
  yamor::cpg::Validate(config);  // throws (a finding) if the reader let anything through
  const std::string canonical = yamor::cpg::WriteConfigXml(config);
  const yamor::cpg::RobotConfig again = yamor::cpg::ParseConfigXml(canonical, "canonical");
  FUZZ_ASSERT(yamor::cpg::WriteConfigXml(again) == canonical);
  FUZZ_ASSERT(again.modules == config.modules);
  FUZZ_ASSERT(again.bluetooth_parent == config.bluetooth_parent);
  FUZZ_ASSERT(again.master_id == config.master_id);
  FUZZ_ASSERT(again.couplings.size() == config.couplings.size());

  const yamor::cpg::Network network = yamor::cpg::Network::Compile(config);
  yamor::cpg::NetworkState state = network.InitialState(1);
  std::vector<std::optional<double>> set_points;
  for (int step = 0; step < 100; ++step) {
    yamor::cpg::Step(network, state, 0.01);
    yamor::cpg::SetPoints(network, state, set_points);
    for (std::size_t i = 0; i < set_points.size(); ++i) {
      FUZZ_ASSERT(set_points[i].has_value());
      const double angle = *set_points[i];
      FUZZ_ASSERT(std::isfinite(angle));
      FUZZ_ASSERT(angle >= network.min_angle(i) && angle <= network.max_angle(i));
    }
  }
  return 0;
}
