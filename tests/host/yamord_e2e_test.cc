// End to end: the real yamord binary on an ephemeral port, driven over gRPC.
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <string>
#include <thread>

#include "bridge/bridge_server.h"
#include "bridge/bridge_transport.h"
#include "physics/morphology.h"
#include "tests/host/grpc_util.h"
#include "tests/support/host_call.h"
#include "tests/support/yamord_process.h"
#include "yamor/v1/host.grpc.pb.h"

namespace yamor::host {
namespace {

namespace v1 = yamor::v1;
using google::protobuf::Empty;
using ::yamor::testing::Call;
using Clock = std::chrono::steady_clock;

const char* const kYamord = YAMORD_PATH;

// A yamord child process (tests/support/yamord_process.h).
class Daemon : public ::yamor::testing::YamordProcess {
 public:
  explicit Daemon(std::vector<std::string> args) : YamordProcess(kYamord, std::move(args)) {}
};

// A running yamord with a channel to it.
struct Connection {
  explicit Connection(std::vector<std::string> extra = {}) {
    std::vector<std::string> args = {"--listen", "127.0.0.1:0", "--log-level", "warn"};
    args.insert(args.end(), extra.begin(), extra.end());
    daemon = std::make_unique<Daemon>(args);
    port = daemon->WaitForPort();
    channel = grpc::CreateChannel("127.0.0.1:" + std::to_string(port),
                                  grpc::InsecureChannelCredentials());
    stub = v1::Host::NewStub(channel);
  }
  std::unique_ptr<Daemon> daemon;
  int port = 0;
  std::shared_ptr<grpc::Channel> channel;
  std::unique_ptr<v1::Host::Stub> stub;
};

TEST(YamordTest, TheThesisSessionOverGrpcHealthAndReflection) {
  Connection c({"--workers", "2"});
  ASSERT_GT(c.port, 0) << "yamord did not report its port";
  v1::Host::Stub& stub = *c.stub;

  int serving = 0;
  ASSERT_OK(testing::HealthCheck(c.channel, "", &serving));
  EXPECT_EQ(serving, 1) << "health: SERVING";
  std::vector<std::string> services;
  ASSERT_OK(testing::ListServices(c.channel, &services));
  EXPECT_NE(std::find(services.begin(), services.end(), "yamor.v1.Host"), services.end());
  EXPECT_NE(std::find(services.begin(), services.end(), "grpc.health.v1.Health"), services.end());
  std::vector<google::protobuf::FileDescriptorProto> files;
  ASSERT_OK(testing::DescribeSymbol(c.channel, "yamor.v1.Host", &files));
  bool has_evaluate = false;
  for (const auto& file : files) {
    for (const auto& service : file.service()) {
      if (service.name() != "Host") continue;
      for (const auto& method : service.method()) has_evaluate |= method.name() == "Evaluate";
    }
  }
  EXPECT_TRUE(has_evaluate) << "reflection describes yamor.v1.Host with its methods";

  // yamord alone is ready to drive: the quadruped is open.
  v1::GetInfoResponse info;
  ASSERT_OK(Call(stub, &v1::Host::Stub::GetInfo, Empty(), &info));
  EXPECT_EQ(info.backend(), "simulation");
  EXPECT_EQ(info.world(), "quadruped");
  EXPECT_EQ(info.worker_capacity(), 2u);

  // The thesis session: open, connect, control on, set parameters, sleep 20 s.
  v1::OpenSimulationRequest open;
  open.set_world("quadruped");
  ASSERT_OK(Call(stub, &v1::Host::Stub::OpenSimulation, open));
  v1::ConnectRobotResponse connected;
  ASSERT_OK(Call(stub, &v1::Host::Stub::ConnectRobot, v1::ConnectRobotRequest(), &connected));
  EXPECT_EQ(connected.links(), 8u);
  v1::ControlMessageRequest control;
  control.set_uart(v1::SWITCH_ON);
  control.set_cpg(v1::SWITCH_ON);
  control.set_motors(v1::SWITCH_ON);
  control.set_all(true);
  ASSERT_OK(Call(stub, &v1::Host::Stub::SendControlMessage, control));
  for (uint32_t hip = 0; hip < 4; ++hip) {
    v1::SetModuleValueRequest speed;
    speed.set_module_id(hip);
    speed.set_value(0.35);
    ASSERT_OK(Call(stub, &v1::Host::Stub::SetModuleSpeed, speed));
  }
  v1::FlushResponse flushed;
  ASSERT_OK(Call(stub, &v1::Host::Stub::Flush, Empty(), &flushed));
  EXPECT_EQ(flushed.frames_sent(), 4u);
  v1::RobotPositionResponse start, end;
  ASSERT_OK(Call(stub, &v1::Host::Stub::RobotPosition, Empty(), &start));
  v1::SleepRequest sleep;
  sleep.set_seconds(20.0);
  v1::SleepResponse slept;
  ASSERT_OK(Call(stub, &v1::Host::Stub::Sleep, sleep, &slept));
  EXPECT_NEAR(slept.time(), 20.0, 1e-9);
  ASSERT_OK(Call(stub, &v1::Host::Stub::RobotPosition, Empty(), &end));
  const double moved = std::hypot(end.position().x() - start.position().x(),
                                  end.position().y() - start.position().y());
  EXPECT_GT(moved, 0.05) << "the quadruped moved " << moved << " m in 20 s";
  std::cerr << "the quadruped moved " << moved << " m in 20 s of virtual time\n";

  c.daemon->Signal(SIGTERM);
  EXPECT_EQ(c.daemon->WaitForExit(std::chrono::seconds(20)), 0);
}

TEST(YamordTest, EvaluateIsDeterministicAndRunsInParallel) {
  Connection c({"--workers", "2"});
  ASSERT_GT(c.port, 0);
  v1::EvaluateRequest request;
  request.set_warmup(1.0);
  request.set_duration(2.0);
  request.set_seed(42);
  auto* p = request.add_parameters();
  p->set_name("phase.0.1");
  p->set_value(2.5);
  v1::EvaluateResponse first, second;
  ASSERT_OK(Call(*c.stub, &v1::Host::Stub::Evaluate, request, &first));
  ASSERT_OK(Call(*c.stub, &v1::Host::Stub::Evaluate, request, &second));
  EXPECT_FALSE(first.diverged());
  EXPECT_EQ(first.velocity(), second.velocity()) << "same seed, same velocity";
  EXPECT_DOUBLE_EQ(first.velocity(), first.distance() / 2.0);

  v1::EvaluateResponse a, b;
  grpc::Status sa, sb;
  std::thread ta([&] { sa = Call(*c.stub, &v1::Host::Stub::Evaluate, request, &a); });
  std::thread tb([&] { sb = Call(*c.stub, &v1::Host::Stub::Evaluate, request, &b); });
  ta.join();
  tb.join();
  ASSERT_OK(sa);
  ASSERT_OK(sb);
  EXPECT_EQ(a.velocity(), first.velocity());
  EXPECT_EQ(b.velocity(), first.velocity());

  c.daemon->Signal(SIGINT);
  EXPECT_EQ(c.daemon->WaitForExit(std::chrono::seconds(20)), 0);
}

// A headless machine renders; one without a renderer says so and serves on.
TEST(YamordTest, FramesOnAHeadlessMachineAndUnavailableWithoutARenderer) {
  {
    ::unsetenv("DISPLAY");  // no X: rendering must not need it
    Connection c;
    ASSERT_GT(c.port, 0);
    v1::RenderFrameRequest request;
    request.set_width(320);
    request.set_height(240);
    v1::RenderFrameResponse frame;
    ASSERT_OK(Call(*c.stub, &v1::Host::Stub::RenderFrame, request, &frame));
    EXPECT_EQ(frame.png().substr(1, 3), "PNG");
  }
  ::setenv("YAMOR_RENDER_BACKEND", "none", 1);
  Connection c;
  ::unsetenv("YAMOR_RENDER_BACKEND");
  ASSERT_GT(c.port, 0);
  v1::RenderFrameRequest request;
  request.set_width(64);
  request.set_height(48);
  v1::RenderFrameResponse frame;
  const grpc::Status status = Call(*c.stub, &v1::Host::Stub::RenderFrame, request, &frame);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE);
  EXPECT_NE(status.error_message().find("no renderer"), std::string::npos)
      << status.error_message();
  v1::ElapsedTimeResponse time;
  ASSERT_OK(Call(*c.stub, &v1::Host::Stub::ElapsedTime, Empty(), &time));
  EXPECT_EQ(time.seconds(), 0.0) << "a failed render leaves the robot alone";
  c.daemon->Signal(SIGINT);
  EXPECT_EQ(c.daemon->WaitForExit(std::chrono::seconds(20)), 0);
}

// Threads of process `pid` whose name starts with "llvmpipe-" (Mesa's
// rasteriser threads name themselves so).
int LlvmpipeThreads(pid_t pid) {
  int n = 0;
  const std::filesystem::path tasks = "/proc/" + std::to_string(pid) + "/task";
  for (const auto& task : std::filesystem::directory_iterator(tasks)) {
    std::ifstream comm(task.path() / "comm");
    std::string name;
    std::getline(comm, name);
    n += name.rfind("llvmpipe-", 0) == 0;
  }
  return n;
}

// yamord rasterises frames on the rendering thread (LP_NUM_THREADS=0, set
// first thing in main) unless the user asked for llvmpipe's threads.
TEST(YamordTest, FramesAreRasterisedWithoutLlvmpipeThreadsUnlessTheUserAsks) {
  const char* saved = std::getenv("LP_NUM_THREADS");
  const std::optional<std::string> user = saved ? std::optional<std::string>(saved) : std::nullopt;
  for (const char* value : {static_cast<const char*>(nullptr), "2"}) {
    SCOPED_TRACE(value ? std::string("LP_NUM_THREADS=") + value : "LP_NUM_THREADS unset");
    if (value) {
      ::setenv("LP_NUM_THREADS", value, 1);
    } else {
      ::unsetenv("LP_NUM_THREADS");
    }
    // Mesa's software driver even where EGL could reach a GPU (which starts
    // no llvmpipe threads): the child inherits the environment as set here.
    ::setenv("LIBGL_ALWAYS_SOFTWARE", "1", 0);
    Connection c;
    if (user) {
      ::setenv("LP_NUM_THREADS", user->c_str(), 1);
    } else {
      ::unsetenv("LP_NUM_THREADS");
    }
    ASSERT_GT(c.port, 0);
    v1::RenderFrameRequest request;
    request.set_width(320);
    request.set_height(240);
    v1::RenderFrameResponse frame;
    const grpc::Status status = Call(*c.stub, &v1::Host::Stub::RenderFrame, request, &frame);
    if (status.error_code() == grpc::StatusCode::UNAVAILABLE) {
      GTEST_SKIP() << "no renderer here: " << status.error_message();
    }
    ASSERT_OK(status);
    EXPECT_EQ(frame.png().substr(1, 3), "PNG");
    EXPECT_EQ(LlvmpipeThreads(c.daemon->pid()), value ? 2 : 0);
    c.daemon->Signal(SIGINT);
    EXPECT_EQ(c.daemon->WaitForExit(std::chrono::seconds(20)), 0);
  }
}

TEST(YamordTest, SigtermDuringALongSleepDrainsAndExitsZero) {
  Connection c;
  ASSERT_GT(c.port, 0);
  ASSERT_OK(Call(*c.stub, &v1::Host::Stub::ConnectRobot, v1::ConnectRobotRequest()));
  grpc::Status sleep_status;
  std::thread sleeper([&] {
    v1::SleepRequest sleep;
    sleep.set_seconds(80000.0);  // most of a day of virtual time: far longer than the test
    grpc::ClientContext context;
    testing::SetDeadline(context, 15);
    v1::SleepResponse response;
    sleep_status = c.stub->Sleep(&context, sleep, &response);
  });
  // Wait until the world is being stepped by that Sleep.
  v1::ElapsedTimeResponse elapsed;
  grpc::Status poll_status;
  for (int i = 0; i < 3000 && elapsed.seconds() < 0.5 && poll_status.ok(); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    poll_status = Call(*c.stub, &v1::Host::Stub::ElapsedTime, Empty(), &elapsed);
  }
  EXPECT_TRUE(poll_status.ok()) << poll_status.error_message();
  EXPECT_GE(elapsed.seconds(), 0.5) << "the Sleep never started stepping";
  const auto signalled = Clock::now();
  c.daemon->Signal(SIGTERM);
  // Generous hang guard: the drain itself takes well under a second.
  EXPECT_EQ(c.daemon->WaitForExit(std::chrono::seconds(10)), 0);
  const double drain = std::chrono::duration<double>(Clock::now() - signalled).count();
  sleeper.join();
  // The daemon ends the Sleep with UNAVAILABLE ("yamord is shutting down"),
  // delivered before it exits, so the caller never waits for its deadline.
  EXPECT_TRUE(sleep_status.error_code() == grpc::StatusCode::CANCELLED ||
              sleep_status.error_code() == grpc::StatusCode::UNAVAILABLE)
      << sleep_status.error_code() << " " << sleep_status.error_message();
  std::cerr << "yamord drained and exited " << drain << " s after SIGTERM; the Sleep got "
            << sleep_status.error_code() << " (" << sleep_status.error_message() << ")\n";
}

TEST(YamordTest, SettingsFileFlagsAndPrintConfig) {
  const std::string path = ::testing::TempDir() + "/yamord_test_settings.toml";
  {
    std::ofstream out(path);
    out << "listen = \"127.0.0.1:0\"\nworld = \"snake\"\nworkers = 3\nmaster = 0\n"
           "link_timeout = 1.5\n[id_map]\n0 = 0\n";
  }
  {
    Daemon d({"--settings", path, "--workers", "5", "--print-config"});
    const std::string text = d.ReadAll();
    EXPECT_EQ(d.WaitForExit(std::chrono::seconds(20)), 0);
    EXPECT_NE(text.find("world = 'snake'"), std::string::npos) << text;
    EXPECT_NE(text.find("workers = 5"), std::string::npos) << "flags override the file\n" << text;
    EXPECT_NE(text.find("master = 0"), std::string::npos) << text;
    EXPECT_NE(text.find("link_timeout = 1.5"), std::string::npos) << text;
  }
  {
    Connection c({"--settings", path});
    ASSERT_GT(c.port, 0);
    v1::GetInfoResponse info;
    ASSERT_OK(Call(*c.stub, &v1::Host::Stub::GetInfo, Empty(), &info));
    EXPECT_EQ(info.world(), "snake");
    EXPECT_EQ(info.worker_capacity(), 3u);
    c.daemon->Signal(SIGTERM);
    EXPECT_EQ(c.daemon->WaitForExit(std::chrono::seconds(20)), 0);
  }
  {
    std::ofstream out(path);
    out << "listen = \"127.0.0.1:0\"\nwrold = \"snake\"\n";
  }
  {
    Daemon d({"--settings", path});
    EXPECT_EQ(d.ReadAll().find("listening"), std::string::npos);
    EXPECT_EQ(d.WaitForExit(std::chrono::seconds(20)), 2) << "unknown setting: exit 2";
  }
  {
    Daemon d({"--listen", "127.0.0.1:0", "--world", "unicorn"});
    EXPECT_EQ(d.WaitForExit(std::chrono::seconds(20)), 2) << "unknown world: exit 2";
  }
}

TEST(YamordTest, SerialBackendDrivesYamorBridgeOverTcpAndAMissingDeviceExits2) {
  // yamor-bridge in-process on an ephemeral loopback port.
  bridge::BridgeServer server(physics::Morphology::LoadFile(
      std::string(YAMOR_SOURCE_DIR) + "/configs/worlds/quadruped.xml"));
  bridge::BridgeTransport transport(
      server, bridge::TransportOptions{.kind = bridge::TransportOptions::Kind::kTcp,
                                       .tcp_port = 0});
  std::thread serving([&] { transport.Run(/*stop_on_signals=*/false); });
  const std::string device = "tcp://127.0.0.1:" + std::to_string(transport.Port());
  {
    Connection c({"--backend", "serial", "--device", device, "--hello-timeout", "5"});
    ASSERT_GT(c.port, 0) << "yamord did not start on " << device;
    v1::GetInfoResponse info;
    ASSERT_OK(Call(*c.stub, &v1::Host::Stub::GetInfo, Empty(), &info));
    EXPECT_EQ(info.backend(), "tcp");
    EXPECT_EQ(info.world(), device);
    v1::SimulationModeEnabledResponse simulation;
    ASSERT_OK(Call(*c.stub, &v1::Host::Stub::SimulationModeEnabled, Empty(), &simulation));
    EXPECT_TRUE(simulation.enabled()) << "the hello found yamor-bridge";
    v1::ConnectRobotResponse connected;
    ASSERT_OK(Call(*c.stub, &v1::Host::Stub::ConnectRobot, v1::ConnectRobotRequest(),
                   &connected));
    EXPECT_EQ(connected.links(), 8u);
    v1::SleepRequest sleep;
    sleep.set_seconds(0.5);
    ASSERT_OK(Call(*c.stub, &v1::Host::Stub::Sleep, sleep));
    v1::ElapsedTimeResponse elapsed;
    ASSERT_OK(Call(*c.stub, &v1::Host::Stub::ElapsedTime, Empty(), &elapsed));
    EXPECT_NEAR(elapsed.seconds(), 0.5, 0.01) << "virtual time, stepped over the link";
    v1::RobotPositionResponse position;
    ASSERT_OK(Call(*c.stub, &v1::Host::Stub::RobotPosition, Empty(), &position));
    EXPECT_GT(position.position().z(), 0.0);
    c.daemon->Signal(SIGTERM);
    EXPECT_EQ(c.daemon->WaitForExit(std::chrono::seconds(20)), 0);
  }
  transport.Stop();
  serving.join();
  EXPECT_GT(server.stats().decoder.frames, 8u);
  {
    Daemon d({"--listen", "127.0.0.1:0", "--backend", "serial", "--device",
              "/nonexistent/yamor/ttyUSB9"});
    EXPECT_EQ(d.ReadAll().find("listening"), std::string::npos);
    EXPECT_EQ(d.WaitForExit(std::chrono::seconds(20)), 2) << "device cannot be opened: exit 2";
  }
}

}  // namespace
}  // namespace yamor::host
