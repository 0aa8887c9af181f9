// Shared helpers of the host tests.
#pragma once

#include <fstream>
#include <ostream>
#include <sstream>
#include <string>

#include "bridge/robot.h"
#include "physics/world.h"
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

/// The text of a file of the source tree (path relative to its root).
inline std::string ReadSourceFile(const std::string& relative) {
  std::ifstream in(kSourceDir + "/" + relative, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

/// configs/worlds/snake.xml with spares 9, 10 and 11.
inline physics::Morphology SnakeWithSpares() {
  const physics::Morphology snake =
      physics::Morphology::LoadFile(kSourceDir + "/configs/worlds/snake.xml");
  std::vector<physics::MorphologyModule> modules = snake.modules();
  for (int id : {9, 10, 11}) modules.push_back({id, true, 0});
  return physics::Morphology::Build(snake.central(), modules, snake.connections(),
                                    snake.orientation_degrees(), "snake+spares");
}

/// Reconfigures a SnakeWithSpares() world into a body that has room as it is
/// but no valid morphology at its starting angles: 9 on module 1 folds over
/// module 0, 10 stands on 9 and 11 on module 0; with 9 upright again 10 would
/// lie across 11.
inline void MakeUnplaceable(physics::World& world) {
  world.Connect(9, physics::ConnectorId::kFront, 1, physics::ConnectorId::kTop, 0);
  world.SetMotorEnabled(9, true);  // a bridge's modules start unpowered
  world.SetServoTarget(9, 1.4);
  world.Step(300);  // 0.6 s: 9 is at 1.4 rad
  world.Connect(11, physics::ConnectorId::kFront, 0, physics::ConnectorId::kTop, 0);
  world.Connect(10, physics::ConnectorId::kFront, 9, physics::ConnectorId::kTop, 0);
}

}  // namespace yamor::host::testing
