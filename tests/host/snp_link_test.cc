// SnpLink over the in-process simulation: bridge specials answer through
// bytes only, ids are mapped, the chunked morphology readback is the current
// morphology exactly.
#include "host/snp_link.h"

#include <gtest/gtest.h>

#include "bridge/robot.h"
#include "common/status.h"
#include "host/sim_backend.h"
#include "host/worlds.h"
#include "physics/world.h"
#include "tests/host/test_util.h"

namespace yamor::host {
namespace {

TEST(SnpLinkTest, MorphologyReadbackIsTheCurrentMorphologyAcrossChunks) {
  SimBackend backend(testing::SnakeWithSpares(), bridge::RobotOptions{});
  SnpLink link(backend, IdMap());
  const std::string xml = link.ReadMorphologyXml();
  EXPECT_GT(xml.size(), snp::kMaxMorphologyChunkSize);  // several chunks
  EXPECT_EQ(xml, backend.robot().world().CurrentMorphology().ToXml());
  link.BridgeRequest(snp::DisconnectModule{.module = 1}, snp::MessageType::kSpecialAck);
  const std::string after = link.ReadMorphologyXml();
  EXPECT_NE(after, xml);
  EXPECT_EQ(after, backend.robot().world().CurrentMorphology().ToXml());
}

TEST(SnpLinkTest, PipelinedReadbackOfEveryBuiltInWorldIsExactAndLeavesNothingBehind) {
  std::size_t largest = 0;
  for (const char* name : {"dog", "quadruped", "snake", "trebuchet", "tripod", "wheel"}) {
    SimBackend backend(ResolveWorld(WorldRequest{.world = name}, "quadruped", false).morphology,
                       bridge::RobotOptions{});
    SnpLink link(backend, IdMap());
    int unsolicited = 0;
    link.SetUnsolicitedHandler([&](const snp::Frame&) { ++unsolicited; });
    const std::string xml = link.ReadMorphologyXml();
    EXPECT_EQ(xml, backend.robot().world().CurrentMorphology().ToXml()) << name;
    EXPECT_EQ(link.ReadMorphologyXml(), xml) << name << ": read twice, same text";
    const snp::Message time =
        link.BridgeRequest(snp::GetSimTime{}, snp::MessageType::kSimTime);
    EXPECT_EQ(std::get<snp::SimTime>(time).seconds, 0.0);
    EXPECT_EQ(unsolicited, 0) << name << ": no reply left over from the pipelined reads";
    largest = std::max(largest, xml.size());
  }
  EXPECT_GT(largest, snp::kMaxMorphologyChunkSize);

  // A 40-module snake needs many more chunks than the window (4 in flight).
  std::string snake = "<morphology central=\"0\">";
  for (int i = 0; i < 40; ++i) snake += "<module id=\"" + std::to_string(i) + "\"/>";
  for (int i = 1; i < 40; ++i) {
    snake += "<connect idfrom=\"" + std::to_string(i) + "\" connfrom=\"front\" idto=\"" +
             std::to_string(i - 1) + "\" connto=\"rear\" angle=\"0\"/>";
  }
  snake += "</morphology>";
  SimBackend backend(physics::Morphology::Parse(snake, "snake40"), bridge::RobotOptions{});
  SnpLink link(backend, IdMap());
  const std::string xml = link.ReadMorphologyXml();
  EXPECT_GT(xml.size(), 8 * snp::kMaxMorphologyChunkSize);
  EXPECT_EQ(xml, backend.robot().world().CurrentMorphology().ToXml());
}

TEST(SnpLinkTest, SpecialsReachTheSimulationWithMappedIds) {
  SimBackend backend(testing::SnakeWithSpares(), bridge::RobotOptions{});
  SnpLink link(backend, IdMap(std::map<int, int>{{100, 2}}));
  EXPECT_EQ(link.Wire(100), 2);
  EXPECT_EQ(link.Real(2), 100);
  link.BridgeRequest(snp::SetMotorFault{.module = 100, .fault = snp::MotorFault::kStuck},
                     snp::MessageType::kSpecialAck);
  EXPECT_EQ(backend.robot().world().GetMotorFault(2), physics::MotorFault::kStuck);
  link.BridgeRequest(snp::SetModuleDefect{.module = 100, .defective = true},
                     snp::MessageType::kSpecialAck);
  EXPECT_TRUE(backend.robot().world().ModuleDefective(2));
  const snp::Message ground = link.BridgeRequest(
      snp::SetGround{.friction = 0.5, .slope = 0.1}, snp::MessageType::kGround);
  EXPECT_EQ(std::get<snp::Ground>(ground), (snp::Ground{0.5, 0.1, 0.0}));
  EXPECT_EQ(backend.robot().world().GroundFriction(), 0.5);
  const snp::Message info = link.BridgeRequest(snp::GetSimInfo{}, snp::MessageType::kSimInfo);
  EXPECT_EQ(std::get<snp::SimInfo>(info).time_step, backend.robot().world().options().time_step);
  const snp::Message d = link.BridgeRequest(snp::GetDivergence{}, snp::MessageType::kDivergence);
  EXPECT_FALSE(std::get<snp::Divergence>(d).diverged);
  link.BridgeRequest(snp::TurnUpsideDown{}, snp::MessageType::kSpecialAck);
}

TEST(SnpLinkTest, SpecialErrorsCarryTheirCode) {
  SimBackend backend(testing::SnakeWithSpares(), bridge::RobotOptions{});
  SnpLink link(backend, IdMap());
  try {
    link.BridgeRequest(snp::SetGround{.friction = 1000.0}, snp::MessageType::kGround);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kOutOfRange) << e.what();
  }
  try {
    link.BridgeRequest(snp::ReadMorphology{.offset = 5, .length = 10},
                       snp::MessageType::kMorphologyChunk);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kFailedPrecondition) << e.what();
  }
}

}  // namespace
}  // namespace yamor::host
