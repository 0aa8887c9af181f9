// Dynamic reconfiguration (issue #3 part 3): Connect/Disconnect at runtime and
// transformation scripts.
#include <cmath>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "common/status.h"
#include "physics/placement.h"
#include "physics/script.h"
#include "physics/world.h"

namespace yamor::physics {
namespace {

using ::testing::HasSubstr;

const std::string kConfigs = std::string(YAMOR_SOURCE_DIR) + "/configs/";

// A robot from configs/worlds plus free modules with the given ids.
Morphology WithSpares(const std::string& robot, std::vector<int> spares) {
  const Morphology base = Morphology::LoadFile(kConfigs + "worlds/" + robot + ".xml");
  std::vector<MorphologyModule> modules = base.modules();
  for (int id : spares) modules.push_back({id, true, 0});
  return Morphology::Build(base.central(), modules, base.connections(),
                           base.orientation_degrees(), robot + "+spares");
}

Error ErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& error) {
    return error;
  }
  ADD_FAILURE() << "no error";
  return Error(StatusCode::kOk, "");
}

// The connector as the simulation has it: on the actual pose of its part.
WorldConnector Actual(const World& world, int id, ConnectorId connector) {
  const bool on_handle = ConnectorFrameOf(connector).part == Part::kHandle;
  return ConnectorInFrame(on_handle ? world.HandlePose(id) : world.ModulePose(id), connector);
}

// Distance between two connectors that should be mated, and the angle
// between their (opposite) normals.
std::pair<double, double> MateError(const World& world, int a, ConnectorId ca, int b,
                                    ConnectorId cb) {
  const WorldConnector x = Actual(world, a, ca);
  const WorldConnector y = Actual(world, b, cb);
  const double distance = (x.position - y.position).norm();
  const double angle = std::acos(std::clamp(-x.normal.dot(y.normal), -1.0, 1.0));
  return {distance, angle};
}

void Stand(World& world, int steps) {
  for (int knee = 5; knee <= 8; ++knee) world.SetServoTarget(knee, -0.7);
  world.SetServoTarget(0, 0.4);
  world.Step(steps);
}

TEST(ReconfigurationTest, ConnectPlacesTheModuleExactlyAndJoinsIt) {
  World world(WithSpares("quadruped", {9}));
  EXPECT_EQ(world.Presence(9), ModulePresence::kPutAway);
  Stand(world, 1000);
  const int bodies = world.BodyCount();
  const double mass = world.TotalMass();
  // Onto the top face of hip 0, which stands at 0.4 rad: exact placement.
  world.Connect(9, ConnectorId::kFront, 0, ConnectorId::kTop, 3);
  EXPECT_TRUE(world.IsConnected(9));
  EXPECT_EQ(world.BodyCount(), bodies + 1);  // 9's handle joins hip 0's body
  EXPECT_NEAR(world.TotalMass(), mass + ModuleMass(), 1e-12);
  auto [distance, angle] = MateError(world, 9, ConnectorId::kFront, 0, ConnectorId::kTop);
  EXPECT_NEAR(distance, module::kConnectionGap, 1e-6);
  EXPECT_LT(angle, 1e-6);
  const WorldConnector top = Actual(world, 0, ConnectorId::kTop);
  const WorldConnector front = Actual(world, 9, ConnectorId::kFront);
  double north = SignedAngle(top.north, front.north, top.normal);
  if (north < 0) north += 2 * M_PI;
  EXPECT_NEAR(north, 3 * module::kConnectionAngleStep, 1e-6);
  // It stays joined while the robot moves.
  world.SetServoTarget(0, -0.4);
  world.SetServoTarget(9, 0.5);
  world.Step(1000);
  ASSERT_FALSE(world.Diverged());
  // One rigid body now: the mate is exact up to rounding.
  std::tie(distance, angle) = MateError(world, 9, ConnectorId::kFront, 0, ConnectorId::kTop);
  EXPECT_NEAR(distance, module::kConnectionGap, 1e-9);
  EXPECT_LT(angle, 1e-7);  // acos near 1 resolves ~1e-8 rad
  EXPECT_NEAR(world.ServoAngle(9), 0.5, 0.02);
  EXPECT_EQ(world.Connections().size(), 9u);
}

TEST(ReconfigurationTest, TheRobotIsLiftedWhenOnlyTheGroundIsInTheWay) {
  World world(WithSpares("quadruped", {9}));
  world.Step(200);
  const double height = world.CentralPosition().z();
  // Knee 5 lies flat with its top face on the ground (knees are mounted upside
  // down): a module screwed in there points into the floor.
  const double face = Actual(world, 5, ConnectorId::kTop).position.z();
  EXPECT_LT(face, 0.01);
  world.Connect(9, ConnectorId::kFront, 5, ConnectorId::kTop, 0);
  const double module_length =
      module::kBodyLength / 2 + module::kPivotX + module::kHandleReach;
  const double lowest = face - module::kConnectionGap - module_length;
  EXPECT_NEAR(world.CentralPosition().z() - height, world.options().drop_gap - lowest, 1e-6);
  EXPECT_GT(world.LowestPoint(), 0.0);
  world.Step(1500);
  ASSERT_FALSE(world.Diverged());
  EXPECT_TRUE(world.IsConnected(9));
  auto [distance, angle] = MateError(world, 9, ConnectorId::kFront, 5, ConnectorId::kTop);
  EXPECT_NEAR(distance, module::kConnectionGap, 1e-9);
  EXPECT_LT(angle, 1e-7);
}

TEST(ReconfigurationTest, NoRoomIsAClearError) {
  World world(WithSpares("snake", {9, 10}));
  world.Step(100);
  // 9 stands on module 1's top, its 60 mm wide crossbar across the snake;
  // 10 screwed into module 1's left face, turned so that its crossbar stands
  // upright, would hit 9's crossbar.
  world.Connect(9, ConnectorId::kFront, 1, ConnectorId::kTop, 0);
  const auto connections = world.Connections();
  const Error error =
      ErrorOf([&] { world.Connect(10, ConnectorId::kFront, 1, ConnectorId::kLeft, 6); });
  EXPECT_EQ(error.code(), StatusCode::kFailedPrecondition);
  EXPECT_THAT(error.what(), HasSubstr("no room"));
  EXPECT_THAT(error.what(), HasSubstr("overlap module 9"));
  // Nothing changed.
  EXPECT_EQ(world.Presence(10), ModulePresence::kPutAway);
  EXPECT_EQ(world.Connections().size(), connections.size());
  world.Step(100);
  EXPECT_FALSE(world.Diverged());
  // Once 9 is put away there is room (after lifting the robot by the 5 mm
  // the upright crossbar reaches below the snake).
  world.Disconnect(9);
  const double height = world.CentralPosition().z();
  world.Connect(10, ConnectorId::kFront, 1, ConnectorId::kLeft, 6);
  EXPECT_TRUE(world.IsConnected(10));
  EXPECT_GT(world.CentralPosition().z(), height + 0.004);
  world.Step(500);
  EXPECT_FALSE(world.Diverged());
}

TEST(ReconfigurationTest, DisconnectPutsAwayOrDrops) {
  World world(Morphology::LoadFile(kConfigs + "worlds/quadruped.xml"));
  world.Step(200);
  const int bodies = world.BodyCount();
  world.Disconnect(7, /*put_away=*/true);
  EXPECT_EQ(world.Presence(7), ModulePresence::kPutAway);
  EXPECT_EQ(world.BodyCount(), bodies - 1);
  EXPECT_NEAR(world.TotalMass(), 8 * ModuleMass(), 1e-12);
  EXPECT_EQ(ErrorOf([&] { world.ModulePose(7); }).code(), StatusCode::kFailedPrecondition);

  // Dropping hip 3 (all its links go) leaves it and knee 8 loose, simulated.
  world.Disconnect(3, /*put_away=*/false);
  EXPECT_EQ(world.Presence(3), ModulePresence::kLoose);
  EXPECT_EQ(world.Presence(8), ModulePresence::kLoose);
  EXPECT_FALSE(world.IsConnected(8));
  EXPECT_NEAR(world.TotalMass(), 8 * ModuleMass(), 1e-12);
  world.SetServoTarget(8, -0.9);
  world.Step(1000);
  ASSERT_FALSE(world.Diverged());
  EXPECT_LT(world.ModulePose(3).translation().z(), 0.1);
  // Loose and put-away single modules can be connected again, placed and
  // holding at servo 0 whatever their set-point was before.
  world.Connect(8, ConnectorId::kFront, 6, ConnectorId::kRear, 0);
  world.Connect(7, ConnectorId::kFront, 2, ConnectorId::kRear, 0);
  EXPECT_TRUE(world.IsConnected(7));
  EXPECT_TRUE(world.IsConnected(8));
  EXPECT_EQ(world.ServoTarget(8), 0.0);
  EXPECT_EQ(world.ServoTarget(7), 0.0);
  world.Step(500);
  EXPECT_FALSE(world.Diverged());

  // Putting away the middle of a snake leaves the tail as one loose chain,
  // whose modules cannot be taken while still linked to each other.
  World snake(Morphology::LoadFile(kConfigs + "worlds/snake.xml"));
  snake.Disconnect(3);
  for (int id = 4; id <= 8; ++id) EXPECT_EQ(snake.Presence(id), ModulePresence::kLoose) << id;
  EXPECT_TRUE(snake.IsConnected(2));
  const Error linked =
      ErrorOf([&] { snake.Connect(4, ConnectorId::kFront, 2, ConnectorId::kRear, 0); });
  EXPECT_EQ(linked.code(), StatusCode::kFailedPrecondition);
  EXPECT_THAT(linked.what(), HasSubstr("disconnect it first"));
}

TEST(ReconfigurationTest, BadRequestsAreRejected) {
  World world(WithSpares("quadruped", {9}));
  EXPECT_EQ(ErrorOf([&] { world.Disconnect(4); }).code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(ErrorOf([&] { world.Disconnect(42); }).code(), StatusCode::kNotFound);
  EXPECT_EQ(ErrorOf([&] { world.Disconnect(9); }).code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(ErrorOf([&] { world.Connect(42, ConnectorId::kFront, 4, ConnectorId::kTop, 0); })
                .code(),
            StatusCode::kNotFound);
  EXPECT_EQ(ErrorOf([&] { world.Connect(9, ConnectorId::kFront, 9, ConnectorId::kTop, 0); })
                .code(),
            StatusCode::kInvalidArgument);
  const Error used =
      ErrorOf([&] { world.Connect(9, ConnectorId::kFront, 4, ConnectorId::kLeft, 0); });
  EXPECT_EQ(used.code(), StatusCode::kFailedPrecondition);
  EXPECT_THAT(used.what(), HasSubstr("already used"));
  EXPECT_EQ(ErrorOf([&] { world.Connect(5, ConnectorId::kRear, 4, ConnectorId::kRear, 0); })
                .code(),
            StatusCode::kFailedPrecondition);  // 5 is part of the robot
  world.InjectNonFiniteForTesting(4);
  world.Step();
  ASSERT_TRUE(world.Diverged());
  EXPECT_EQ(ErrorOf([&] { world.Connect(9, ConnectorId::kFront, 5, ConnectorId::kRear, 0); })
                .code(),
            StatusCode::kFailedPrecondition);
  world.Reset();
  EXPECT_EQ(world.Presence(9), ModulePresence::kPutAway);
  world.Connect(9, ConnectorId::kFront, 5, ConnectorId::kRear, 0);
  EXPECT_TRUE(world.IsConnected(9));
  world.Reset();  // back to the morphology
  EXPECT_EQ(world.Presence(9), ModulePresence::kPutAway);
  EXPECT_EQ(world.Connections().size(), 8u);
}

TEST(ScriptTest, ParsesTheThesisVocabulary) {
  const TransformationScript script = TransformationScript::Parse(
      "<script>\n"
      "  <disconnect id=\"7\"/>\n"
      "  <pause delay=\"250\"/>\n"
      "  <connect idfrom=\"7\" connfrom=\"front\" idto=\"5\" connto=\"rear\" angle=\"-90\"/>\n"
      "</script>\n",
      "s.xml");
  ASSERT_EQ(script.commands().size(), 3u);
  EXPECT_EQ(script.commands()[0].kind, ScriptCommand::Kind::kDisconnect);
  EXPECT_EQ(script.commands()[0].id, 7);
  EXPECT_EQ(script.commands()[1].delay_ms, 250);
  EXPECT_EQ(script.commands()[2].connection.angle_steps, 18);
  EXPECT_EQ(script.commands()[2].line, 4);
}

TEST(ScriptTest, MalformedScriptsNameFileAndLine) {
  const std::pair<std::string, std::string> cases[] = {
      {"<script>\n<jump/>\n</script>", "s.xml:2"},
      {"<script>\n<connect idfrom=\"1\" connfrom=\"nose\" idto=\"2\" connto=\"rear\"/>\n</script>",
       "connfrom=\"nose\""},
      {"<script>\n<connect idfrom=\"1\" connfrom=\"front\" idto=\"2\" connto=\"rear\" "
       "angle=\"20\"/>\n</script>",
       "multiple of 15"},
      {"<script>\n<pause delay=\"-1\"/>\n</script>", "delay=\"-1\""},
      {"<script>\n<disconnect/>\n</script>", "missing attribute id"},
      {"<scrip/>", "<script>"},
  };
  for (const auto& [xml, fragment] : cases) {
    const Error error = ErrorOf([&] { TransformationScript::Parse(xml, "s.xml"); });
    EXPECT_EQ(error.code(), StatusCode::kInvalidArgument) << xml;
    EXPECT_THAT(error.what(), HasSubstr(fragment));
    EXPECT_THAT(error.what(), HasSubstr("s.xml:"));
  }
}

TEST(ScriptTest, RuntimeErrorsCarryTheScriptLine) {
  World world(Morphology::LoadFile(kConfigs + "worlds/quadruped.xml"));
  const TransformationScript script = TransformationScript::Parse(
      "<script>\n<disconnect id=\"7\"/>\n"
      "<connect idfrom=\"7\" connfrom=\"front\" idto=\"4\" connto=\"left\"/>\n</script>",
      "bad.xml");
  const Error error = ErrorOf([&] { RunScript(world, script); });
  EXPECT_EQ(error.code(), StatusCode::kFailedPrecondition);
  EXPECT_THAT(error.what(), HasSubstr("bad.xml:3"));
  EXPECT_THAT(error.what(), HasSubstr("already used"));
}

TEST(ScriptTest, QuadrupedTransformationSucceedsHundredTimes) {
  const Morphology quadruped = Morphology::LoadFile(kConfigs + "worlds/quadruped.xml");
  const TransformationScript script =
      TransformationScript::LoadFile(kConfigs + "scripts/quadruped-transform.xml");
  int succeeded = 0;
  for (std::uint64_t seed = 0; seed < 100; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    // A random gait inside the quadruped's Table 6.1 bounds keeps walking
    // while the script runs.
    const double hip_amplitude = unit(rng) * M_PI / 4;
    const double knee_amplitude = unit(rng) * M_PI / 2;
    const double knee_offset = -unit(rng) * M_PI / 2;
    const double inside_out = unit(rng) * 2 * M_PI;
    double phase[4] = {0, unit(rng) * 2 * M_PI, 0, 0};
    phase[2] = phase[1] + unit(rng) * 2 * M_PI;
    phase[3] = phase[2] + unit(rng) * 2 * M_PI;
    WorldOptions options;
    options.seed = seed;
    World world(quadruped, options);
    auto drive = [&](World& w) {
      const double t = w.Time();
      for (int hip = 0; hip < 4; ++hip) {
        w.SetServoTarget(hip, hip_amplitude * std::sin(2 * M_PI * t + phase[hip]));
        w.SetServoTarget(hip + 5, knee_offset + knee_amplitude * std::sin(2 * M_PI * t +
                                                                          phase[hip] +
                                                                          inside_out));
      }
    };
    for (int s = 0; s < 1000; ++s) {
      drive(world);
      world.Step();
    }
    RunScript(world, script, drive);
    for (int s = 0; s < 500; ++s) {
      drive(world);
      world.Step();
    }
    ASSERT_FALSE(world.Diverged()) << world.Divergence().reason;
    for (int id : world.ModuleIds()) ASSERT_TRUE(world.IsConnected(id)) << id;
    // Intact: the moved knees sit exactly on the ends of legs 0 and 1.
    for (const auto& [knee, foot] : {std::pair{7, 5}, std::pair{8, 6}}) {
      const auto [distance, angle] =
          MateError(world, knee, ConnectorId::kFront, foot, ConnectorId::kRear);
      ASSERT_NEAR(distance, module::kConnectionGap, 1e-5) << knee;
      ASSERT_LT(angle, 1e-4) << knee;
    }
    ++succeeded;
  }
  EXPECT_EQ(succeeded, 100);
}

// ---- CurrentMorphology (issue 12 §0) --------------------------------------------

// A connection without its source line, comparable.
std::tuple<int, ConnectorId, int, ConnectorId, int> Link(const MorphologyConnection& c) {
  return {c.from, c.from_connector, c.to, c.to_connector, c.angle_steps};
}

std::vector<std::tuple<int, ConnectorId, int, ConnectorId, int>> Links(
    const std::vector<MorphologyConnection>& connections) {
  std::vector<std::tuple<int, ConnectorId, int, ConnectorId, int>> links;
  for (const MorphologyConnection& c : connections) links.push_back(Link(c));
  return links;
}

MorphologyConnection Connection(int from, ConnectorId from_connector, int to,
                                ConnectorId to_connector, int angle_steps) {
  MorphologyConnection c;
  c.from = from;
  c.from_connector = from_connector;
  c.to = to;
  c.to_connector = to_connector;
  c.angle_steps = angle_steps;
  return c;
}

// The XML a morphology writes survives a parse unchanged.
void ExpectRoundTrips(const Morphology& morphology) {
  const std::string xml = morphology.ToXml();
  EXPECT_EQ(Morphology::Parse(xml, "round-trip.xml").ToXml(), xml);
}

TEST(CurrentMorphologyTest, IsTheInitialMorphologyWhileNothingChanged) {
  World world(WithSpares("quadruped", {9}));
  world.Step(100);
  const Morphology current = world.CurrentMorphology();
  EXPECT_EQ(current.ToXml(), world.morphology().ToXml());
  EXPECT_EQ(current.source(), world.morphology().source());
  EXPECT_TRUE(current.Module(9).free);
  // Back to it after a change and a Reset().
  world.Disconnect(7);
  EXPECT_NE(world.CurrentMorphology().ToXml(), world.morphology().ToXml());
  world.Reset();
  EXPECT_EQ(world.CurrentMorphology().ToXml(), world.morphology().ToXml());
}

TEST(CurrentMorphologyTest, FollowsDisconnectAndConnect) {
  World world(WithSpares("quadruped", {9}));
  const std::string initial = world.morphology().ToXml();
  world.Step(200);

  world.Disconnect(7);  // put away
  Morphology current = world.CurrentMorphology();
  EXPECT_TRUE(current.Module(7).free);
  EXPECT_TRUE(current.Module(9).free);
  EXPECT_FALSE(current.Module(2).free);
  EXPECT_EQ(current.central(), 4);
  EXPECT_EQ(current.orientation_degrees(), world.morphology().orientation_degrees());
  EXPECT_EQ(Links(current.connections()), Links(world.Connections()));
  EXPECT_EQ(current.connections().size(), 7u);
  EXPECT_THAT(current.source(), HasSubstr("reconfigured"));
  EXPECT_EQ(world.morphology().ToXml(), initial) << "the initial morphology stays as it was";
  ExpectRoundTrips(current);

  // Spare 9 extends leg 3; then hip 3 is dropped with knee 8 and 9 still
  // screwed together: all three are loose, and the 9 -> 8 link is not part of
  // the robot.
  world.Connect(9, ConnectorId::kFront, 8, ConnectorId::kRear, 0);
  current = world.CurrentMorphology();
  EXPECT_FALSE(current.Module(9).free);
  EXPECT_EQ(Link(current.connections().back()),
            Link(Connection(9, ConnectorId::kFront, 8, ConnectorId::kRear, 0)));
  EXPECT_EQ(Links(current.connections()), Links(world.Connections()));
  ExpectRoundTrips(current);
  world.Disconnect(3, /*put_away=*/false);
  ASSERT_EQ(world.Presence(9), ModulePresence::kLoose);
  EXPECT_EQ(world.Connections().size(), 6u) << "0, 1, 2 -> 4, 5 -> 0, 6 -> 1 and 9 -> 8";
  current = world.CurrentMorphology();
  for (int id : {3, 7, 8, 9}) EXPECT_TRUE(current.Module(id).free) << id;
  for (int id : {0, 1, 2, 4, 5, 6}) EXPECT_FALSE(current.Module(id).free) << id;
  const std::vector<MorphologyConnection> robot_links = {
      Connection(0, ConnectorId::kFront, 4, ConnectorId::kBottom, 18),
      Connection(1, ConnectorId::kFront, 4, ConnectorId::kLeft, 0),
      Connection(2, ConnectorId::kFront, 4, ConnectorId::kTop, 18),
      Connection(5, ConnectorId::kFront, 0, ConnectorId::kRear, 18),
      Connection(6, ConnectorId::kFront, 1, ConnectorId::kRear, 18),
  };
  EXPECT_EQ(Links(current.connections()), Links(robot_links));
  ExpectRoundTrips(current);
  // A fresh world of it has the same body.
  World rebuilt(current);
  for (int id : world.ModuleIds()) {
    EXPECT_EQ(rebuilt.IsConnected(id), world.IsConnected(id)) << id;
  }

  // Knee 7 comes back where it was.
  world.Connect(7, ConnectorId::kFront, 2, ConnectorId::kRear, 18);
  current = world.CurrentMorphology();
  EXPECT_FALSE(current.Module(7).free);
  EXPECT_EQ(Link(current.connections().back()),
            Link(Connection(7, ConnectorId::kFront, 2, ConnectorId::kRear, 18)));
  ExpectRoundTrips(current);
  world.Reset();
  EXPECT_EQ(world.CurrentMorphology().ToXml(), initial);
}

TEST(CurrentMorphologyTest, KeepsTheStartingAnglesAndFreesTheAngleOfASpare) {
  World world(Morphology::LoadFile(kConfigs + "worlds/wheel.xml"));
  world.Step(200);
  world.Disconnect(6);  // opens the ring: a chain of five
  const Morphology current = world.CurrentMorphology();
  EXPECT_TRUE(current.Module(6).free);
  EXPECT_EQ(current.Module(6).angle_degrees, 0.0) << "a spare takes no angle";
  for (int id : {1, 2, 3}) EXPECT_EQ(current.Module(id).angle_degrees, -60.0) << id;
  for (int id : {7, 12}) EXPECT_EQ(current.Module(id).angle_degrees, 60.0) << id;
  EXPECT_EQ(current.connections().size(), 4u);
  ExpectRoundTrips(current);
}

TEST(CurrentMorphologyTest, FollowsTheQuadrupedTransformation) {
  World world(Morphology::LoadFile(kConfigs + "worlds/quadruped.xml"));
  const TransformationScript script =
      TransformationScript::LoadFile(kConfigs + "scripts/quadruped-transform.xml");
  Stand(world, 500);
  RunScript(world, script);
  const Morphology current = world.CurrentMorphology();
  std::vector<MorphologyModule> modules = world.morphology().modules();
  for (MorphologyModule& m : modules) m.line = 0;
  std::vector<MorphologyConnection> connections;
  for (const MorphologyConnection& c : world.morphology().connections()) {
    if (c.from != 7 && c.from != 8) connections.push_back(c);
  }
  connections.push_back(Connection(7, ConnectorId::kFront, 5, ConnectorId::kRear, 0));
  connections.push_back(Connection(8, ConnectorId::kFront, 6, ConnectorId::kRear, 0));
  const Morphology expected = Morphology::Build(4, modules, connections,
                                                world.morphology().orientation_degrees());
  EXPECT_EQ(current.ToXml(), expected.ToXml());
  EXPECT_NE(current.ToXml(), world.morphology().ToXml());
  for (const MorphologyModule& m : current.modules()) EXPECT_FALSE(m.free) << m.id;
  ExpectRoundTrips(current);
  // Built from scratch, the transformed body has the moved knees on the ends
  // of legs 0 and 1.
  World transformed(Morphology::Parse(current.ToXml(), "transformed.xml"));
  for (const auto& [knee, foot] : {std::pair{7, 5}, std::pair{8, 6}}) {
    const auto [distance, angle] =
        MateError(transformed, knee, ConnectorId::kFront, foot, ConnectorId::kRear);
    EXPECT_NEAR(distance, module::kConnectionGap, 1e-6) << knee;
    EXPECT_LT(angle, 1e-6) << knee;
  }
}

TEST(CurrentMorphologyTest, ABodyThatDoesNotPlaceAtItsStartingAnglesIsAFailedPrecondition) {
  World world(WithSpares("snake", {9, 10, 11}));
  // 9 stands on module 1 and folds its body over module 0; 10, screwed onto
  // the face of 9 that now points up, stands clear of 11 upright on module 0.
  // At the starting angles (9 upright again) 10 would lie across 11.
  world.Connect(9, ConnectorId::kFront, 1, ConnectorId::kTop, 0);
  world.SetServoTarget(9, 1.4);
  world.Step(300);  // 0.6 s: 9 is at 1.4 rad
  world.Connect(11, ConnectorId::kFront, 0, ConnectorId::kTop, 0);
  world.Connect(10, ConnectorId::kFront, 9, ConnectorId::kTop, 0);
  const Error error = ErrorOf([&] { world.CurrentMorphology(); });
  EXPECT_EQ(error.code(), StatusCode::kFailedPrecondition);
  EXPECT_THAT(error.what(), HasSubstr("starting angles"));
  EXPECT_THAT(error.what(), HasSubstr("module id=\"11\""));
  EXPECT_THAT(error.what(), HasSubstr("module id=\"10\""));
  // The world itself is fine and keeps running; without 10 there is a
  // morphology again.
  world.Step(200);
  EXPECT_FALSE(world.Diverged());
  world.Disconnect(10);
  EXPECT_TRUE(world.CurrentMorphology().Module(10).free);
}

}  // namespace
}  // namespace yamor::physics
