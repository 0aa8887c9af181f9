// Static boxes of a world (tables, platforms): parsing and validation, the
// robot standing on them, falling off them, and what the world keeps of them.
#include <cmath>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "common/status.h"
#include "physics/morphology.h"
#include "physics/world.h"

namespace yamor::physics {
namespace {

using ::testing::HasSubstr;

const std::string kWorlds = std::string(YAMOR_SOURCE_DIR) + "/configs/worlds/";

// One module with `boxes` (XML elements) in its world.
std::string OneModuleXml(const std::string& boxes) {
  return "<morphology central=\"0\">\n  <module id=\"0\"/>\n" + boxes + "</morphology>\n";
}

// The quadruped's world file with `boxes` added before its closing tag.
std::string QuadrupedXml(const std::string& boxes) {
  Morphology quadruped = Morphology::LoadFile(kWorlds + "quadruped.xml");
  std::string xml = quadruped.ToXml();
  xml.insert(xml.rfind("</morphology>"), boxes);
  return xml;
}

// The message of the yamor::Error `f` throws, with its code checked.
template <typename F>
std::string ErrorOf(F&& f, StatusCode code) {
  try {
    f();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), code) << e.what();
    return e.what();
  }
  ADD_FAILURE() << "no error thrown";
  return "";
}

// Drives the quadruped's hips and knees with an open-loop gait for one step.
void GaitStep(World& world) {
  const double t = world.Time();
  for (int hip = 0; hip < 4; ++hip) {
    world.SetServoTarget(hip, 0.6 * std::sin(2 * M_PI * t + hip * 1.3));
    world.SetServoTarget(hip + 5, -0.8 + 0.5 * std::sin(2 * M_PI * t + hip * 1.3 + 2.0));
  }
  world.Step();
}

int Steps(const World& world, double seconds) {
  return static_cast<int>(std::lround(seconds / world.options().time_step));
}

TEST(StaticBoxTest, ParsedWithDefaultsAndWrittenBack) {
  const Morphology m = Morphology::Parse(
      OneModuleXml("  <box name=\"table\" size=\"0.5 0.4 0.3\" position=\"0 0 0.15\"/>\n"
                   "  <box size=\"1 1 0.1\" position=\"2 0 0.05\" orientation=\"0 0 30\"/>\n"),
      "w.xml");
  ASSERT_EQ(m.boxes().size(), 2u);
  EXPECT_EQ(m.boxes()[0].name, "table");
  EXPECT_TRUE(m.boxes()[0].size.isApprox(Eigen::Vector3d(0.5, 0.4, 0.3)));
  EXPECT_EQ(m.boxes()[0].line, 3);
  EXPECT_EQ(m.boxes()[1].name, "box 2");
  EXPECT_TRUE(m.boxes()[1].orientation_degrees.isApprox(Eigen::Vector3d(0, 0, 30)));
  const Eigen::Vector3d x_axis = m.boxes()[1].Pose().linear().col(0);
  EXPECT_NEAR(std::atan2(x_axis.y(), x_axis.x()), M_PI / 6, 1e-12);
  const Morphology again = Morphology::Parse(m.ToXml(), "again");
  ASSERT_EQ(again.boxes().size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(again.boxes()[i].name, m.boxes()[i].name);
    EXPECT_EQ(again.boxes()[i].size, m.boxes()[i].size);
    EXPECT_EQ(again.boxes()[i].position, m.boxes()[i].position);
    EXPECT_EQ(again.boxes()[i].orientation_degrees, m.boxes()[i].orientation_degrees);
  }
  EXPECT_EQ(again.ToXml(), m.ToXml());
  // Names with XML's special characters and line breaks survive the round trip.
  const Morphology odd = Morphology::Parse(
      OneModuleXml("  <box name=\"a &quot;b&quot; &lt;&amp;&gt;&#10;c\" size=\"1 1 1\" position=\"5 0 0.5\"/>\n"),
      "w.xml");
  EXPECT_EQ(odd.boxes()[0].name, "a \"b\" <&>\nc");
  EXPECT_EQ(Morphology::Parse(odd.ToXml(), "again").boxes()[0].name, odd.boxes()[0].name);
  EXPECT_EQ(Morphology::Parse(odd.ToXml(), "again").ToXml(), odd.ToXml());
  // A world without boxes writes none.
  EXPECT_THAT(Morphology::LoadFile(kWorlds + "snake.xml").ToXml(), ::testing::Not(HasSubstr("<box")));
}

TEST(StaticBoxTest, BadBoxesAreRejectedNamingTheValueFileAndLine) {
  struct Case {
    std::string box;
    std::string expected;
  };
  const Case cases[] = {
      {"<box name=\"t\" size=\"0.5 0 0.3\"/>", "w.xml:3: box \"t\": size=\"0.5 0 0.3\""},
      {"<box name=\"t\" size=\"0.5 -1 0.3\"/>", "(y is -1)"},
      {"<box name=\"t\" size=\"0.5 0.5 nan\"/>", "size=\"0.5 0.5 nan\" is not three finite"},
      {"<box name=\"t\" size=\"0.5 0.5\"/>", "size=\"0.5 0.5\" is not three finite"},
      {"<box name=\"t\" size=\"0.5 0.5 0.5 1\"/>", "size=\"0.5 0.5 0.5 1\""},
      {"<box name=\"t\" size=\"0.5 0.5 0.5\" position=\"0 inf 0\"/>", "position=\"0 inf 0\""},
      {"<box name=\"t\" size=\"0.5 0.5 0.5\" position=\"0 5000 0\"/>", "(y is 5000)"},
      {"<box name=\"t\" size=\"2000 0.5 0.5\"/>", "(x is 2000)"},
      {"<box name=\"t\" size=\"0.5 0.5 1e-300\"/>", "in [0.001, 1000] m (z is 1e-300)"},
      {"<box name=\"t\" size=\"1 1 1\" position=\"5 5 5\" orientation=\"0 x 0\"/>",
       "orientation=\"0 x 0\""},
      {"<box name=\"t\"/>", "w.xml:3: <box> is missing attribute size"},
      {"<box name=\"t\" size=\"1 1 1\" colour=\"red\"/>", "unknown attribute colour=\"red\""},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.box);
    const std::string message = ErrorOf(
        [&] { Morphology::Parse(OneModuleXml("  " + c.box + "\n"), "w.xml"); },
        StatusCode::kInvalidArgument);
    EXPECT_THAT(message, HasSubstr(c.expected));
  }
  EXPECT_THAT(ErrorOf(
                  [] {
                    Morphology::Parse(OneModuleXml("  <box name=\"a\" size=\"1 1 1\" position=\"5 0 0\"/>\n"
                                                   "  <box name=\"a\" size=\"1 1 1\" position=\"9 0 0\"/>\n"),
                                      "w.xml");
                  },
                  StatusCode::kInvalidArgument),
              HasSubstr("w.xml:4: box \"a\": duplicate box name"));
  // Built in code: the same rules, without a line.
  StaticBox bad;
  bad.name = "pillar";
  bad.size = Eigen::Vector3d(0.1, std::nan(""), 0.1);
  EXPECT_THAT(ErrorOf([&] { Morphology::Build(0, {MorphologyModule{.id = 0}}, {}, {}, "code", {bad}); },
                      StatusCode::kInvalidArgument),
              HasSubstr("code: box \"pillar\": size=\"0.1 nan 0.1\""));
}

TEST(StaticBoxTest, BoxOverlappingTheRobotAtTheStartIsRefused) {
  // A wall across the quadruped's legs, not under its central module: the
  // robot starts on the ground and its hips would be inside the wall.
  const Morphology m = Morphology::Parse(
      QuadrupedXml("  <box name=\"wall\" size=\"0.05 0.6 0.2\" position=\"0.09 0 0.1\"/>\n"), "q.xml");
  const int line = m.boxes()[0].line;
  const std::string message =
      ErrorOf([&] { World world(m); }, StatusCode::kInvalidArgument);
  EXPECT_THAT(message, HasSubstr("q.xml:" + std::to_string(line) + ": box \"wall\""));
  EXPECT_THAT(message, HasSubstr("overlaps module"));
  // Moved away it is fine.
  const Morphology moved = Morphology::Parse(
      QuadrupedXml("  <box name=\"wall\" size=\"0.05 0.6 0.2\" position=\"0.6 0 0.1\"/>\n"), "q.xml");
  World world(moved);
  EXPECT_NEAR(world.LowestPoint(), world.options().drop_gap, 1e-9);
}

TEST(StaticBoxTest, ModuleDroppedOnABoxRestsOnItsTop) {
  for (const double yaw : {0.0, 30.0}) {
    SCOPED_TRACE(yaw);
    const Morphology m = Morphology::Parse(
        OneModuleXml("  <box name=\"block\" size=\"0.3 0.3 0.2\" position=\"0.05 0 0.1\" orientation=\"0 0 " +
                     std::to_string(yaw) + "\"/>\n"),
        "w.xml");
    WorldOptions options;
    options.drop_gap = 0.1;  // released 10 cm above the block's top
    World world(m, options);
    EXPECT_NEAR(world.LowestPoint(), 0.3, 1e-9);
    world.Step(Steps(world, 1.5));
    ASSERT_FALSE(world.Diverged()) << world.Divergence().reason;
    // On the block (soft contacts: a fraction of a millimetre into it), not
    // on the ground 20 cm below, and still above the origin.
    EXPECT_NEAR(world.LowestPoint(), 0.2, 1e-3);
    EXPECT_LT(world.CentralPosition().head<2>().norm(), 0.01);
    const Eigen::Vector3d before = world.CentralPosition();
    world.Step(Steps(world, 0.5));
    EXPECT_LT((world.CentralPosition() - before).norm(), 1e-4);
  }
  // Without the block the same module falls to the ground.
  WorldOptions options;
  options.drop_gap = 0.1;
  World bare(Morphology::Parse(OneModuleXml(""), "w.xml"), options);
  bare.Step(Steps(bare, 1.5));
  EXPECT_NEAR(bare.LowestPoint(), 0.0, 1e-3);
}

TEST(StaticBoxTest, BoxesTakeTheGroundsFriction) {
  // A module on a block tilted by gravity (slope 0.3 rad): it holds with the
  // default friction and slides off once the ground turns slippery.
  const Morphology m = Morphology::Parse(
      OneModuleXml("  <box name=\"block\" size=\"1 1 0.2\" position=\"0 0 0.1\"/>\n"), "w.xml");
  World holds(m);
  holds.SetSlope(0.3, 0.0);
  holds.Step(Steps(holds, 1.0));
  EXPECT_LT(holds.CentralPosition().head<2>().norm(), 0.01);
  World slides(m);
  slides.SetSlope(0.3, 0.0);
  slides.SetGroundFriction(0.05);
  slides.Step(Steps(slides, 1.0));
  EXPECT_GT(slides.CentralPosition().x(), 0.2);
}

TEST(StaticBoxTest, QuadrupedWalksOffTheTableAndFalls) {
  // A 50 x 50 cm table 30 cm high: the quadruped's legs reach nearly to its
  // edges, so walking any way takes it over one.
  const Morphology m = Morphology::Parse(
      QuadrupedXml("  <box name=\"table\" size=\"0.5 0.5 0.3\" position=\"0 0 0.15\"/>\n"), "q.xml");
  World world(m);
  EXPECT_NEAR(world.LowestPoint(), 0.3 + world.options().drop_gap, 1e-9);
  const double start_height = world.CentralPosition().z();
  EXPECT_GT(start_height, 0.3);
  double fell_at = -1;
  for (int s = 0; s < Steps(world, 60.0); ++s) {
    GaitStep(world);
    ASSERT_FALSE(world.Diverged()) << world.Divergence().reason;
    if (fell_at < 0 && world.CentralPosition().z() < 0.2) fell_at = world.Time();
    if (fell_at >= 0 && world.Time() > fell_at + 3.0) break;
  }
  ASSERT_GT(fell_at, 0) << "still on the table at " << world.CentralPosition().transpose();
  EXPECT_GT(fell_at, 1.0);  // it stood and walked on the table first (about 6 s)
  // Down on the floor, off the table's footprint.
  EXPECT_LT(world.LowestPoint(), 0.01);
  EXPECT_GT(world.LowestPoint(), -0.005);
  const Eigen::Vector3d p = world.CentralPosition();
  EXPECT_GT(std::max(std::abs(p.x()), std::abs(p.y())), 0.25) << p.transpose();
}

TEST(StaticBoxTest, UpsideDownOnATableStaysOnTheTable) {
  const Morphology m = Morphology::Parse(
      QuadrupedXml("  <box name=\"table\" size=\"1 1 0.3\" position=\"0 0 0.15\"/>\n"), "q.xml");
  World world(m);
  world.Step(Steps(world, 0.5));
  const Eigen::Vector3d up_before =
      world.CentralOrientation().inverse() * Eigen::Vector3d::UnitZ();  // in the module's frame
  world.TurnUpsideDown();
  EXPECT_NEAR(world.LowestPoint(), 0.3 + world.options().drop_gap, 1e-9);
  world.Step(Steps(world, 1.0));
  ASSERT_FALSE(world.Diverged());
  EXPECT_NEAR(world.LowestPoint(), 0.3, 2e-3);
  const Eigen::Vector3d up_after = world.CentralOrientation().inverse() * Eigen::Vector3d::UnitZ();
  EXPECT_LT(up_before.dot(up_after), -0.9);  // upside down
}

TEST(StaticBoxTest, CurrentMorphologyAndResetKeepTheBoxes) {
  const Morphology m = Morphology::Parse(
      QuadrupedXml("  <box name=\"table\" size=\"1 1 0.3\" position=\"0 0 0.15\"/>\n"), "q.xml");
  World world(m);
  ASSERT_EQ(world.StaticBoxes().size(), 1u);
  world.Disconnect(5);
  const Morphology now = world.CurrentMorphology();
  ASSERT_EQ(now.boxes().size(), 1u);
  EXPECT_EQ(now.boxes()[0].name, "table");
  EXPECT_THAT(now.ToXml(), HasSubstr("<box name=\"table\" size=\"1 1 0.3\" position=\"0 0 0.15\"/>"));
  world.Reset();
  EXPECT_NEAR(world.LowestPoint(), 0.3 + world.options().drop_gap, 1e-9);
}

TEST(StaticBoxTest, ConnectingIntoABoxIsRefused) {
  // The snake lies on the ground; a block 4 to 8 cm behind the rear face of
  // its tail (module 8) leaves no room for a module screwed on there.
  const Morphology snake = Morphology::LoadFile(kWorlds + "snake.xml");
  const World probe(snake);
  const ConnectorFrame& rear = ConnectorFrameOf(ConnectorId::kRear);
  const Eigen::Isometry3d tail = probe.ModulePose(8);
  const Eigen::Vector3d block = tail * rear.position + tail.linear() * rear.normal * 0.06;
  std::string xml = snake.ToXml();
  xml.insert(xml.find("  <connect"), "  <module id=\"99\" free=\"true\"/>\n");
  xml.insert(xml.rfind("</morphology>"),
             "  <box name=\"block\" size=\"0.04 0.04 0.04\" position=\"" +
                 std::to_string(block.x()) + " " + std::to_string(block.y()) + " " +
                 std::to_string(block.z()) + "\"/>\n");
  World world(Morphology::Parse(xml, "snake+block"));
  const std::string message = ErrorOf(
      [&] { world.Connect(99, ConnectorId::kFront, 8, ConnectorId::kRear, 0); },
      StatusCode::kFailedPrecondition);
  EXPECT_THAT(message, HasSubstr("box \"block\""));
  EXPECT_EQ(world.Presence(99), ModulePresence::kPutAway);
  // Without the block the same connection is made.
  std::string free_xml = snake.ToXml();
  free_xml.insert(free_xml.find("  <connect"), "  <module id=\"99\" free=\"true\"/>\n");
  World open(Morphology::Parse(free_xml, "snake"));
  open.Connect(99, ConnectorId::kFront, 8, ConnectorId::kRear, 0);
  EXPECT_EQ(open.Presence(99), ModulePresence::kInRobot);
}

}  // namespace
}  // namespace yamor::physics
