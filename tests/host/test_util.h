// Shared helpers of the host tests.
#pragma once

#include <ostream>
#include <string>

#include "bridge/robot.h"
#include "cpg/config_xml.h"
#include "proto/snp/snp.h"

namespace yamor::snp {
// Readable frames in gtest failure messages.
inline void PrintTo(const Frame& frame, std::ostream* os) {
  *os << ToString(frame.source) << " -> " << ToString(frame.destination) << " "
      << MessageTypeName(frame.type) << " [";
  for (uint8_t b : frame.payload.bytes()) *os << ' ' << static_cast<int>(b);
  *os << " ]";
}
}  // namespace yamor::snp

namespace yamor::host::testing {

inline const std::string kSourceDir = YAMOR_SOURCE_DIR;

/// A four-module robot: tree 0 -> 1, 0 -> 2, 1 -> 3; couplings 1 <-> 2.
inline constexpr const char* kSmallConfigXml = R"(<?xml version="1.0"?>
<yamorconfig master="0">
  <modulelist>
    <module realid="0" amplitude="0" offset="0" speed="0" minangle="-1" maxangle="1">
      <bluetooth to="1"/>
      <bluetooth to="2"/>
    </module>
    <module realid="1" amplitude="0.5" offset="0.1" speed="0.5" minangle="-1" maxangle="1">
      <bluetooth to="3"/>
      <cpglink to="2" phase="1.5" weight="1"/>
    </module>
    <module realid="2" amplitude="0.5" offset="0" speed="0.5" minangle="-1" maxangle="1">
      <cpglink to="1" phase="-1.5" weight="2"/>
    </module>
    <module realid="3" amplitude="0.3" offset="0" speed="0.5" minangle="-0.5" maxangle="0.5"/>
  </modulelist>
</yamorconfig>
)";

inline cpg::RobotConfig SmallConfig() { return cpg::ParseConfigXml(kSmallConfigXml, "small"); }

inline cpg::RobotConfig QuadrupedConfig() {
  return cpg::LoadConfigFile(kSourceDir + "/configs/robots/quadruped.xml");
}

inline snp::Frame ToModule(int id, const snp::Message& m) {
  return snp::MakeFrame(snp::Address::Host(), snp::Address::Module(static_cast<uint8_t>(id)), m);
}

inline snp::Frame ToBridge(const snp::Message& m) {
  return snp::MakeFrame(snp::Address::Host(), snp::Address::Bridge(), m);
}

/// True once the emulated robot implements the reconfiguration bridge
/// commands (ConnectModules / DisconnectModule); until then the driver
/// reports UNIMPLEMENTED for them.
inline bool BridgeReconfigures() {
  bridge::Robot robot(
      physics::Morphology::LoadFile(kSourceDir + "/configs/worlds/quadruped.xml"));
  std::vector<snp::Frame> out;
  robot.HandleFrame(ToBridge(snp::DisconnectModule{.module = 8}), out);
  return !out.empty() && out.front().type == snp::MessageType::kSpecialAck;
}

}  // namespace yamor::host::testing
