// SnpLink over the in-process simulation: bridge specials answer through
// bytes only, ids are mapped, the chunked morphology readback is the current
// morphology exactly.
#include "host/snp_link.h"

#include <gtest/gtest.h>

#include "bridge/robot.h"
#include "common/status.h"
#include "host/sim_backend.h"
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
