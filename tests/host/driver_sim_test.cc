// RobotDriver over the in-process simulation, and Evaluate.
#include <gtest/gtest.h>

#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "bridge/robot.h"
#include "common/status.h"
#include "cpg/config_xml.h"
#include "host/builtin_robots.h"
#include "host/driver.h"
#include "host/evaluator.h"
#include "host/frames.h"
#include "host/sim_backend.h"
#include "host/worker_pool.h"
#include "host/worlds.h"
#include "physics/render/image.h"
#include "physics/script.h"
#include "physics/world.h"
#include "tests/support/code_of.h"
#include "tests/host/test_util.h"

namespace yamor::host {
namespace {

using snp::Tristate;

using ::yamor::testing::CodeOf;

double Horizontal(const RobotPose& a, const RobotPose& b) {
  return std::hypot(a.position[0] - b.position[0], a.position[1] - b.position[1]);
}

SimulationSpec Quadruped(uint64_t seed = 0) {
  ResolvedWorld world = ResolveWorld(WorldRequest{.world = "quadruped"}, kDefaultWorld, false);
  return SimulationSpec{.morphology = std::move(world.morphology),
                        .world_name = world.name,
                        .config = std::move(world.config),
                        .seed = seed};
}

TEST(BuiltinRobotsTest, EveryWorldWithAConfigurationIsEmbedded) {
  const std::vector<std::string> names = BuiltinRobotNames();
  for (const char* name : {"quadruped", "snake", "dog", "tripod", "wheel", "trebuchet"}) {
    EXPECT_NE(std::find(names.begin(), names.end(), name), names.end()) << name;
    EXPECT_NE(FindBuiltinRobot(name), nullptr) << name;
  }
  for (const std::string& name : names) {
    ResolvedWorld world = ResolveWorld(WorldRequest{.world = name}, kDefaultWorld, false);
    ASSERT_TRUE(world.config.has_value()) << name;
    for (const cpg::ModuleParams& m : world.config->modules) {
      EXPECT_TRUE(world.morphology.Contains(m.id)) << name << " module " << m.id;
    }
  }
  std::string message;
  EXPECT_EQ(CodeOf([&] { ResolveWorld(WorldRequest{.world = "unicorn"}, kDefaultWorld, false); },
                   &message),
            StatusCode::kNotFound);
  EXPECT_NE(message.find("quadruped"), std::string::npos) << "lists the built-in worlds";
  EXPECT_EQ(CodeOf([&] {
              ResolveWorld(WorldRequest{.world = testing::kSourceDir + "/configs/worlds/snake.xml"},
                           kDefaultWorld, /*allow_files=*/false);
            }),
            StatusCode::kNotFound)
      << "network requests never read files";
}

// The thesis's session (5.5, C.2): open, connect, control on, let it walk.
TEST(DriverSimTest, TheQuadrupedWalksInVirtualTime) {
  RobotDriver driver({}, testing::QuadrupedConfig());
  const OpenedSimulation opened = driver.OpenSimulation(Quadruped());
  EXPECT_EQ(opened.module_ids.size(), 9u);
  EXPECT_EQ(opened.central_module, 4);
  EXPECT_TRUE(driver.SimulationModeEnabled());
  const ConnectResult connected = driver.ConnectRobot(0.0, false, nullptr);
  EXPECT_EQ(connected.links, 8);
  driver.SendControlMessage(ControlMessage{Tristate::kOn, Tristate::kOn, Tristate::kOn, {}, true});
  const RobotPose start = driver.RobotPosition();
  EXPECT_DOUBLE_EQ(start.time, 0.0);
  EXPECT_EQ(start.source, "simulation");
  const double t = driver.Sleep(20.0, false, nullptr);
  EXPECT_NEAR(t, 20.0, 1e-9);
  EXPECT_NEAR(driver.ElapsedTime(), 20.0, 1e-9);
  const RobotPose end = driver.RobotPosition();
  EXPECT_GT(Horizontal(start, end), 0.05) << "the quadruped walked less than 5 cm in 20 s";

  // The servos follow the oscillators; angles come back over SNP.
  const auto angles = driver.GetServoAngles({0, 5});
  ASSERT_EQ(angles.size(), 2u);
  EXPECT_LE(std::fabs(angles[0].second), 0.9);

  // UART is on: the accelerometer of the upright central module sees gravity.
  const auto samples = driver.GetAccelerometer(4, 4);
  ASSERT_FALSE(samples.empty());
  const auto& a = samples.back().acceleration;
  EXPECT_NEAR(std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]), 9.81, 3.0);

  driver.ResetSimulation();
  EXPECT_DOUBLE_EQ(driver.ElapsedTime(), 0.0);
  EXPECT_FALSE(driver.Info().connected);
  EXPECT_EQ(CodeOf([&] { driver.Flush(); }), StatusCode::kFailedPrecondition);
}

TEST(DriverSimTest, WithoutControlTheRobotStaysPut) {
  RobotDriver driver({}, testing::QuadrupedConfig());
  driver.OpenSimulation(Quadruped());
  driver.ConnectRobot(0.0, false, nullptr);
  const RobotPose start = driver.RobotPosition();
  driver.Sleep(2.0, false, nullptr);
  EXPECT_LT(Horizontal(start, driver.RobotPosition()), 0.01);
}

TEST(DriverSimTest, IdMappingDrivesASimulationWithOtherIds) {
  // The real robot's modules are 20..28; the simulation's quadruped 0..8.
  std::map<int, int> map;
  for (int i = 0; i <= 8; ++i) map[20 + i] = i;
  cpg::RobotConfig real = testing::QuadrupedConfig();
  cpg::RobotConfig renamed;
  for (cpg::ModuleParams m : real.modules) {
    m.id += 20;
    renamed.modules.push_back(m);
  }
  for (cpg::Coupling c : real.couplings) {
    c.from += 20;
    c.to += 20;
    renamed.couplings.push_back(c);
  }
  for (const auto& [child, parent] : real.bluetooth_parent) {
    renamed.bluetooth_parent[child + 20] = parent + 20;
  }
  renamed.master_id = real.master_id + 20;
  DriverOptions options;
  options.id_map = IdMap(map);
  RobotDriver driver(options, renamed);
  SimulationSpec spec = Quadruped();
  spec.config.reset();  // keep the renamed configuration
  const OpenedSimulation opened = driver.OpenSimulation(std::move(spec));
  EXPECT_EQ(opened.central_module, 24);
  driver.ConnectRobot(0.0, false, nullptr);
  driver.SendControlMessage(ControlMessage{Tristate::kOn, Tristate::kOn, Tristate::kOn, {}, true});
  const RobotPose start = driver.RobotPosition();
  driver.Sleep(10.0, false, nullptr);
  EXPECT_GT(Horizontal(start, driver.RobotPosition()), 0.02);
  EXPECT_EQ(driver.GetServoAngles({25}).at(0).first, 25);

  // A configuration the world cannot hold is refused.
  RobotDriver unmapped({}, renamed);
  SimulationSpec bad = Quadruped();
  bad.config.reset();
  std::string message;
  EXPECT_EQ(CodeOf([&] { unmapped.OpenSimulation(std::move(bad)); }, &message),
            StatusCode::kInvalidArgument);
  EXPECT_NE(message.find("module 20"), std::string::npos) << message;
}

TEST(DriverSimTest, DivergenceIsReportedAndResetRecovers) {
  RobotDriver driver({}, testing::QuadrupedConfig());
  const physics::Morphology morphology = Quadruped().morphology;
  auto backend = std::make_unique<SimBackend>(morphology, bridge::RobotOptions{});
  SimBackend* sim = backend.get();
  driver.AttachBackend(std::move(backend), "quadruped");
  driver.ConnectRobot(0.0, false, nullptr);
  driver.Sleep(0.1, false, nullptr);
  sim->robot().world().InjectNonFiniteForTesting(0);
  std::string message;
  EXPECT_EQ(CodeOf([&] { driver.Sleep(1.0, false, nullptr); }, &message),
            StatusCode::kFailedPrecondition);
  EXPECT_NE(message.find("diverged"), std::string::npos) << message;
  EXPECT_EQ(CodeOf([&] { driver.RobotPosition(); }), StatusCode::kFailedPrecondition);
  EXPECT_EQ(CodeOf([&] { driver.Sleep(1.0, false, nullptr); }), StatusCode::kFailedPrecondition);
  driver.ResetSimulation();
  EXPECT_EQ(CodeOf([&] { driver.Sleep(0.2, false, nullptr); }), StatusCode::kOk);
  EXPECT_TRUE(std::isfinite(driver.RobotPosition().position[0]));
}

// The scene over SNP (ReadScene), real ids, and frames drawn from it.
TEST(DriverSimTest, GetSceneCarriesRealIdsAndFramesComeFromIt) {
  std::map<int, int> map;
  for (int i = 0; i <= 8; ++i) map[20 + i] = i;
  cpg::RobotConfig renamed;
  for (cpg::ModuleParams m : testing::QuadrupedConfig().modules) {
    m.id += 20;
    renamed.modules.push_back(m);
  }
  renamed.master_id = testing::QuadrupedConfig().master_id + 20;
  for (const auto& [child, parent] : testing::QuadrupedConfig().bluetooth_parent) {
    renamed.bluetooth_parent[child + 20] = parent + 20;
  }
  DriverOptions options;
  options.id_map = IdMap(map);
  RobotDriver driver(options, renamed);
  EXPECT_EQ(CodeOf([&] { driver.GetScene(); }), StatusCode::kFailedPrecondition);  // no world
  SimulationSpec spec = Quadruped();
  spec.config.reset();
  driver.OpenSimulation(std::move(spec));
  driver.Sleep(0.5, false, nullptr);
  const render::Scene scene = driver.GetScene();
  ASSERT_EQ(scene.modules.size(), 9u);
  EXPECT_EQ(scene.modules.front().id, 20);
  EXPECT_EQ(scene.Central()->id, 24);
  EXPECT_NEAR(scene.Central()->body.position.x(), driver.RobotPosition().position[0], 1e-6);
  EXPECT_NEAR(scene.time, 0.5, 1e-9);

  try {
    const EncodedFrame frame = RenderFrame(driver, FrameSpec{.width = 64, .height = 48});
    EXPECT_EQ(render::DecodePng(frame.png).width, 64);
    EXPECT_NEAR(frame.time, 0.5, 1e-9);
    std::vector<EncodedFrame> frames;
    RecordFrames(driver, RecordSpec{.frame = {.width = 32, .height = 24}, .frame_rate = 20,
                                    .seconds = 0.25},
                 [&](EncodedFrame&& f) {
                   frames.push_back(std::move(f));
                   return true;
                 },
                 nullptr);
    ASSERT_EQ(frames.size(), 5u);
    for (std::size_t i = 0; i < frames.size(); ++i) {
      EXPECT_EQ(frames[i].index, i);
      EXPECT_NEAR(frames[i].time, 0.5 + 0.05 * i, 1e-9);
    }
    EXPECT_NEAR(driver.ElapsedTime(), 0.75, 1e-9);
    // A sink that gives up stops the recording at once.
    int taken = 0;
    RecordFrames(driver, RecordSpec{.frame = {.width = 8, .height = 8}, .frame_rate = 10,
                                    .seconds = 10},
                 [&](EncodedFrame&&) { return ++taken < 2; }, nullptr);
    EXPECT_EQ(taken, 2);
  } catch (const Error& e) {
    if (e.code() != StatusCode::kUnavailable) throw;
    GTEST_SKIP() << "no renderer on this machine: " << e.what();
  }
}

TEST(DriverSimTest, ASleepOverlappingAResetOwesOnlyTheRestOfItsTime) {
  // Issue 17, found by the soak: a Sleep kept its absolute target time, so
  // a reset by another caller made a short Sleep step the whole lost
  // timeline again (Sleeps of 0.3 s ran into 30-s deadlines).
  RobotDriver driver({}, testing::QuadrupedConfig());
  driver.OpenSimulation(Quadruped());
  driver.ConnectRobot(0.0, false, nullptr);  // a walking robot steps fastest
  driver.SendControlMessage(ControlMessage{Tristate::kOn, Tristate::kOn, Tristate::kOn, {}, true});
  driver.Sleep(1.0, false, nullptr);
  std::atomic<double> ended{-1.0};
  std::thread sleeper([&] { ended = driver.Sleep(3.0, false, nullptr); });
  while (driver.ElapsedTime() < 1.5 && ended.load() < 0) {
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  ASSERT_LT(ended.load(), 0.0) << "the Sleep ended before the reset";
  driver.ResetSimulation();
  sleeper.join();
  // It had stepped at least 0.5 s before the reset, so at most 2.5 s are owed
  // on the new clock; the old target made it step to t = 4.
  EXPECT_GT(ended.load(), 0.0);
  EXPECT_LE(ended.load(), 2.5 + 1e-6);
  EXPECT_NEAR(driver.ElapsedTime(), ended.load(), 1e-9);
}

TEST(DriverSimTest, FramesOfManyThreadsShareABoundedNumberOfRenderers) {
  // Issue 17, found by the soak: a renderer (an OpenGL context, tens of MB)
  // per gRPC thread took yamord past 800 MB under 64 RenderFrame clients.
  RobotDriver driver({}, testing::QuadrupedConfig());
  SimulationSpec spec = Quadruped();
  spec.config.reset();
  driver.OpenSimulation(std::move(spec));
  try {
    RenderFrame(driver, FrameSpec{.width = 16, .height = 12});
  } catch (const Error& e) {
    if (e.code() != StatusCode::kUnavailable) throw;
    GTEST_SKIP() << "no renderer on this machine: " << e.what();
  }
  ASSERT_GE(RendererCapacity(), 1u);
  ASSERT_LE(RendererCapacity(), kMaxRenderers);
  // More threads than renderers, each drawing several frames (so a renderer
  // goes from thread to thread and back while each thread lives on, as
  // gRPC's do), then waves of short-lived threads.
  const std::size_t threads = 3 * RendererCapacity() + 2;
  constexpr int kFramesEach = 20;
  std::atomic<int> frames{0};
  std::vector<std::string> errors(threads);
  auto draw = [&](std::size_t t, int count) {
    try {
      for (int i = 0; i < count; ++i) {
        const EncodedFrame frame = RenderFrame(driver, FrameSpec{.width = 16, .height = 12});
        if (render::DecodePng(frame.png).width == 16) ++frames;
      }
    } catch (const Error& e) {
      errors[t] = e.what();
    }
  };
  {
    std::vector<std::thread> pool;
    for (std::size_t t = 0; t < threads; ++t) pool.emplace_back(draw, t, kFramesEach);
    for (std::thread& t : pool) t.join();
  }
  for (int wave = 0; wave < 2; ++wave) {
    std::vector<std::thread> pool;
    for (std::size_t t = 0; t < threads; ++t) pool.emplace_back(draw, t, 1);
    for (std::thread& t : pool) t.join();
  }
  for (const std::string& e : errors) EXPECT_EQ(e, "");
  EXPECT_EQ(frames.load(), static_cast<int>((kFramesEach + 2) * threads));
  EXPECT_LE(RenderersCreated(), RendererCapacity());
  // The cancel check is consulted only while every renderer is busy: with
  // one free, even a cancelled caller draws.
  EXPECT_NO_THROW(RenderFrame(driver, FrameSpec{.width = 8, .height = 8}, [] { return true; }));
}

TEST(DriverSimTest, FramesOfADivergedWorldFailAndBadSpecsAreRefusedFirst) {
  RobotDriver driver({}, testing::QuadrupedConfig());
  auto backend = std::make_unique<SimBackend>(Quadruped().morphology, bridge::RobotOptions{});
  SimBackend* sim = backend.get();
  driver.AttachBackend(std::move(backend), "quadruped");
  std::string message;
  EXPECT_EQ(CodeOf([&] { RenderFrame(driver, FrameSpec{.width = 0}); }, &message),
            StatusCode::kOutOfRange);
  EXPECT_EQ(message, "frame width 0 is outside 1..4096");
  EXPECT_EQ(CodeOf([&] {
              RecordFrames(driver, RecordSpec{.frame_rate = 0}, [](EncodedFrame&&) { return true; },
                           nullptr);
            }, &message),
            StatusCode::kOutOfRange);
  EXPECT_EQ(message, "frame rate 0 per second is outside (0, 240]");
  EXPECT_EQ(CodeOf([&] {
              RecordFrames(driver, RecordSpec{.seconds = std::nan("")},
                           [](EncodedFrame&&) { return true; }, nullptr);
            }),
            StatusCode::kInvalidArgument);
  sim->robot().world().InjectNonFiniteForTesting(0);
  sim->robot().world().Step();
  EXPECT_EQ(CodeOf([&] { driver.GetScene(); }, &message), StatusCode::kFailedPrecondition);
  EXPECT_NE(message.find("diverged"), std::string::npos) << message;
}

TEST(DriverSimTest, FaultsAndGroundReachTheWorld) {
  RobotDriver driver({}, testing::QuadrupedConfig());
  const physics::Morphology morphology = Quadruped().morphology;
  auto backend = std::make_unique<SimBackend>(morphology, bridge::RobotOptions{});
  physics::World& world = backend->robot().world();
  bridge::Robot& robot = backend->robot();
  driver.AttachBackend(std::move(backend), "quadruped");
  driver.ConnectRobot(0.0, false, nullptr);
  driver.SendControlMessage(ControlMessage{Tristate::kOn, Tristate::kOn, Tristate::kOn, {}, true});
  EXPECT_TRUE(world.MotorEnabled(2));
  // The passive centre 4 is inactive (all-zero oscillator): "all" leaves its
  // servo unpowered; naming it powers it.
  EXPECT_FALSE(world.MotorEnabled(4));
  EXPECT_FALSE(robot.Firmware(4).motors);
  driver.SendControlMessage(ControlMessage{.motors = Tristate::kOn, .module_ids = {4}});
  EXPECT_TRUE(world.MotorEnabled(4));
  driver.SetMotorDefect(2, MotorDefect::kLimp);
  EXPECT_EQ(world.GetMotorFault(2), physics::MotorFault::kLimp);
  EXPECT_FALSE(world.MotorEnabled(2)) << "the defect motor was switched off over SNP";
  driver.SendControlMessage(ControlMessage{.motors = Tristate::kOn, .all = true});
  EXPECT_FALSE(robot.Firmware(2).motors) << "motor-on was not forwarded";
  EXPECT_TRUE(robot.Firmware(3).motors);

  driver.SetModuleDefect(5, true);
  EXPECT_TRUE(world.ModuleDefective(5));
  EXPECT_EQ(CodeOf([&] { driver.SetModuleDefect(77, true); }), StatusCode::kNotFound);

  driver.SetGround({.friction = 0.3});
  EXPECT_DOUBLE_EQ(world.GroundFriction(), 0.3);
  driver.SetGround({.slope = 0.1});
  EXPECT_NEAR(world.Gravity().x(), 9.81 * std::sin(0.1), 1e-9);
  EXPECT_EQ(CodeOf([&] { driver.SetGround({.slope = 2.0}); }), StatusCode::kOutOfRange);
  EXPECT_EQ(CodeOf([&] { driver.SetGround({.friction = NAN}); }), StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf([&] { driver.SetGround({}); }), StatusCode::kInvalidArgument);

  // Physical reconfiguration goes to the bridge as SNP; a bridge without it
  // answers a clear UNIMPLEMENTED.
  const bool reconfigures = testing::BridgeReconfigures();
  EXPECT_EQ(CodeOf([&] { driver.DisconnectModule(5); }),
            reconfigures ? StatusCode::kOk : StatusCode::kUnimplemented);

  driver.ResetSimulation();
  EXPECT_DOUBLE_EQ(world.GroundFriction(), physics::WorldOptions().ground_friction);
  EXPECT_EQ(world.GetMotorFault(2), physics::MotorFault::kNone);
  EXPECT_FALSE(world.ModuleDefective(5));
}

TEST(DriverSimTest, TurnUpsideDownFlipsTheCentralModule) {
  RobotDriver driver({}, testing::QuadrupedConfig());
  driver.OpenSimulation(Quadruped());
  const RobotPose before = driver.RobotPosition();
  driver.TurnUpsideDown();
  const RobotPose after = driver.RobotPosition();
  // The world z component of each of the central module's axes (rotation
  // matrix row 2 from the quaternion w, x, y, z): the axis that pointed up
  // points down now.
  auto world_z = [](const RobotPose& p) {
    const auto& q = p.orientation;
    const double w = q[0], x = q[1], y = q[2], z = q[3];
    return std::array<double, 3>{2 * (x * z - w * y), 2 * (y * z + w * x),
                                 1 - 2 * (x * x + y * y)};
  };
  const std::array<double, 3> up_before = world_z(before);
  const std::array<double, 3> up_after = world_z(after);
  int vertical = 0;
  for (int k = 1; k < 3; ++k) {
    if (std::abs(up_before[k]) > std::abs(up_before[vertical])) vertical = k;
  }
  EXPECT_GT(std::abs(up_before[vertical]), 0.9);
  EXPECT_NEAR(up_after[vertical], -up_before[vertical], 0.1) << "axis " << vertical;
  EXPECT_NEAR(Horizontal(before, after), 0.0, 0.02) << "about its centre";
  driver.Sleep(1.0, false, nullptr);
  EXPECT_TRUE(std::isfinite(driver.RobotPosition().position[2]));
  RobotDriver no_world({}, testing::QuadrupedConfig());
  EXPECT_EQ(CodeOf([&] { no_world.TurnUpsideDown(); }), StatusCode::kFailedPrecondition);
}

TEST(DriverSimTest, FreeRunAdvancesTheWorldOnItsOwn) {
  RobotDriver driver({}, testing::QuadrupedConfig());
  driver.OpenSimulation(Quadruped());
  EXPECT_EQ(CodeOf([&] { driver.SetFreeRun(-1.0); }), StatusCode::kOutOfRange);
  driver.SetFreeRun(5.0);
  EXPECT_DOUBLE_EQ(driver.Info().free_run_factor, 5.0);
  double t = 0.0;
  for (int i = 0; i < 500 && t <= 0.0; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    t = driver.ElapsedTime();
  }
  EXPECT_GT(t, 0.0) << "free-run never stepped the world";
  driver.SetFreeRun(0.0);
  const double stopped = driver.ElapsedTime();
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_DOUBLE_EQ(driver.ElapsedTime(), stopped) << "free-run off: the world waits";
}

// Issue 12 §0: GetMorphology is the robot as it is now, not the world's
// initial body.
TEST(DriverSimTest, GetMorphologyIsTheRobotAsItIsNow) {
  RobotDriver driver({}, testing::QuadrupedConfig());
  const physics::Morphology initial = Quadruped().morphology;
  driver.OpenSimulation(Quadruped());
  const std::string before = driver.GetMorphology().ToXml();
  EXPECT_EQ(before, initial.ToXml());

  driver.DisconnectModule(7);
  physics::Morphology now = driver.GetMorphology();
  EXPECT_TRUE(now.Module(7).free);
  EXPECT_EQ(now.connections().size(), 7u);
  driver.ConnectModules(7, snp::Connector::kFront, 5, snp::Connector::kRear, 0);
  now = driver.GetMorphology();
  EXPECT_FALSE(now.Module(7).free);
  EXPECT_EQ(now.connections().back().to, 5);
  driver.ResetSimulation();
  EXPECT_EQ(driver.GetMorphology().ToXml(), before) << "Reset restores the initial body";

  const std::string script = testing::ReadSourceFile("configs/scripts/quadruped-transform.xml");
  ASSERT_FALSE(script.empty());
  driver.ConnectRobot(0.0, false, nullptr);
  driver.SendControlMessage(ControlMessage{Tristate::kOn, Tristate::kOn, Tristate::kOn, {}, true});
  driver.RunTransformationScript(script, nullptr);
  const physics::Morphology after = driver.GetMorphology();
  EXPECT_NE(after.ToXml(), before);
  auto has_link = [&](int from, int to) {
    for (const physics::MorphologyConnection& c : after.connections()) {
      if (c.from == from && c.to == to) return true;
    }
    return false;
  };
  EXPECT_TRUE(has_link(7, 5));
  EXPECT_TRUE(has_link(8, 6));
  EXPECT_FALSE(has_link(7, 2));
  EXPECT_FALSE(has_link(8, 3));
  for (const physics::MorphologyModule& m : after.modules()) EXPECT_FALSE(m.free) << m.id;
  // The script run on a world of its own gives the same body.
  physics::World reference(initial);
  physics::RunScript(reference, physics::TransformationScript::Parse(script, "script"));
  EXPECT_EQ(after.ToXml(), reference.CurrentMorphology().ToXml());
}

// Issue 13: a spare attached while the robot lives may be configured (the
// lifelong runner rebuilds the network with it); one still lying free may not.
TEST(DriverSimTest, AnAttachedSpareMayBeConfigured) {
  RobotDriver driver({}, testing::QuadrupedConfig());
  SimulationSpec spec = Quadruped();
  std::vector<physics::MorphologyModule> modules = spec.morphology.modules();
  modules.push_back({9, true, 0});
  spec.morphology = physics::Morphology::Build(spec.morphology.central(), modules, spec.morphology.connections(),
                                               spec.morphology.orientation_degrees(), "quadruped+spare");
  driver.OpenSimulation(std::move(spec));
  cpg::RobotConfig config = testing::QuadrupedConfig();
  config.modules.push_back({.id = 9, .amplitude = 0.3, .speed = 0.3});
  config.bluetooth_parent[9] = 5;
  const std::string xml = cpg::WriteConfigXml(config);
  std::string message;
  EXPECT_EQ(CodeOf([&] { driver.LoadConfig(xml, "with-9.xml"); }, &message), StatusCode::kInvalidArgument);
  EXPECT_NE(message.find("module 9 of the configuration is a free module"), std::string::npos) << message;
  driver.ConnectModules(9, snp::Connector::kFront, 5, snp::Connector::kRear, 0);
  driver.LoadConfig(xml, "with-9.xml");
  EXPECT_EQ(driver.Config().modules.back().id, 9);
  const ConnectResult connected = driver.ConnectRobot(0.0, false, nullptr);
  EXPECT_EQ(connected.links, 9);
  // A module put away since the world opened stays configurable, as before.
  driver.DisconnectModule(9);
  driver.DisconnectModule(7);
  driver.LoadConfig(cpg::WriteConfigXml(testing::QuadrupedConfig()), "quadruped.xml");
}

TEST(DriverSimTest, ABodyWithoutAValidMorphologyIsAFailedPrecondition) {
  RobotDriver driver({}, testing::QuadrupedConfig());
  auto backend = std::make_unique<SimBackend>(testing::SnakeWithSpares(), bridge::RobotOptions{});
  physics::World& world = backend->robot().world();
  driver.AttachBackend(std::move(backend), "snake+spares");
  testing::MakeUnplaceable(world);
  std::string message;
  EXPECT_EQ(CodeOf([&] { driver.GetMorphology(); }, &message), StatusCode::kFailedPrecondition);
  EXPECT_NE(message.find("starting angles"), std::string::npos) << message;
  EXPECT_NE(message.find("overlaps"), std::string::npos) << message;
  driver.Sleep(0.2, false, nullptr);  // the robot itself is fine
  driver.DisconnectModule(10);
  EXPECT_TRUE(driver.GetMorphology().Module(10).free);
}

// ---- Evaluate ----------------------------------------------------------------------

EvaluationSpec QuadrupedEvaluation(double warmup = 2.0, double duration = 4.0) {
  SimulationSpec sim = Quadruped();
  return EvaluationSpec{.morphology = std::move(sim.morphology),
                        .config = std::move(*sim.config),
                        .warmup = warmup,
                        .duration = duration,
                        .seed = 7};
}

TEST(EvaluateTest, SameSeedSameVelocityAndVelocityIsDistanceOverDuration) {
  EvaluationSpec spec = QuadrupedEvaluation();
  spec.trajectory_period = 0.5;
  const EvaluationResult a = RunEvaluation(spec, nullptr);
  const EvaluationResult b = RunEvaluation(spec, nullptr);
  EXPECT_FALSE(a.diverged);
  EXPECT_GT(a.velocity, 0.0);
  EXPECT_EQ(a.velocity, b.velocity) << "bit-identical for the same seed";
  EXPECT_EQ(a.final_pose.position, b.final_pose.position);
  EXPECT_DOUBLE_EQ(a.velocity, a.distance / 4.0);
  ASSERT_EQ(a.trajectory.size(), 13u) << "t = 0, 0.5, ..., 6";
  EXPECT_NEAR(a.trajectory.back().time, 6.0, 1e-9);
  EXPECT_EQ(a.trajectory.back().position, a.final_pose.position);
  // Distance from the pose at t = warm-up (trajectory sample 4) to the end.
  const auto& w = a.trajectory[4].position;
  EXPECT_NEAR(a.distance, std::hypot(a.final_pose.position[0] - w[0], a.final_pose.position[1] - w[1]),
              1e-12);

  EvaluationSpec still = QuadrupedEvaluation();
  for (int id = 0; id <= 8; ++id) {
    still.parameters.emplace_back("amplitude." + std::to_string(id), 0.0);
  }
  const EvaluationResult c = RunEvaluation(still, nullptr);
  EXPECT_LT(c.velocity, a.velocity / 4.0) << "parameters are applied";
}

TEST(EvaluateTest, ParameterErrorsNameTheParameter) {
  struct Case {
    std::string name;
    double value;
    StatusCode code;
  };
  const Case cases[] = {
      {"amplitude.3", NAN, StatusCode::kInvalidArgument},
      {"amplitude.3", -1.0, StatusCode::kOutOfRange},
      {"amplitude.42", 0.5, StatusCode::kNotFound},
      {"phase.0.8", 0.5, StatusCode::kNotFound},
      {"phase.0", 0.5, StatusCode::kInvalidArgument},
      {"torque.3", 0.5, StatusCode::kInvalidArgument},
      {"speed.x", 0.5, StatusCode::kInvalidArgument},
      {"speed.3", 99.0, StatusCode::kOutOfRange},
      {"minangle.3", 1.0, StatusCode::kOutOfRange},  // above maxangle 0.78
      {"weight.0.1", INFINITY, StatusCode::kInvalidArgument},
  };
  for (const Case& c : cases) {
    EvaluationSpec spec = QuadrupedEvaluation(0.0, 0.1);
    spec.parameters.emplace_back(c.name, c.value);
    std::string message;
    EXPECT_EQ(CodeOf([&] { RunEvaluation(spec, nullptr); }, &message), c.code) << c.name;
    EXPECT_NE(message.find(c.name), std::string::npos) << message;
  }
  EvaluationSpec ordered = QuadrupedEvaluation(0.0, 0.1);
  ordered.parameters = {{"minangle.3", 1.0}, {"maxangle.3", 1.2}};
  EXPECT_EQ(CodeOf([&] { RunEvaluation(ordered, nullptr); }), StatusCode::kOk)
      << "min < max is checked after all parameters";
  EvaluationSpec timing = QuadrupedEvaluation(-1.0, 1.0);
  EXPECT_EQ(CodeOf([&] { RunEvaluation(timing, nullptr); }), StatusCode::kOutOfRange);
  timing = QuadrupedEvaluation(1.0, NAN);
  EXPECT_EQ(CodeOf([&] { RunEvaluation(timing, nullptr); }), StatusCode::kInvalidArgument);
}

// Issue 13 §2 "model" mode: the evaluated robot's condition changes its gait.
TEST(EvaluateTest, DefectsGroundAndUpsideDownChangeTheVelocity) {
  const EvaluationResult healthy = RunEvaluation(QuadrupedEvaluation(1.0, 3.0), nullptr);
  ASSERT_FALSE(healthy.diverged);
  ASSERT_GT(healthy.velocity, 0.01);
  struct Case {
    std::string name;
    std::function<void(EvaluationSpec&)> change;
  };
  const Case cases[] = {
      {"limp motor 2", [](EvaluationSpec& s) { s.motor_defects = {{2, MotorDefect::kLimp}}; }},
      {"stuck motor 2", [](EvaluationSpec& s) { s.motor_defects = {{2, MotorDefect::kStuck}}; }},
      {"module 3 defect", [](EvaluationSpec& s) { s.module_defects = {{3, true}}; }},
      {"slippery ground", [](EvaluationSpec& s) { s.ground.friction = 0.05; }},
      {"slope", [](EvaluationSpec& s) { s.ground = {.slope = 0.35, .slope_direction = M_PI / 2}; }},
      {"upside down", [](EvaluationSpec& s) { s.upside_down = true; }},
  };
  for (const Case& c : cases) {
    EvaluationSpec spec = QuadrupedEvaluation(1.0, 3.0);
    c.change(spec);
    const EvaluationResult changed = RunEvaluation(spec, nullptr);
    EXPECT_FALSE(changed.diverged) << c.name << ": " << changed.divergence;
    EXPECT_GT(std::abs(changed.velocity - healthy.velocity), 0.1 * healthy.velocity)
        << c.name << ": " << changed.velocity << " vs healthy " << healthy.velocity;
  }
  EvaluationSpec again = QuadrupedEvaluation(1.0, 3.0);
  again.ground.friction = 0.05;
  again.upside_down = true;
  EXPECT_EQ(RunEvaluation(again, nullptr).velocity, RunEvaluation(again, nullptr).velocity)
      << "deterministic";
  // Entries that change nothing are checked and leave the run bit-identical.
  EvaluationSpec ok = QuadrupedEvaluation(1.0, 3.0);
  ok.motor_defects = {{2, MotorDefect::kNone}};
  ok.module_defects = {{3, false}};
  EXPECT_EQ(RunEvaluation(ok, nullptr).velocity, healthy.velocity);
}

TEST(EvaluateTest, BadConditionValuesAreRefusedNamingThem) {
  struct Case {
    std::string name;
    std::function<void(EvaluationSpec&)> change;
    StatusCode code;
    std::string mention;
  };
  const Case cases[] = {
      {"motor defect of a module not configured",
       [](EvaluationSpec& s) { s.motor_defects = {{42, MotorDefect::kLimp}}; },
       StatusCode::kNotFound, "module 42"},
      {"motor defect twice",
       [](EvaluationSpec& s) { s.motor_defects = {{2, MotorDefect::kLimp}, {2, MotorDefect::kNone}}; },
       StatusCode::kInvalidArgument, "module 2"},
      {"module defect not in the world", [](EvaluationSpec& s) { s.module_defects = {{99, true}}; },
       StatusCode::kNotFound, "module 99"},
      {"module defect out of id range", [](EvaluationSpec& s) { s.module_defects = {{300, false}}; },
       StatusCode::kNotFound, "module 300"},
      {"module defect twice", [](EvaluationSpec& s) { s.module_defects = {{3, true}, {3, true}}; },
       StatusCode::kInvalidArgument, "module 3"},
      {"NaN friction", [](EvaluationSpec& s) { s.ground.friction = NAN; },
       StatusCode::kInvalidArgument, "friction"},
      {"zero friction", [](EvaluationSpec& s) { s.ground.friction = 0.0; },
       StatusCode::kOutOfRange, "friction"},
      {"huge friction", [](EvaluationSpec& s) { s.ground.friction = 1000.0; },
       StatusCode::kOutOfRange, "friction"},
      {"steep slope", [](EvaluationSpec& s) { s.ground.slope = 2.0; }, StatusCode::kOutOfRange,
       "slope"},
      {"negative slope", [](EvaluationSpec& s) { s.ground.slope = -0.1; },
       StatusCode::kOutOfRange, "slope"},
      {"infinite slope direction",
       [](EvaluationSpec& s) { s.ground.slope_direction = INFINITY; },
       StatusCode::kInvalidArgument, "slope direction"},
  };
  for (const Case& c : cases) {
    EvaluationSpec spec = QuadrupedEvaluation(0.0, 0.1);
    c.change(spec);
    std::string message;
    EXPECT_EQ(CodeOf([&] { RunEvaluation(spec, nullptr); }, &message), c.code) << c.name;
    EXPECT_NE(message.find(c.mention), std::string::npos) << c.name << ": " << message;
  }
}

TEST(EvaluateTest, CancellationStopsBetweenChunks) {
  EvaluationSpec spec = QuadrupedEvaluation(8.0, 12.0);
  int checks = 0;
  EXPECT_EQ(CodeOf([&] { RunEvaluation(spec, [&] { return ++checks > 5; }); }),
            StatusCode::kCancelled);
  EXPECT_EQ(checks, 6);
}

// EvaluationSpec::film: frames from the evaluating thread's own world, the
// result untouched by them.
TEST(EvaluateTest, AFilmedEvaluationReturnsItsFramesAndTheSameResult) {
  EvaluationSpec plain = QuadrupedEvaluation(0.5, 1.0);
  const EvaluationResult base = RunEvaluation(plain, nullptr);
  EvaluationSpec filmed = plain;
  filmed.film = EvaluationFilm{.frame = {.width = 48, .height = 36}, .frame_rate = 10};
  EvaluationResult a;
  try {
    a = RunEvaluation(filmed, nullptr);
  } catch (const Error& e) {
    if (e.code() != StatusCode::kUnavailable) throw;
    GTEST_SKIP() << "no renderer on this machine: " << e.what();
  }
  EXPECT_EQ(a.velocity, base.velocity) << "filming never changes the evaluation";
  EXPECT_EQ(a.final_pose.position, base.final_pose.position);
  EXPECT_TRUE(base.frames.empty());
  ASSERT_EQ(a.frames.size(), 15u) << "1.5 s at 10 frames per second";
  for (std::size_t i = 0; i < a.frames.size(); ++i) {
    EXPECT_EQ(a.frames[i].index, i);
    EXPECT_NEAR(a.frames[i].time, 0.1 * static_cast<double>(i), 1e-9);
    const render::Image image = render::DecodePng(a.frames[i].png);
    EXPECT_EQ(image.width, 48);
    EXPECT_EQ(image.height, 36);
  }
  EXPECT_NE(a.frames.front().png, a.frames.back().png) << "the robot moves";

  // Deterministic, and one GL context per thread: two workers film the same
  // evaluation at once and get the same bytes.
  WorkerPool pool(2);
  auto x = pool.Submit([&] { return RunEvaluation(filmed, nullptr); });
  auto y = pool.Submit([&] { return RunEvaluation(filmed, nullptr); });
  const EvaluationResult rx = x.get();
  const EvaluationResult ry = y.get();
  ASSERT_EQ(rx.frames.size(), a.frames.size());
  ASSERT_EQ(ry.frames.size(), a.frames.size());
  for (std::size_t i = 0; i < a.frames.size(); ++i) {
    EXPECT_EQ(rx.frames[i].png, a.frames[i].png) << i;
    EXPECT_EQ(ry.frames[i].png, a.frames[i].png) << i;
  }

  // A period that is no whole number of steps: absolute frame times, no drift.
  filmed.film->frame_rate = 30;
  filmed.film->frame.width = 8;
  filmed.film->frame.height = 8;
  const EvaluationResult b = RunEvaluation(filmed, nullptr);
  ASSERT_EQ(b.frames.size(), 45u);
  EXPECT_NEAR(b.frames.back().time, 44.0 / 30.0, 0.0011);
  EXPECT_EQ(b.velocity, base.velocity);
}

TEST(EvaluateTest, BadFilmValuesAreRefusedNamingThemBeforeTheWorld) {
  struct Case {
    const char* name;
    std::function<void(EvaluationFilm&)> change;
    StatusCode code;
    std::string message;
  };
  const std::vector<Case> cases = {
      {"width 0", [](EvaluationFilm& f) { f.frame.width = 0; }, StatusCode::kOutOfRange,
       "frame width 0 is outside 1..4096"},
      {"huge height", [](EvaluationFilm& f) { f.frame.height = 5000; }, StatusCode::kOutOfRange,
       "frame height 5000 is outside 1..4096"},
      {"rate 0", [](EvaluationFilm& f) { f.frame_rate = 0; }, StatusCode::kOutOfRange,
       "frame rate 0 per second is outside (0, 240]"},
      {"NaN rate", [](EvaluationFilm& f) { f.frame_rate = std::nan(""); },
       StatusCode::kInvalidArgument, "frame rate is not finite: nan"},
      {"NaN camera", [](EvaluationFilm& f) { f.frame.camera.elevation = std::nan(""); },
       StatusCode::kInvalidArgument, "camera elevation is not finite: nan"},
  };
  for (const Case& c : cases) {
    EvaluationSpec spec = QuadrupedEvaluation(0.5, 1.0);
    spec.film = EvaluationFilm{.frame = {.width = 32, .height = 24}, .frame_rate = 10};
    c.change(*spec.film);
    std::string message;
    EXPECT_EQ(CodeOf([&] { RunEvaluation(spec, nullptr); }, &message), c.code) << c.name;
    EXPECT_EQ(message, c.message) << c.name;
  }
  EvaluationSpec long_film = QuadrupedEvaluation(0.0, 1000.0);
  long_film.film = EvaluationFilm{.frame = {.width = 8, .height = 8}, .frame_rate = 240};
  std::string message;
  EXPECT_EQ(CodeOf([&] { RunEvaluation(long_film, nullptr); }, &message), StatusCode::kOutOfRange);
  EXPECT_NE(message.find("240000 frames, more than 100000"), std::string::npos) << message;
  EXPECT_EQ(EvaluationFrameCount(3.0, 25.0), 75u);
  EXPECT_EQ(EvaluationFrameCount(0.01, 25.0), 1u);
}

bool FfmpegInstalled() {
  return std::system("ffmpeg -version > /dev/null 2>&1") == 0 &&
         std::system("ffprobe -version > /dev/null 2>&1") == 0;
}

// `command`'s standard output.
std::string OutputOf(const std::string& command) {
  std::string out;
  std::unique_ptr<FILE, int (*)(FILE*)> pipe(popen(command.c_str(), "r"), pclose);
  if (!pipe) return out;
  char buffer[256];
  while (std::fgets(buffer, sizeof(buffer), pipe.get())) out += buffer;
  return out;
}

// EvaluationFilm::mp4: the frames go raw to ffmpeg in the evaluating
// process; only the frames asked for come back as PNG, the same pictures
// as those of a PNG film.
TEST(EvaluateTest, AFilmAsMp4IsMadeHereWithOnlyTheAskedForFramesAsPng) {
  if (!FfmpegInstalled()) GTEST_SKIP() << "ffmpeg not installed";
  EvaluationSpec spec = QuadrupedEvaluation(0.5, 1.0);
  spec.film = EvaluationFilm{.frame = {.width = 48, .height = 36}, .frame_rate = 10};
  EvaluationResult png_film;
  try {
    png_film = RunEvaluation(spec, nullptr);
  } catch (const Error& e) {
    if (e.code() != StatusCode::kUnavailable) throw;
    GTEST_SKIP() << "no renderer on this machine: " << e.what();
  }
  ASSERT_EQ(png_film.frames.size(), 15u);
  spec.film->mp4 = true;
  spec.film->png_frames = {14, 0, 7};
  const EvaluationResult film = RunEvaluation(spec, nullptr);
  EXPECT_EQ(film.velocity, png_film.velocity) << "filming never changes the evaluation";
  EXPECT_TRUE(film.video_note.empty()) << film.video_note;
  EXPECT_EQ(film.mp4_frames, 15u);
  ASSERT_GT(film.mp4.size(), 8u);
  EXPECT_EQ(std::string(film.mp4.begin() + 4, film.mp4.begin() + 8), "ftyp") << "an MP4 file";
  ASSERT_EQ(film.frames.size(), 3u);
  const uint32_t wanted[] = {0, 7, 14};
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(film.frames[i].index, wanted[i]);
    EXPECT_EQ(film.frames[i].time, png_film.frames[wanted[i]].time);
    EXPECT_EQ(film.frames[i].png, png_film.frames[wanted[i]].png) << "frame " << wanted[i];
  }
  const std::filesystem::path path = std::filesystem::temp_directory_path() /
                                     ("yamor_film_test_" + std::to_string(::getpid()) + ".mp4");
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(film.mp4.data()),
             static_cast<std::streamsize>(film.mp4.size()));
  const std::string probe =
      OutputOf("ffprobe -v error -count_frames -select_streams v:0 -show_entries "
          "stream=codec_name,width,height,nb_read_frames -of csv=p=0 " + path.string());
  std::filesystem::remove(path);
  EXPECT_EQ(probe, "h264,48,36,15\n");
}

// A machine without ffmpeg: every frame as PNG, and a note that says why.
TEST(EvaluateTest, AFilmAsMp4WithoutFfmpegComesAsPngFramesWithANote) {
  EvaluationSpec spec = QuadrupedEvaluation(0.5, 1.0);
  spec.film = EvaluationFilm{.frame = {.width = 16, .height = 12}, .frame_rate = 10, .mp4 = true,
                             .png_frames = {3}};
  ::setenv("YAMOR_FFMPEG", "/nonexistent/ffmpeg", 1);
  EvaluationResult film;
  try {
    film = RunEvaluation(spec, nullptr);
  } catch (const Error& e) {
    ::unsetenv("YAMOR_FFMPEG");
    if (e.code() != StatusCode::kUnavailable) throw;
    GTEST_SKIP() << "no renderer on this machine: " << e.what();
  }
  ::unsetenv("YAMOR_FFMPEG");
  EXPECT_TRUE(film.mp4.empty());
  EXPECT_NE(film.video_note.find("cannot run ffmpeg"), std::string::npos) << film.video_note;
  ASSERT_EQ(film.frames.size(), 15u);
  for (std::size_t i = 0; i < film.frames.size(); ++i) EXPECT_EQ(film.frames[i].index, i);
}

TEST(EvaluateTest, PngFramesOfAnMp4FilmAreCheckedBeforeTheWorld) {
  EvaluationSpec spec = QuadrupedEvaluation(0.5, 1.0);
  spec.film = EvaluationFilm{.frame = {.width = 16, .height = 12}, .frame_rate = 10, .mp4 = true,
                             .png_frames = {0, 15}};
  std::string message;
  EXPECT_EQ(CodeOf([&] { RunEvaluation(spec, nullptr); }, &message), StatusCode::kOutOfRange);
  EXPECT_EQ(message, "PNG frame 15 is past the film's 15 frames");
  spec.film->png_frames.assign(65, 0);
  EXPECT_EQ(CodeOf([&] { RunEvaluation(spec, nullptr); }, &message), StatusCode::kOutOfRange);
  EXPECT_EQ(message, "65 PNG frames asked for; at most 64");
}

TEST(EvaluateTest, TheWorkerPoolRunsJobsInParallelAndPropagatesErrors) {
  WorkerPool pool(2);
  EXPECT_EQ(pool.size(), 2u);
  auto a = pool.Submit([] { return RunEvaluation(QuadrupedEvaluation(0.5, 1.0), nullptr); });
  auto b = pool.Submit([] { return RunEvaluation(QuadrupedEvaluation(0.5, 1.0), nullptr); });
  EXPECT_EQ(a.get().velocity, b.get().velocity);
  auto bad = pool.Submit([]() -> int { throw Error(StatusCode::kNotFound, "nope"); });
  EXPECT_EQ(CodeOf([&] { bad.get(); }), StatusCode::kNotFound);
  pool.Shutdown();
  EXPECT_EQ(CodeOf([&] { pool.Submit([] { return 1; }); }), StatusCode::kUnavailable);
}

}  // namespace
}  // namespace yamor::host
