#include "physics/morphology.h"

#include <filesystem>
#include <set>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "common/status.h"
#include "physics/placement.h"

namespace yamor::physics {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

const std::string kWorlds = std::string(YAMOR_SOURCE_DIR) + "/configs/worlds/";

// Runs Parse on `xml` and returns the error (fails the test when none).
Error ParseError(const std::string& xml) {
  try {
    Morphology::Parse(xml, "test.xml");
  } catch (const Error& error) {
    return error;
  }
  ADD_FAILURE() << "no error for:\n" << xml;
  return Error(StatusCode::kOk, "");
}

std::string TwoModules(const std::string& connect) {
  return "<morphology central=\"0\">\n"  // line 1
         "  <module id=\"0\"/>\n"         // line 2
         "  <module id=\"1\"/>\n"         // line 3
         "  " + connect + "\n"            // line 4
         "</morphology>\n";
}

TEST(MorphologyTest, ParsesAChain) {
  const Morphology m = Morphology::Parse(
      TwoModules(R"(<connect idfrom="1" connfrom="front" idto="0" connto="rear" angle="0"/>)"),
      "chain.xml");
  EXPECT_EQ(m.central(), 0);
  ASSERT_EQ(m.modules().size(), 2u);
  ASSERT_EQ(m.connections().size(), 1u);
  EXPECT_EQ(m.connections()[0].line, 4);
  EXPECT_TRUE(m.BodyPose(0).isApprox(Eigen::Isometry3d::Identity()));
  const Eigen::Isometry3d expected = MateBodyPose(
      Eigen::Isometry3d::Identity(), 0, ConnectorId::kRear, ConnectorId::kFront, 0, 0);
  EXPECT_TRUE(m.BodyPose(1).isApprox(expected, 1e-12));
  EXPECT_LT(m.BodyPose(1).translation().x(), -0.1);
}

TEST(MorphologyTest, AngleIsNormalisedAndOptional) {
  const Morphology m = Morphology::Parse(
      TwoModules(R"(<connect idfrom="1" connfrom="front" idto="0" connto="rear" angle="-90"/>)"),
      "a.xml");
  EXPECT_EQ(m.connections()[0].angle_steps, 18);
  const Morphology n = Morphology::Parse(
      TwoModules(R"(<connect idfrom="1" connfrom="front" idto="0" connto="rear"/>)"), "b.xml");
  EXPECT_EQ(n.connections()[0].angle_steps, 0);
}

struct BadCase {
  std::string name;
  std::string xml;
  std::vector<std::string> fragments;  // all must appear in the message
};

std::vector<BadCase> BadCases() {
  return {
      {"malformed", "<morphology central=\"0\">\n<module id=\"0\">\n</morphology>\n",
       {"test.xml:", "malformed XML"}},
      {"wrong_root", "<robot/>", {"test.xml:1", "<morphology>"}},
      {"unknown_connector",
       TwoModules(R"(<connect idfrom="1" connfrom="frnt" idto="0" connto="rear" angle="0"/>)"),
       {"test.xml:4", "module 1", "connfrom=\"frnt\"", "unknown connector"}},
      {"angle_not_multiple",
       TwoModules(R"(<connect idfrom="1" connfrom="front" idto="0" connto="rear" angle="10"/>)"),
       {"test.xml:4", "angle=\"10\"", "multiple of 15"}},
      {"angle_not_number",
       TwoModules(R"(<connect idfrom="1" connfrom="front" idto="0" connto="rear" angle="x"/>)"),
       {"test.xml:4", "angle=\"x\""}},
      {"unknown_module",
       TwoModules(R"(<connect idfrom="1" connfrom="front" idto="9" connto="rear" angle="0"/>)"),
       {"test.xml:4", "idto=\"9\"", "unknown module"}},
      {"bad_id", TwoModules(R"(<connect idfrom="a" connfrom="front" idto="0" connto="rear"/>)"),
       {"test.xml:4", "idfrom=\"a\""}},
      {"self", TwoModules(R"(<connect idfrom="1" connfrom="front" idto="1" connto="rear"/>)"),
       {"test.xml:4", "module 1", "itself"}},
      {"unknown_attribute",
       TwoModules(R"(<connect idfrom="1" connfrom="front" idto="0" conto="rear"/>)"),
       {"test.xml:4", "conto"}},
      {"unknown_element", TwoModules("<link/>"), {"test.xml:4", "<link>"}},
      {"connector_used",
       "<morphology central=\"0\">\n<module id=\"0\"/>\n<module id=\"1\"/>\n<module id=\"2\"/>\n"
       "<connect idfrom=\"1\" connfrom=\"front\" idto=\"0\" connto=\"rear\"/>\n"
       "<connect idfrom=\"2\" connfrom=\"front\" idto=\"0\" connto=\"rear\"/>\n</morphology>",
       {"test.xml:6", "module 0", "connto=\"rear\"", "already used", "line 5"}},
      {"duplicate_id",
       "<morphology central=\"0\">\n<module id=\"0\"/>\n<module id=\"0\"/>\n</morphology>",
       {"test.xml:3", "duplicate module id=\"0\""}},
      {"central_missing", "<morphology central=\"7\">\n<module id=\"0\"/>\n</morphology>",
       {"test.xml", "central module 7"}},
      {"central_attribute_missing", "<morphology>\n<module id=\"0\"/>\n</morphology>",
       {"test.xml:1", "central"}},
      {"central_free", "<morphology central=\"0\">\n<module id=\"0\" free=\"true\"/>\n</morphology>",
       {"test.xml:2", "central module 0", "free"}},
      {"not_connected",
       "<morphology central=\"0\">\n<module id=\"0\"/>\n<module id=\"5\"/>\n</morphology>",
       {"test.xml:3", "id=\"5\"", "not connected"}},
      {"free_connected",
       "<morphology central=\"0\">\n<module id=\"0\"/>\n<module id=\"1\" free=\"true\"/>\n"
       "<connect idfrom=\"1\" connfrom=\"front\" idto=\"0\" connto=\"rear\"/>\n</morphology>",
       {"test.xml:4", "idfrom=\"1\"", "free"}},
      {"overlap_handles",
       // Modules on the central's left and rear faces: their 60 mm wide handle
       // crossbars collide at the edge between the two faces.
       "<morphology central=\"0\">\n<module id=\"0\"/>\n<module id=\"1\"/>\n<module id=\"2\"/>\n"
       "<connect idfrom=\"1\" connfrom=\"front\" idto=\"0\" connto=\"left\" angle=\"0\"/>\n"
       "<connect idfrom=\"2\" connfrom=\"front\" idto=\"0\" connto=\"rear\" angle=\"0\"/>\n"
       "</morphology>",
       {"test.xml:6", "module id=\"2\" (crossbar)", "overlaps module id=\"1\" (crossbar)"}},
      {"start_angle_not_number",
       "<morphology central=\"0\">\n<module id=\"0\" angle=\"x\"/>\n</morphology>",
       {"test.xml:2", "module 0", "angle=\"x\"", "not a number of degrees"}},
      {"start_angle_not_finite",
       "<morphology central=\"0\">\n<module id=\"0\" angle=\"inf\"/>\n</morphology>",
       {"test.xml:2", "module 0", "angle=\"inf\""}},
      {"start_angle_beyond_the_stops",
       "<morphology central=\"0\">\n<module id=\"0\"/>\n<module id=\"1\" angle=\"-90.5\"/>\n"
       "</morphology>",
       {"test.xml:3", "module 1", "angle=\"-90.5\"", "hinge range"}},
      {"start_angle_on_a_free_module",
       "<morphology central=\"0\">\n<module id=\"0\"/>\n<module id=\"1\" free=\"true\" "
       "angle=\"30\"/>\n</morphology>",
       {"test.xml:3", "module 1", "free"}},
      {"overlap_at_the_start_angle",
       // Fine with 0's servo at 0 (1 sticks out in front); with 0's handle
       // turned up by the starting angle, 1 stands up into 2, which sits on
       // 0's top face.
       "<morphology central=\"0\">\n<module id=\"0\" angle=\"-90\"/>\n<module id=\"1\"/>\n"
       "<module id=\"2\"/>\n"
       "<connect idfrom=\"1\" connfrom=\"rear\" idto=\"0\" connto=\"front\"/>\n"
       "<connect idfrom=\"2\" connfrom=\"front\" idto=\"0\" connto=\"top\"/>\n"
       "</morphology>",
       {"test.xml:6", "module id=\"2\"", "overlaps module id=\"1\" (body)"}},
      {"overlap_bodies",
       // A chain that climbs up behind the central module and comes back down
       // onto it: module 4 lands inside module 0.
       "<morphology central=\"0\">\n"
       "<module id=\"0\"/><module id=\"1\"/><module id=\"2\"/><module id=\"3\"/>\n"
       "<module id=\"4\"/>\n"
       "<connect idfrom=\"1\" connfrom=\"front\" idto=\"0\" connto=\"rear\"/>\n"
       "<connect idfrom=\"2\" connfrom=\"front\" idto=\"1\" connto=\"top\"/>\n"
       "<connect idfrom=\"3\" connfrom=\"front\" idto=\"2\" connto=\"top\"/>\n"
       "<connect idfrom=\"4\" connfrom=\"front\" idto=\"3\" connto=\"top\"/>\n"
       "</morphology>",
       {"test.xml:7", "module id=\"4\"", "overlaps module id=\"0\" (body)"}},
  };
}

TEST(MorphologyTest, ValidationErrorsNameFileLineAndCulprit) {
  for (const BadCase& bad : BadCases()) {
    SCOPED_TRACE(bad.name);
    const Error error = ParseError(bad.xml);
    EXPECT_EQ(error.code(), StatusCode::kInvalidArgument);
    for (const std::string& fragment : bad.fragments) {
      EXPECT_THAT(error.what(), HasSubstr(fragment));
    }
  }
}

TEST(MorphologyTest, StartAnglesPlaceTheModulesOnBothSidesOfAHinge) {
  // 1 hangs on 0's handle, 2 carries 0 on its own handle: 0's starting angle
  // turns 1, 2's turns 2's body relative to 0.
  const Morphology m = Morphology::Parse(
      "<morphology central=\"0\">\n"
      "  <module id=\"0\" angle=\"30\"/>\n"
      "  <module id=\"1\"/>\n"
      "  <module id=\"2\" angle=\"-45.5\"/>\n"
      "  <connect idfrom=\"1\" connfrom=\"rear\" idto=\"0\" connto=\"front\"/>\n"
      "  <connect idfrom=\"2\" connfrom=\"front\" idto=\"0\" connto=\"rear\"/>\n"
      "</morphology>\n",
      "start.xml");
  EXPECT_EQ(m.Module(0).angle_degrees, 30.0);
  EXPECT_EQ(m.Module(1).angle_degrees, 0.0);
  EXPECT_DOUBLE_EQ(m.Module(2).StartAngle(), -45.5 * M_PI / 180);
  const Eigen::Isometry3d one = MateBodyPose(Eigen::Isometry3d::Identity(), M_PI / 6,
                                             ConnectorId::kFront, ConnectorId::kRear, 0, 0);
  EXPECT_TRUE(m.BodyPose(1).isApprox(one, 1e-12));
  const Eigen::Isometry3d two = MateBodyPose(Eigen::Isometry3d::Identity(), 0, ConnectorId::kRear,
                                             ConnectorId::kFront, -45.5 * M_PI / 180, 0);
  EXPECT_TRUE(m.BodyPose(2).isApprox(two, 1e-12));
  // The handle turned by +30° about +y puts 1 below 0's axis (tip towards -z).
  EXPECT_NEAR(m.BodyPose(1).translation().z(), -0.5 * (0.045 + 0.035 + 1e-4), 1e-9);
  // Written back with the angles, read back to the same poses.
  const std::string xml = m.ToXml();
  EXPECT_THAT(xml, HasSubstr("<module id=\"0\" angle=\"30\"/>"));
  EXPECT_THAT(xml, HasSubstr("<module id=\"1\"/>"));
  EXPECT_THAT(xml, HasSubstr("<module id=\"2\" angle=\"-45.5\"/>"));
  const Morphology again = Morphology::Parse(xml, "again");
  for (int id : {0, 1, 2}) {
    EXPECT_EQ(again.Module(id).angle_degrees, m.Module(id).angle_degrees);
    EXPECT_TRUE(again.BodyPose(id).isApprox(m.BodyPose(id), 1e-12));
  }
}

TEST(MorphologyTest, StartAnglesMustCloseTheLoop) {
  const Morphology wheel = Morphology::LoadFile(kWorlds + "wheel.xml");
  std::vector<MorphologyModule> modules = wheel.modules();
  for (const MorphologyModule& module : modules) EXPECT_NE(module.angle_degrees, 0.0);
  // One hinge bent 2° further: the hexagon no longer closes.
  modules.front().angle_degrees += 2.0;
  try {
    Morphology::Build(wheel.central(), modules, wheel.connections());
    FAIL() << "inconsistent loop accepted";
  } catch (const Error& error) {
    EXPECT_EQ(error.code(), StatusCode::kInvalidArgument);
    EXPECT_THAT(error.what(), HasSubstr("closes a loop"));
  }
  // Build validates the range as Parse does.
  modules = wheel.modules();
  modules.back().angle_degrees = 91.0;
  try {
    Morphology::Build(wheel.central(), modules, wheel.connections());
    FAIL() << "angle beyond the stops accepted";
  } catch (const Error& error) {
    EXPECT_EQ(error.code(), StatusCode::kInvalidArgument);
    EXPECT_THAT(error.what(), HasSubstr("hinge range"));
  }
}

TEST(MorphologyTest, LoopClosureMustAgree) {
  const Morphology wheel = Morphology::LoadFile(kWorlds + "wheel.xml");
  std::vector<MorphologyConnection> connections = wheel.connections();
  // Turning the closing connection by 15° breaks the loop.
  connections.back().angle_steps = (connections.back().angle_steps + 1) % 24;
  try {
    Morphology::Build(wheel.central(), wheel.modules(), connections);
    FAIL() << "inconsistent loop accepted";
  } catch (const Error& error) {
    EXPECT_EQ(error.code(), StatusCode::kInvalidArgument);
    EXPECT_THAT(error.what(), AllOf(HasSubstr("<built>:"), HasSubstr("closes a loop")));
  }
}

TEST(MorphologyTest, MissingFileIsNotFound) {
  try {
    Morphology::LoadFile(kWorlds + "no-such-robot.xml");
    FAIL();
  } catch (const Error& error) {
    EXPECT_EQ(error.code(), StatusCode::kNotFound);
    EXPECT_THAT(error.what(), HasSubstr("no-such-robot.xml"));
  }
}

TEST(MorphologyTest, FreeModulesHaveNoPose) {
  const Morphology m = Morphology::Parse(
      "<morphology central=\"0\"><module id=\"0\"/><module id=\"3\" free=\"true\"/></morphology>",
      "free.xml");
  EXPECT_TRUE(m.Module(3).free);
  try {
    m.BodyPose(3);
    FAIL();
  } catch (const Error& error) {
    EXPECT_EQ(error.code(), StatusCode::kFailedPrecondition);
  }
  try {
    m.Module(4);
    FAIL();
  } catch (const Error& error) {
    EXPECT_EQ(error.code(), StatusCode::kNotFound);
  }
}

TEST(MorphologyTest, CanonicalXmlRoundTrips) {
  for (const char* robot : {"quadruped", "wheel", "dog"}) {
    const Morphology m = Morphology::LoadFile(kWorlds + robot + ".xml");
    const Morphology again = Morphology::Parse(m.ToXml(), "round-trip");
    EXPECT_EQ(again.central(), m.central());
    for (const MorphologyModule& module : m.modules()) {
      EXPECT_TRUE(again.BodyPose(module.id).isApprox(m.BodyPose(module.id), 1e-12)) << robot;
    }
  }
}

TEST(MorphologyTest, ConnectedConnectorsCoincideInEveryWorld) {
  for (const auto& entry : std::filesystem::directory_iterator(kWorlds)) {
    if (entry.path().extension() != ".xml") continue;
    const Morphology m = Morphology::LoadFile(entry.path());
    for (const MorphologyConnection& c : m.connections()) {
      const WorldConnector a =
          ModuleConnector(m.BodyPose(c.from), m.Module(c.from).StartAngle(), c.from_connector);
      const WorldConnector b =
          ModuleConnector(m.BodyPose(c.to), m.Module(c.to).StartAngle(), c.to_connector);
      SCOPED_TRACE(entry.path().filename().string() + ":" + std::to_string(c.line));
      EXPECT_TRUE(a.normal.isApprox(-b.normal, 1e-9));
      EXPECT_NEAR((a.position - b.position).norm(), module::kConnectionGap, 1e-9);
      double angle = SignedAngle(b.north, a.north, b.normal);
      if (angle < -1e-9) angle += 2 * M_PI;
      EXPECT_NEAR(angle, c.angle_steps * module::kConnectionAngleStep, 1e-9);
    }
  }
}

struct RobotIds {
  const char* file;
  int central;
  std::set<int> ids;
};

TEST(MorphologyTest, RobotWorldsHaveTheConfiguredModuleIds) {
  const RobotIds robots[] = {
      {"quadruped", 4, {0, 1, 2, 3, 4, 5, 6, 7, 8}},
      {"snake", 0, {0, 1, 2, 3, 4, 5, 6, 7, 8}},
      {"trebuchet", 10, {1, 7, 10, 12}},
      {"dog", 11, {1, 5, 10, 11, 12}},
      {"wheel", 1, {1, 2, 3, 6, 7, 12}},
      {"tripod", 0, {0, 1, 2, 3, 4, 5, 6}},
  };
  for (const RobotIds& robot : robots) {
    const Morphology m = Morphology::LoadFile(kWorlds + robot.file + ".xml");
    EXPECT_EQ(m.central(), robot.central) << robot.file;
    std::set<int> ids;
    for (const MorphologyModule& module : m.modules()) ids.insert(module.id);
    EXPECT_EQ(ids, robot.ids) << robot.file;
  }
  // Quadruped: hip i carries knee i + 5; tripod: hip i carries knee i + 3.
  const Morphology quadruped = Morphology::LoadFile(kWorlds + "quadruped.xml");
  const Morphology tripod = Morphology::LoadFile(kWorlds + "tripod.xml");
  auto linked = [](const Morphology& m, int a, int b) {
    for (const MorphologyConnection& c : m.connections()) {
      if ((c.from == a && c.to == b) || (c.from == b && c.to == a)) return true;
    }
    return false;
  };
  for (int hip = 0; hip < 4; ++hip) {
    EXPECT_TRUE(linked(quadruped, hip, 4));
    EXPECT_TRUE(linked(quadruped, hip, hip + 5));
  }
  for (int hip = 1; hip <= 3; ++hip) {
    EXPECT_TRUE(linked(tripod, hip, 0));
    EXPECT_TRUE(linked(tripod, hip, hip + 3));
  }
}

}  // namespace
}  // namespace yamor::physics

namespace yamor::physics {
namespace {

// The LED sits on the central module's face that is up as built: +z for a
// module lying flat, another axis for one built on its side.
TEST(CentralUpAxisTest, IsTheCentralModulesAxisThatPointsUpAsBuilt) {
  EXPECT_TRUE(NearestFrameAxis({0.1, -0.9, 0.3}).isApprox(Eigen::Vector3d(0, -1, 0)));
  EXPECT_TRUE(NearestFrameAxis({0.5, 0.5, 0.1}).isApprox(Eigen::Vector3d(1, 0, 0))) << "ties go to x";
  for (const char* robot : {"quadruped", "snake", "wheel", "dog", "tripod", "trebuchet"}) {
    const Morphology m = Morphology::LoadFile(kWorlds + robot + ".xml");
    const Eigen::Vector3d up = CentralUpAxis(m);
    const Eigen::Vector3d world_up = m.BodyPose(m.central()).linear() * up;
    EXPECT_GT(world_up.z(), std::cos(M_PI / 4)) << robot << ": the axis points up within 45 degrees";
    EXPECT_NEAR(up.norm(), 1.0, 1e-12) << robot;
  }
  const Morphology quadruped = Morphology::LoadFile(kWorlds + std::string("quadruped.xml"));
  EXPECT_TRUE(CentralUpAxis(quadruped).isApprox(Eigen::Vector3d::UnitX()))
      << "the quadruped's central body is built on its side";
}

}  // namespace
}  // namespace yamor::physics
