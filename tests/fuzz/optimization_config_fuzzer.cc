// libFuzzer target for the optimization configuration XML
// (optimizer-plugins/framework/optimization_config.h, thesis 5.7.2): a file a
// user hands yamor-optimize --config, with muParser expressions in its
// constrain rules. Input: the XML text. Checks, aborting on violation:
//  - OptimizationConfig::Parse never crashes and rejects only with
//    INVALID_ARGUMENT naming the source ("fuzz:...");
//  - an accepted configuration resolves its start point, and every corner
//    and the centre of its bounds box either resolve to finite values inside
//    what the modules accept or are refused with INVALID_ARGUMENT; a
//    resolved point applies to a valid robot whose XML parses back.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "common/log.h"
#include "common/status.h"
#include "cpg/config_xml.h"
#include "optimizer-plugins/framework/optimization_config.h"
#include "tests/fuzz/fuzz_assert.h"

namespace {

using yamor::optimizer::OptimizationConfig;

void CheckPoint(const OptimizationConfig& config, const std::vector<double>& x) {
  try {
    const auto values = config.Resolve(x);
    FUZZ_ASSERT(values.size() == config.optimized().size() + config.constrained().size());
    for (const auto& [name, value] : values) FUZZ_ASSERT(std::isfinite(value));
    const yamor::cpg::RobotConfig robot = config.Apply(x);
    yamor::cpg::Validate(robot);
    const std::string xml = yamor::cpg::WriteConfigXml(robot);
    FUZZ_ASSERT(yamor::cpg::ParseConfigXml(xml, "applied") == robot);
  } catch (const yamor::Error& e) {
    FUZZ_ASSERT(e.code() == yamor::StatusCode::kInvalidArgument);
    FUZZ_ASSERT(std::string_view(e.what()).substr(0, 4) == "fuzz");
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const bool quiet = [] {
    yamor::SetLogLevel("off");  // rule warnings would flood the output
    return true;
  }();
  (void)quiet;
  const std::string xml(reinterpret_cast<const char*>(data), size);
  OptimizationConfig config;
  try {
    config = OptimizationConfig::Parse(xml, "fuzz");
  } catch (const yamor::Error& e) {
    FUZZ_ASSERT(e.code() == yamor::StatusCode::kInvalidArgument);
    FUZZ_ASSERT(std::string_view(e.what()).substr(0, 5) == "fuzz:");
    return 0;
  }
  const std::vector<double> start = config.StartValues();
  FUZZ_ASSERT(start.size() == config.optimized().size());
  CheckPoint(config, start);  // Parse evaluated it already: must resolve
  (void)config.Resolve(start);
  (void)yamor::cpg::ParseConfigXml(config.RobotXml(), "robot");

  const std::size_t n = config.optimized().size();
  std::vector<double> centre(n);
  for (std::size_t i = 0; i < n; ++i) {
    centre[i] = 0.5 * (config.optimized()[i].min + config.optimized()[i].max);
  }
  CheckPoint(config, centre);
  const std::size_t corners = n < 6 ? (std::size_t{1} << n) : 64;
  for (std::size_t mask = 0; mask < corners; ++mask) {
    std::vector<double> corner(n);
    for (std::size_t i = 0; i < n; ++i) {
      const bool high = i < 64 && ((mask >> (i % 64)) & 1) != 0;
      corner[i] = high ? config.optimized()[i].max : config.optimized()[i].min;
    }
    CheckPoint(config, corner);
  }
  return 0;
}
