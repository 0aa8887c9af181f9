// yamorctl against a recording fake of yamor.v1.Host: every command reaches
// its RPC with the right request and a deadline, output (readable and JSON)
// and exit codes follow the status. The real daemon is driven end to end by
// tests/python/test_yamorctl.py.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gmock/gmock.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include "common/format.h"
#include "common/status.h"
#include "physics/render/image.h"
#include "host/camera_model.h"
#include "tools/camapp/camapp_server.h"
#include "tools/camapp/camera_emulator.h"
#include "tools/yamorctl/tracking.h"
#include "tools/yamorctl/yamorctl.h"
#include "yamor/v1/host.grpc.pb.h"
#include "yamor/v1/lifelong.grpc.pb.h"

namespace yamor::yamorctl {
namespace {

using google::protobuf::Empty;
using ::testing::HasSubstr;

/// One call the fake received.
struct Recorded {
  std::string method;
  std::string request;       // ShortDebugString of the request
  double deadline_seconds;   // time left until the call's deadline when it arrived
};

/// Records every call; answers with a canned response (or the default
/// message) and the status set by the test. Thread-safety: guarded by mutex_.
class RecordingHost final : public v1::Host::Service {
 public:
  /// The response `method` returns from now on.
  void SetResponse(const std::string& method, std::unique_ptr<google::protobuf::Message> r) {
    std::lock_guard<std::mutex> lock(mutex_);
    responses_[method] = std::move(r);
  }
  /// The status every later call returns.
  void SetStatus(grpc::Status status) {
    std::lock_guard<std::mutex> lock(mutex_);
    status_ = std::move(status);
  }
  std::vector<Recorded> calls() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return calls_;
  }
  void Clear() {
    std::lock_guard<std::mutex> lock(mutex_);
    calls_.clear();
  }

#define YAMOR_FAKE(Method, Request, Response)                                              \
  grpc::Status Method(grpc::ServerContext* context, const Request* request,                \
                      Response* response) override {                                       \
    return Record(#Method, *context, *request, response);                                  \
  }
  YAMOR_FAKE(ElapsedTime, Empty, v1::ElapsedTimeResponse)
  YAMOR_FAKE(RobotPosition, Empty, v1::RobotPositionResponse)
  YAMOR_FAKE(SimulationModeEnabled, Empty, v1::SimulationModeEnabledResponse)
  YAMOR_FAKE(AddCoupling, v1::AddCouplingRequest, Empty)
  YAMOR_FAKE(CloseSimulation, Empty, Empty)
  YAMOR_FAKE(ConnectRobot, v1::ConnectRobotRequest, v1::ConnectRobotResponse)
  YAMOR_FAKE(Flush, Empty, v1::FlushResponse)
  YAMOR_FAKE(GetAllModulesId, Empty, v1::GetAllModulesIdResponse)
  YAMOR_FAKE(GetCouplingPhase, v1::CouplingRequest, v1::ValueResponse)
  YAMOR_FAKE(SetCouplingPhase, v1::SetCouplingValueRequest, Empty)
  YAMOR_FAKE(GetCouplingWeight, v1::CouplingRequest, v1::ValueResponse)
  YAMOR_FAKE(SetCouplingWeight, v1::SetCouplingValueRequest, Empty)
  YAMOR_FAKE(GetModuleAmplitude, v1::ModuleRequest, v1::ValueResponse)
  YAMOR_FAKE(SetModuleAmplitude, v1::SetModuleValueRequest, Empty)
  YAMOR_FAKE(GetModuleMaxAngle, v1::ModuleRequest, v1::ValueResponse)
  YAMOR_FAKE(SetModuleMaxAngle, v1::SetModuleValueRequest, Empty)
  YAMOR_FAKE(GetModuleMinAngle, v1::ModuleRequest, v1::ValueResponse)
  YAMOR_FAKE(SetModuleMinAngle, v1::SetModuleValueRequest, Empty)
  YAMOR_FAKE(GetModuleOffset, v1::ModuleRequest, v1::ValueResponse)
  YAMOR_FAKE(SetModuleOffset, v1::SetModuleValueRequest, Empty)
  YAMOR_FAKE(GetModuleSpeed, v1::ModuleRequest, v1::ValueResponse)
  YAMOR_FAKE(SetModuleSpeed, v1::SetModuleValueRequest, Empty)
  YAMOR_FAKE(OpenSimulation, v1::OpenSimulationRequest, v1::OpenSimulationResponse)
  YAMOR_FAKE(Refresh, Empty, v1::FlushResponse)
  YAMOR_FAKE(RemoveAllCoupling, Empty, Empty)
  YAMOR_FAKE(SendControlMessage, v1::ControlMessageRequest, Empty)
  YAMOR_FAKE(Sleep, v1::SleepRequest, v1::SleepResponse)
  YAMOR_FAKE(GetInfo, Empty, v1::GetInfoResponse)
  YAMOR_FAKE(LoadConfig, v1::LoadConfigRequest, Empty)
  YAMOR_FAKE(SaveConfig, Empty, v1::SaveConfigResponse)
  YAMOR_FAKE(GetMorphology, Empty, v1::GetMorphologyResponse)
  YAMOR_FAKE(ConnectModules, v1::ConnectModulesRequest, Empty)
  YAMOR_FAKE(DisconnectModule, v1::ModuleRequest, Empty)
  YAMOR_FAKE(RunTransformationScript, v1::RunTransformationScriptRequest, Empty)
  YAMOR_FAKE(SetMotorDefect, v1::SetMotorDefectRequest, Empty)
  YAMOR_FAKE(SetModuleDefect, v1::SetModuleDefectRequest, Empty)
  YAMOR_FAKE(SetGround, v1::SetGroundRequest, Empty)
  YAMOR_FAKE(GetServoAngles, v1::GetServoAnglesRequest, v1::GetServoAnglesResponse)
  YAMOR_FAKE(GetAccelerometer, v1::GetAccelerometerRequest, v1::GetAccelerometerResponse)
  YAMOR_FAKE(GetOrientation, v1::GetOrientationRequest, v1::GetOrientationResponse)
  YAMOR_FAKE(ResetSimulation, Empty, Empty)
  YAMOR_FAKE(TurnUpsideDown, Empty, Empty)
  YAMOR_FAKE(Evaluate, v1::EvaluateRequest, v1::EvaluateResponse)
  YAMOR_FAKE(SetFreeRun, v1::SetFreeRunRequest, Empty)
  YAMOR_FAKE(RenderFrame, v1::RenderFrameRequest, v1::RenderFrameResponse)
  YAMOR_FAKE(SimulatedPosition, Empty, v1::RobotPositionResponse)
#undef YAMOR_FAKE

  grpc::Status RecordFrames(grpc::ServerContext* context, const v1::RecordFramesRequest* request,
                            grpc::ServerWriter<v1::VideoFrame>* writer) override {
    v1::VideoFrame unused;
    const grpc::Status status = Record("RecordFrames", *context, *request, &unused);
    if (!status.ok()) return status;
    // Two frames of the requested size (or 8x6), 1/frame_rate apart.
    const int width = request->width() > 0 && request->width() <= 64 ? request->width() : 8;
    const int height = request->height() > 0 && request->height() <= 64 ? request->height() : 6;
    render::Image image{.width = width, .height = height};
    image.rgba.assign(static_cast<std::size_t>(width) * height * 4, 200);
    const std::vector<uint8_t> png = render::EncodePng(image);
    for (uint32_t i = 0; i < 2; ++i) {
      v1::VideoFrame frame;
      frame.set_index(i);
      frame.set_time(i / (request->frame_rate() > 0 ? request->frame_rate() : 1.0));
      frame.set_png(png.data(), png.size());
      if (!writer->Write(frame)) break;
    }
    return grpc::Status::OK;
  }

  grpc::Status WatchState(grpc::ServerContext* context, const v1::WatchStateRequest* request,
                          grpc::ServerWriter<v1::StateUpdate>* writer) override {
    v1::StateUpdate unused;
    const grpc::Status status = Record("WatchState", *context, *request, &unused);
    if (!status.ok()) return status;
    // Updates at t = 0, period, 2 period ... until the client cancels.
    for (int i = 0; i < 1000 && !context->IsCancelled(); ++i) {
      v1::StateUpdate update;
      update.set_time(i * request->period());
      update.mutable_central()->mutable_position()->set_x(0.01 * i);
      if (i == 1) {
        v1::StateEvent* event = update.add_events();
        event->set_kind("defect_set");
        event->set_module_id(3);
        event->set_detail("motor limp");
      }
      if (!writer->Write(update)) break;
    }
    return grpc::Status::OK;
  }

 private:
  grpc::Status Record(const std::string& method, const grpc::ServerContext& context,
                      const google::protobuf::Message& request,
                      google::protobuf::Message* response) {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto left = context.deadline() - std::chrono::system_clock::now();
    calls_.push_back({method, request.ShortDebugString(),
                      std::chrono::duration<double>(left).count()});
    if (auto it = responses_.find(method); it != responses_.end()) response->CopyFrom(*it->second);
    return status_;
  }

  mutable std::mutex mutex_;
  std::vector<Recorded> calls_;                                                  // guarded
  std::map<std::string, std::unique_ptr<google::protobuf::Message>> responses_;  // guarded
  grpc::Status status_ = grpc::Status::OK;                                       // guarded
};

/// What one yamorctl command line printed and returned.
struct Result {
  int exit_code;
  std::string out;
  std::string err;
};

class YamorctlTest : public ::testing::Test {
 protected:
  void SetUp() override {
    grpc::ServerBuilder builder;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port_);
    builder.RegisterService(&fake_);
    server_ = builder.BuildAndStart();
    ASSERT_NE(server_, nullptr);
    ASSERT_NE(port_, 0);
  }
  void TearDown() override { server_->Shutdown(std::chrono::system_clock::now()); }

  /// Runs `yamorctl --host <fake> <args>`.
  Result Ctl(std::vector<std::string> args) {
    args.insert(args.begin(), {"--host", "127.0.0.1:" + std::to_string(port_)});
    std::ostringstream out, err;
    const int code = yamorctl::Run(args, out, err);
    return {code, out.str(), err.str()};
  }

  /// The single call the last command made.
  Recorded OnlyCall() {
    const std::vector<Recorded> calls = fake_.calls();
    EXPECT_EQ(calls.size(), 1u);
    return calls.empty() ? Recorded{} : calls.back();
  }

  std::string TempFile(const std::string& name, const std::string& text) {
    const std::filesystem::path path =
        std::filesystem::temp_directory_path() /
        ("yamorctl_test_" + std::to_string(::getpid()) + "_" + name);
    std::ofstream(path) << text;
    temp_files_.push_back(path);
    return path.string();
  }
  ~YamorctlTest() override {
    for (const auto& path : temp_files_) std::filesystem::remove(path);
  }

  RecordingHost fake_;
  std::unique_ptr<grpc::Server> server_;
  int port_ = 0;
  std::vector<std::filesystem::path> temp_files_;
};

// ---- every command reaches its RPC with the right request --------------------------

struct CommandCase {
  std::vector<std::string> args;
  std::string method;
  std::string request;  // ShortDebugString
};

TEST_F(YamorctlTest, EveryCommandSendsItsRequest) {
  const std::string config = TempFile("config.xml", "<yamorconfig/>");
  const std::string morphology = TempFile("morphology.xml", "<morphology/>");
  const std::string script = TempFile("script.xml", "<script/>");
  const std::vector<CommandCase> cases = {
      {{"time"}, "ElapsedTime", ""},
      {{"position"}, "RobotPosition", ""},
      {{"position", "--simulated"}, "SimulatedPosition", ""},
      {{"sim-enabled"}, "SimulationModeEnabled", ""},
      {{"couple", "2", "5", "1.5", "0.5"}, "AddCoupling",
       "from_id: 2 to_id: 5 phase: 1.5 weight: 0.5"},
      {{"close"}, "CloseSimulation", ""},
      {{"connect"}, "ConnectRobot", ""},
      {{"connect", "--link-timeout", "2.5", "--links-only"}, "ConnectRobot",
       "link_timeout: 2.5 links_only: true"},
      {{"flush"}, "Flush", ""},
      {{"modules"}, "GetAllModulesId", ""},
      {{"get", "phase", "2", "5"}, "GetCouplingPhase", "from_id: 2 to_id: 5"},
      {{"set", "phase", "2", "5", "1.57"}, "SetCouplingPhase", "from_id: 2 to_id: 5 value: 1.57"},
      {{"get", "weight", "2", "5"}, "GetCouplingWeight", "from_id: 2 to_id: 5"},
      {{"set", "weight", "2", "5", "0.25"}, "SetCouplingWeight",
       "from_id: 2 to_id: 5 value: 0.25"},
      {{"get", "amplitude", "3"}, "GetModuleAmplitude", "module_id: 3"},
      {{"set", "amplitude", "3", "0.5"}, "SetModuleAmplitude", "module_id: 3 value: 0.5"},
      {{"get", "maxangle", "3"}, "GetModuleMaxAngle", "module_id: 3"},
      {{"set", "maxangle", "3", "1.2"}, "SetModuleMaxAngle", "module_id: 3 value: 1.2"},
      {{"get", "minangle", "3"}, "GetModuleMinAngle", "module_id: 3"},
      {{"set", "minangle", "3", "-1.2"}, "SetModuleMinAngle", "module_id: 3 value: -1.2"},
      {{"get", "offset", "3"}, "GetModuleOffset", "module_id: 3"},
      {{"set", "offset", "3", "-0.5"}, "SetModuleOffset", "module_id: 3 value: -0.5"},
      {{"get", "speed", "3"}, "GetModuleSpeed", "module_id: 3"},
      {{"set", "speed", "3", "0.75"}, "SetModuleSpeed", "module_id: 3 value: 0.75"},
      {{"open"}, "OpenSimulation", ""},
      {{"open", "--world", "snake", "--seed", "7", "--step", "0.001"}, "OpenSimulation",
       "world: \"snake\" seed: 7 time_step: 0.001"},
      {{"open", "--morphology", morphology, "--config", config}, "OpenSimulation",
       "morphology_xml: \"<morphology/>\" config_xml: \"<yamorconfig/>\""},
      {{"refresh"}, "Refresh", ""},
      {{"uncouple-all"}, "RemoveAllCoupling", ""},
      {{"control", "--uart", "on", "--cpg", "on", "--motors", "on", "all"}, "SendControlMessage",
       "uart: SWITCH_ON cpg: SWITCH_ON motors: SWITCH_ON all: true"},
      {{"control", "--motors", "off", "3", "5"}, "SendControlMessage",
       "motors: SWITCH_OFF module_ids: 3 module_ids: 5"},
      {{"sleep", "5"}, "Sleep", "seconds: 5"},
      {{"sleep", "1.5", "--real"}, "Sleep", "seconds: 1.5 real_time: true"},
      {{"info"}, "GetInfo", ""},
      {{"load", config}, "LoadConfig",
       "config_xml: \"<yamorconfig/>\" source_name: \"" + config + "\""},
      {{"save"}, "SaveConfig", ""},
      {{"morphology"}, "GetMorphology", ""},
      {{"attach", "7", "front", "5", "rear", "90"}, "ConnectModules",
       "from_id: 7 to_id: 5 to_connector: CONNECTOR_REAR angle_degrees: 90"},
      {{"attach", "7", "top", "5", "bottom", "0"}, "ConnectModules",
       "from_id: 7 from_connector: CONNECTOR_TOP to_id: 5 to_connector: CONNECTOR_BOTTOM"},
      {{"detach", "7"}, "DisconnectModule", "module_id: 7"},
      {{"script", script}, "RunTransformationScript", "script_xml: \"<script/>\""},
      {{"defect", "motor", "3", "limp"}, "SetMotorDefect", "module_id: 3 defect: MOTOR_LIMP"},
      {{"defect", "motor", "3", "stuck"}, "SetMotorDefect", "module_id: 3 defect: MOTOR_STUCK"},
      {{"defect", "motor", "3", "ok"}, "SetMotorDefect", "module_id: 3"},
      {{"defect", "module", "3", "on"}, "SetModuleDefect", "module_id: 3 defective: true"},
      {{"defect", "module", "3", "off"}, "SetModuleDefect", "module_id: 3"},
      {{"ground", "--friction", "0.8"}, "SetGround", "friction: 0.8"},
      {{"ground", "--slope", "0.1", "--direction", "1.5"}, "SetGround",
       "slope: 0.1 slope_direction: 1.5"},
      {{"servos"}, "GetServoAngles", ""},
      {{"servos", "1", "2"}, "GetServoAngles", "module_ids: 1 module_ids: 2"},
      {{"accel", "4", "--samples", "3"}, "GetAccelerometer", "module_id: 4 samples: 3"},
      {{"orientation", "4", "--samples", "8", "--reference", "0", "1", "0"},
       "GetOrientation", "module_id: 4 samples: 8 reference_up { y: 1 }"},
      {{"reset"}, "ResetSimulation", ""},
      {{"upside-down"}, "TurnUpsideDown", ""},
      {{"watch", "--period", "0.5", "--count", "1"}, "WatchState", "period: 0.5"},
      {{"evaluate", "--world", "quadruped", "--param", "amplitude.3=0.5", "--param",
        "phase.2.5=-1", "--warmup", "2", "--duration", "3", "--seed", "9", "--trajectory", "0.5",
        "--step", "0.002"},
       "Evaluate",
       "world: \"quadruped\" parameters { name: \"amplitude.3\" value: 0.5 } parameters { name: "
       "\"phase.2.5\" value: -1 } warmup: 2 duration: 3 seed: 9 trajectory_period: 0.5 "
       "time_step: 0.002"},
      {{"evaluate", "--world", "quadruped", "--motor-defect", "3=limp", "--motor-defect", "4=stuck",
        "--module-defect", "5", "--friction", "0.2", "--slope", "0.1", "--slope-direction", "1.5",
        "--upside-down"},
       "Evaluate",
       "world: \"quadruped\" motor_defects { module_id: 3 defect: MOTOR_LIMP } motor_defects { "
       "module_id: 4 defect: MOTOR_STUCK } module_defects { module_id: 5 defective: true } ground { "
       "friction: 0.2 slope: 0.1 slope_direction: 1.5 } upside_down: true"},
      {{"evaluate", "--config", config, "--morphology", morphology}, "Evaluate",
       "config_xml: \"<yamorconfig/>\" morphology_xml: \"<morphology/>\""},
      {{"freerun", "2"}, "SetFreeRun", "real_time_factor: 2"},
      {{"snapshot", TempFile("frame.png", "")}, "RenderFrame",
       "camera { } width: 640 height: 480"},
      {{"snapshot", TempFile("top.png", ""), "--camera", "top", "--target", "1", "2", "0",
        "--camera-height", "1.5", "--width", "320", "--height", "240", "--no-legend"},
       "RenderFrame",
       "camera { kind: CAMERA_TOP target { x: 1 y: 2 } height: 1.5 } width: 320 height: 240 "
       "hide_legend: true"},
      {{"snapshot", TempFile("fixed.png", ""), "--camera", "fixed", "--eye", "1", "-1", "0.5",
        "--fov", "0.6", "--no-labels"},
       "RenderFrame",
       "camera { kind: CAMERA_FIXED eye { x: 1 y: -1 z: 0.5 } fov: 0.6 } width: 640 height: 480 "
       "hide_labels: true"},
      {{"record", "--seconds", "2", TempFile("walk.mp4", ""), "--distance", "1.2", "--elevation",
        "0.3", "--azimuth", "-1", "--width", "32", "--height", "24", "--fps", "10"},
       "RecordFrames",
       "camera { distance: 1.2 elevation: 0.3 azimuth: -1 } width: 32 height: 24 frame_rate: 10 "
       "seconds: 2"},
      {{"record", "--seconds", "1", "--watch", TempFile("watch.mp4", "")}, "RecordFrames",
       "camera { } width: 640 height: 480 frame_rate: 25 seconds: 1 watch: true"},
  };
  std::set<std::string> reached;
  for (const CommandCase& c : cases) {
    SCOPED_TRACE(::testing::PrintToString(c.args));
    fake_.Clear();
    const Result r = Ctl(c.args);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    const Recorded call = OnlyCall();
    EXPECT_EQ(call.method, c.method);
    EXPECT_EQ(call.request, c.request);
    EXPECT_GT(call.deadline_seconds, 0.0);
    reached.insert(call.method);
  }
  // The commands cover the whole service.
  const google::protobuf::ServiceDescriptor* service =
      google::protobuf::DescriptorPool::generated_pool()->FindServiceByName("yamor.v1.Host");
  ASSERT_NE(service, nullptr);
  for (int i = 0; i < service->method_count(); ++i) {
    EXPECT_TRUE(reached.count(service->method(i)->name()))
        << "no yamorctl command calls " << service->method(i)->name();
  }
}

// ---- deadlines ---------------------------------------------------------------------

// gRPC sends the timeout rounded up, so the server may see a little more.
constexpr double kSlack = 2.0;

TEST_F(YamorctlTest, EveryCallCarriesADeadline) {
  ASSERT_EQ(Ctl({"get", "amplitude", "3"}).exit_code, 0);
  double left = OnlyCall().deadline_seconds;
  EXPECT_GT(left, 5.0);  // default 10 s
  EXPECT_LE(left, kDefaultTimeout + kSlack);

  fake_.Clear();
  ASSERT_EQ(Ctl({"--timeout", "2", "info"}).exit_code, 0);
  left = OnlyCall().deadline_seconds;
  EXPECT_GT(left, 0.5);
  EXPECT_LE(left, 2.0 + kSlack);

  // A sleep adds its duration; evaluate its warm-up plus duration.
  fake_.Clear();
  ASSERT_EQ(Ctl({"sleep", "100"}).exit_code, 0);
  left = OnlyCall().deadline_seconds;
  EXPECT_GT(left, 100.0);
  EXPECT_LE(left, 110.0 + kSlack);

  fake_.Clear();
  ASSERT_EQ(Ctl({"evaluate"}).exit_code, 0);
  left = OnlyCall().deadline_seconds;
  EXPECT_GT(left, 20.0);  // 8 s + 12 s defaults
  EXPECT_LE(left, 30.0 + kSlack);

  // An explicit --timeout wins.
  fake_.Clear();
  ASSERT_EQ(Ctl({"sleep", "100", "--timeout", "3"}).exit_code, 0);
  EXPECT_LE(OnlyCall().deadline_seconds, 3.0 + kSlack);
}

// ---- output ------------------------------------------------------------------------

TEST_F(YamorctlTest, ReadableAndJsonOutput) {
  auto value = std::make_unique<v1::ValueResponse>();
  value->set_value(0.5);
  fake_.SetResponse("GetModuleAmplitude", std::move(value));
  Result r = Ctl({"get", "amplitude", "3"});
  EXPECT_EQ(r.out, "amplitude.3 = 0.5 rad\n");
  r = Ctl({"--json", "get", "amplitude", "3"});
  EXPECT_EQ(r.out, "{\"value\":0.5}\n");
  r = Ctl({"get", "amplitude", "3", "--json"});  // global options may follow the command
  EXPECT_EQ(r.out, "{\"value\":0.5}\n");

  // Defaults are printed, so scripts always find the keys.
  r = Ctl({"--json", "flush"});
  EXPECT_EQ(r.out, "{\"frames_sent\":0}\n");
  r = Ctl({"--json", "reset"});
  EXPECT_EQ(r.out, "{}\n");
  r = Ctl({"reset"});
  EXPECT_EQ(r.out, "");

  auto ids = std::make_unique<v1::GetAllModulesIdResponse>();
  for (uint32_t id : {0u, 1u, 7u}) ids->add_module_ids(id);
  fake_.SetResponse("GetAllModulesId", std::move(ids));
  EXPECT_EQ(Ctl({"modules"}).out, "0 1 7\n");
  EXPECT_EQ(Ctl({"--json", "modules"}).out, "{\"module_ids\":[0,1,7]}\n");

  auto position = std::make_unique<v1::RobotPositionResponse>();
  position->mutable_position()->set_x(0.25);
  position->set_time(20.0);
  position->set_source("simulation");
  fake_.SetResponse("RobotPosition", std::move(position));
  EXPECT_THAT(Ctl({"position"}).out,
              HasSubstr("position (0.2500, 0.0000, 0.0000) m at t=20.000 s (simulation)"));

  auto evaluation = std::make_unique<v1::EvaluateResponse>();
  evaluation->set_velocity(0.0125);
  evaluation->set_diverged(true);
  evaluation->set_divergence("body 3 left the world");
  fake_.SetResponse("Evaluate", std::move(evaluation));
  r = Ctl({"evaluate"});
  EXPECT_EQ(r.exit_code, 0);  // a diverged gait is a result, not an error
  EXPECT_THAT(r.out, HasSubstr("diverged: body 3 left the world"));
  EXPECT_THAT(r.out, HasSubstr("velocity  0.012500 m/s (1.25 cm/s)"));

  auto config = std::make_unique<v1::SaveConfigResponse>();
  config->set_config_xml("<yamorconfig/>");
  fake_.SetResponse("SaveConfig", std::move(config));
  EXPECT_EQ(Ctl({"save"}).out, "<yamorconfig/>\n");
  const std::string saved = TempFile("saved.xml", "");
  r = Ctl({"save", saved});
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_EQ(r.out, "");
  std::ifstream in(saved);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(text, "<yamorconfig/>");
}

TEST_F(YamorctlTest, WatchPrintsCountUpdatesThenStops) {
  Result r = Ctl({"watch", "--period", "0.5", "--count", "3"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("t=0.000 s"));
  EXPECT_THAT(r.out, HasSubstr("t=1.000 s"));
  EXPECT_THAT(r.out, HasSubstr("event defect_set module 3: motor limp"));
  EXPECT_EQ(r.out.find("t=1.500 s"), std::string::npos);

  r = Ctl({"--json", "watch", "--count", "2"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  std::istringstream lines(r.out);
  std::string line;
  int count = 0;
  while (std::getline(lines, line)) {
    EXPECT_EQ(line.front(), '{');
    EXPECT_EQ(line.back(), '}');
    EXPECT_THAT(line, HasSubstr("\"time\":"));
    ++count;
  }
  EXPECT_EQ(count, 2);
}

// ---- exit codes --------------------------------------------------------------------

TEST_F(YamorctlTest, FailedCallsExitWithTheGrpcCode) {
  const std::vector<std::pair<grpc::StatusCode, std::string>> statuses = {
      {grpc::StatusCode::NOT_FOUND, "NOT_FOUND"},
      {grpc::StatusCode::INVALID_ARGUMENT, "INVALID_ARGUMENT"},
      {grpc::StatusCode::OUT_OF_RANGE, "OUT_OF_RANGE"},
      {grpc::StatusCode::FAILED_PRECONDITION, "FAILED_PRECONDITION"},
      {grpc::StatusCode::UNIMPLEMENTED, "UNIMPLEMENTED"},
      {grpc::StatusCode::RESOURCE_EXHAUSTED, "RESOURCE_EXHAUSTED"},
      {grpc::StatusCode::INTERNAL, "INTERNAL"},
  };
  for (const auto& [code, name] : statuses) {
    fake_.SetStatus(grpc::Status(code, "module 42 does not exist"));
    for (const std::vector<std::string>& args :
         {std::vector<std::string>{"get", "amplitude", "42"},
          std::vector<std::string>{"--json", "set", "speed", "42", "1"},
          std::vector<std::string>{"watch", "--count", "1"}}) {
      const Result r = Ctl(args);
      EXPECT_EQ(r.exit_code, static_cast<int>(code)) << name;
      EXPECT_EQ(r.err, "yamorctl: " + name + ": module 42 does not exist\n");
      EXPECT_EQ(r.out, "");
    }
  }
}

TEST_F(YamorctlTest, NoDaemonIsUnavailable) {
  const int port = port_;
  server_->Shutdown(std::chrono::system_clock::now());
  server_->Wait();
  std::ostringstream out, err;
  const int code = yamorctl::Run(
      {"--host", "127.0.0.1:" + std::to_string(port), "--timeout", "5", "info"}, out, err);
  EXPECT_EQ(code, static_cast<int>(grpc::StatusCode::UNAVAILABLE));
  EXPECT_THAT(err.str(), HasSubstr("yamorctl: UNAVAILABLE: "));
}

TEST_F(YamorctlTest, UsageErrorsExitTwoWithoutCalling) {
  const std::vector<std::vector<std::string>> bad = {
      {},
      {"frobnicate"},
      {"get"},
      {"get", "amplitude"},
      {"get", "amplitude", "x"},
      {"get", "amplitude", "-1"},
      {"set", "amplitude", "3"},
      {"set", "amplitude", "3", "lots"},
      {"control", "--uart", "maybe", "all"},
      {"control", "--uart", "on"},
      {"control", "--uart", "on", "all", "3"},
      {"control", "--uart", "on", "three"},
      {"defect", "motor", "3", "broken"},
      {"defect", "module", "3", "yes"},
      {"attach", "7", "side", "5", "rear", "0"},
      {"open", "--world", "snake", "--morphology", "m.xml"},
      {"load", "/nonexistent/yamorctl/config.xml"},
      {"script", "/nonexistent/yamorctl/script.xml"},
      {"evaluate", "--param", "amplitude.3"},
      {"evaluate", "--param", "amplitude.3=fast"},
      {"evaluate", "--motor-defect", "3"},
      {"evaluate", "--motor-defect", "x=limp"},
      {"evaluate", "--motor-defect", "3=broken"},
      {"--timeout", "0", "info"},
      {"sleep"},
  };
  for (const std::vector<std::string>& args : bad) {
    SCOPED_TRACE(::testing::PrintToString(args));
    const Result r = Ctl(args);
    EXPECT_EQ(r.exit_code, kUsageExitCode);
    EXPECT_FALSE(r.err.empty());
  }
  EXPECT_TRUE(fake_.calls().empty());
}

TEST_F(YamorctlTest, HelpListsCommandsAndExitCodes) {
  const Result r = Ctl({"--help"});
  EXPECT_EQ(r.exit_code, 0);
  for (const char* text : {"evaluate", "watch", "uncouple-all", "Exit status", "5 NOT_FOUND",
                           "14 UNAVAILABLE", "3 INVALID_ARGUMENT", "usage error"}) {
    EXPECT_THAT(r.out, HasSubstr(text));
  }
  EXPECT_EQ(Ctl({"get", "--help"}).exit_code, 0);
}

// ---- LED tracking: track (a camera application on loopback) and calibrate --------

// The lines of a CSV file, header included.
std::vector<std::string> Lines(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

// Publishes `lines` once `server` has a client (the tracker of the command under test).
std::thread PublishWhenConnected(camapp::CamAppServer& server, std::vector<std::string> lines) {
  return std::thread([&server, lines = std::move(lines)] {
    for (int i = 0; i < 1000 && server.clients() == 0; ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    for (const std::string& line : lines) server.Publish(line, std::chrono::steady_clock::now());
  });
}

TEST_F(YamorctlTest, TrackRecordsRawAndCorrectedPositions) {
  camapp::CameraOptions camera;
  camera.noise = 0;
  const camapp::CameraEmulator emulator(camera);
  const std::string calibration = TempFile("camera.txt", emulator.CalibrationText(0.05));
  const std::string csv = TempFile("track.csv", "");
  Eigen::Vector2d pixel;
  ASSERT_TRUE(emulator.ProjectExact({0.3, -0.2, 0.05}, &pixel));
  camapp::CamAppServer server(camapp::CamAppServerOptions{.port = 0});
  std::thread publisher = PublishWhenConnected(
      server, {"7 40000 " + FormatDouble(std::round(pixel.x())) + " " + FormatDouble(std::round(pixel.y())),
               "8 80000 - -", "9 120000 320 240"});
  const Result r = Ctl({"track", "--camapp", "127.0.0.1:" + std::to_string(server.port()), "--calibration",
                        calibration, "--record", csv, "--samples", "3", "--timeout", "20"});
  publisher.join();
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("recorded 3 samples (2 with the LED, 2 in metres)"));
  const std::vector<std::string> lines = Lines(csv);
  ASSERT_EQ(lines.size(), 4u);
  EXPECT_EQ(lines[0], kTrackCsvHeader);
  std::vector<std::string> fields;
  std::stringstream row(lines[1]);
  for (std::string f; std::getline(row, f, ',');) fields.push_back(f);
  ASSERT_EQ(fields.size(), 9u) << lines[1];
  EXPECT_EQ(fields[1], "7");
  EXPECT_EQ(fields[2], "40000");
  EXPECT_EQ(fields[3], "1");
  EXPECT_NEAR(std::stod(fields[6]), 0.3, 0.004) << "metres, within a pixel's 3.3 mm";
  EXPECT_NEAR(std::stod(fields[7]), -0.2, 0.004);
  EXPECT_EQ(fields[8], "1") << "the first connection";
  EXPECT_THAT(lines[2], HasSubstr(",8,80000,0,,,,,1"));
}

TEST_F(YamorctlTest, TrackPrintsRawPixelsWithoutACalibration) {
  camapp::CamAppServer server(camapp::CamAppServerOptions{.port = 0});
  std::thread publisher = PublishWhenConnected(server, {"1 40000 320 240", "2 80000 - -"});
  Result r = Ctl({"track", "--camapp", "127.0.0.1:" + std::to_string(server.port()), "--samples", "2",
                  "--timeout", "20"});
  publisher.join();
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, "seq 1  camera 0.040000 s  pixel (320, 240)\nseq 2  camera 0.080000 s  LED not seen\n");
  EXPECT_TRUE(fake_.calls().empty()) << "the daemon is not involved";

  // Nobody listening: UNAVAILABLE after --timeout.
  const int port = server.port();
  r = Ctl({"track", "--camapp", "127.0.0.1:" + std::to_string(port == 65535 ? 1 : port + 1), "--timeout",
           "0.3"});
  EXPECT_EQ(r.exit_code, static_cast<int>(grpc::StatusCode::UNAVAILABLE)) << r.err;
  EXPECT_THAT(r.err, HasSubstr("not connected after 0.3 s"));
  EXPECT_EQ(Ctl({"track", "--camapp", "nowhere"}).exit_code, kUsageExitCode);
  EXPECT_EQ(Ctl({"track", "--calibration", "/nonexistent/camera.txt"}).exit_code, kUsageExitCode);
}

TEST_F(YamorctlTest, CalibrateReportsEachPointsErrorAndWritesTheFile) {
  camapp::CameraOptions camera;
  camera.noise = 0;
  const camapp::CameraEmulator emulator(camera);
  const std::string lens = TempFile("lens.txt", emulator.CalibrationText(0.05));
  // Reference points as a lab measures them: whole pixels where the LED was seen.
  std::string points = "# x y X Y\n";
  for (double x : {-0.8, 0.0, 0.8}) {
    for (double y : {-0.6, 0.0, 0.6}) {
      Eigen::Vector2d p;
      ASSERT_TRUE(emulator.ProjectExact({x, y, 0.05}, &p));
      points += FormatDouble(std::round(p.x())) + " " + FormatDouble(std::round(p.y())) + " " +
                FormatDouble(x) + " " + FormatDouble(y) + "\n";
    }
  }
  const std::string points_file = TempFile("points.txt", points);
  const std::string output = TempFile("calibrated.txt", "");
  Result r = Ctl({"calibrate", points_file, "--lens", lens, "--output", output});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("err [mm]"));
  EXPECT_THAT(r.out, HasSubstr("9 reference points: reprojection error RMS "));
  EXPECT_THAT(r.out, HasSubstr("calibration written to " + output));
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1 + 9 + 2) << r.out;
  const host::CameraModel model = host::LoadCameraModel(output);
  EXPECT_EQ(model.fit().residuals.size(), 9u);
  EXPECT_LT(model.fit().max_error, 0.004) << "whole pixels: within a pixel's 3.3 mm";
  EXPECT_GT(model.fit().max_error, 0.0);
  EXPECT_DOUBLE_EQ(model.led_height(), 0.05) << "from the lens file";
  EXPECT_EQ(model.lens().params().k1, camera.k1);

  r = Ctl({"--json", "calibrate", output, "--led-height", "0.07"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("\"rms_m\":"));
  EXPECT_THAT(r.out, HasSubstr("\"led_height\":0.07"));
  EXPECT_THAT(r.out, HasSubstr("{\"line\":"));

  const std::string three = TempFile("three.txt", "1 1 0 0\n100 1 1 0\n100 100 1 1\n");
  r = Ctl({"calibrate", three, "--lens", lens});
  EXPECT_EQ(r.exit_code, static_cast<int>(StatusCode::kInvalidArgument));
  EXPECT_THAT(r.err, HasSubstr(three + ":1,2,3: 3 reference points; at least 4"));
  EXPECT_EQ(Ctl({"calibrate", "/nonexistent/points.txt"}).exit_code, kUsageExitCode);
  EXPECT_EQ(Ctl({"calibrate", points_file}).exit_code, static_cast<int>(StatusCode::kInvalidArgument))
      << "a points file needs --lens";
  EXPECT_TRUE(fake_.calls().empty());
}

// ---- parsing helpers ---------------------------------------------------------------

TEST(ParseParameterAssignment, NameAndValue) {
  EXPECT_EQ(ParseParameterAssignment("amplitude.3=0.5"),
            (std::pair<std::string, double>{"amplitude.3", 0.5}));
  EXPECT_EQ(ParseParameterAssignment("phase.2.5=-1.57"),
            (std::pair<std::string, double>{"phase.2.5", -1.57}));
  for (const char* bad : {"amplitude.3", "=0.5", "amplitude.3=", "amplitude.3=0.5x", "a=b"}) {
    EXPECT_THROW(ParseParameterAssignment(bad), Error) << bad;
  }
}

TEST(ParseModuleTargets, AllOrIds) {
  EXPECT_EQ(ParseModuleTargets({"all"}), (std::pair<bool, std::vector<uint32_t>>{true, {}}));
  EXPECT_EQ(ParseModuleTargets({"3", "5"}),
            (std::pair<bool, std::vector<uint32_t>>{false, {3, 5}}));
  for (const std::vector<std::string>& bad : std::vector<std::vector<std::string>>{
           {}, {"all", "3"}, {"3", "all"}, {"x"}, {"-1"}, {"3x"}, {""}}) {
    EXPECT_THROW(ParseModuleTargets(bad), Error) << ::testing::PrintToString(bad);
  }
}

// ---- life: a running yamor-lifelong's status service -------------------------------

/// A yamor-lifelong status service with a fixed status and two events.
class FakeLife final : public v1::Lifelong::Service {
 public:
  grpc::Status GetLifeStatus(grpc::ServerContext*, const Empty*, v1::LifeStatus* out) override {
    *out = Status();
    return grpc::Status::OK;
  }
  grpc::Status WatchLife(grpc::ServerContext*, const v1::WatchLifeRequest* request,
                         grpc::ServerWriter<v1::LifeUpdate>* writer) override {
    replay_seen = request->replay();
    for (int i = 0; i < 2; ++i) {
      v1::LifeUpdate u;
      u.set_index(static_cast<uint64_t>(i));
      u.set_time(10.0 * (i + 1));
      u.set_kind(i == 0 ? "start" : "anomaly");
      u.set_json(i == 0 ? R"({"time":10,"kind":"start"})" : R"({"time":20,"kind":"anomaly","trigger":"orientation"})");
      *u.mutable_status() = Status();
      writer->Write(u);
    }
    return grpc::Status::OK;  // the life ended
  }
  static v1::LifeStatus Status() {
    v1::LifeStatus s;
    s.set_state("relearning");
    s.set_time(125.5);
    s.set_velocity(0.0123);
    s.set_ema(0.025);
    s.set_threshold(0.0075);
    s.set_gait(2);
    s.set_anomalies(1);
    s.set_relearns(1);
    s.set_trials(7);
    s.set_relearn_trials(7);
    s.set_relearn_budget(100);
    s.set_mode("online");
    s.set_robot("127.0.0.1:2224");
    s.set_detail("trial 7");
    return s;
  }
  std::atomic<bool> replay_seen{false};
};

TEST(YamorctlLifeTest, LifeShowsTheStatusAndWatchStreamsTheEvents) {
  FakeLife life;
  int port = 0;
  grpc::ServerBuilder builder;
  builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
  builder.RegisterService(&life);
  std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
  ASSERT_NE(server, nullptr);
  const std::string host = "127.0.0.1:" + std::to_string(port);
  auto ctl = [&](std::vector<std::string> args) {
    args.insert(args.begin(), {"--host", host});
    std::ostringstream out, err;
    const int code = yamorctl::Run(args, out, err);
    return Result{code, out.str(), err.str()};
  };
  const Result status = ctl({"life"});
  EXPECT_EQ(status.exit_code, 0) << status.err;
  EXPECT_THAT(status.out, HasSubstr("relearning at t=125.5 s"));
  EXPECT_THAT(status.out, HasSubstr("velocity 1.23 cm/s"));
  EXPECT_THAT(status.out, HasSubstr("threshold 0.75 cm/s"));
  EXPECT_THAT(status.out, HasSubstr("gait 2"));
  EXPECT_THAT(status.out, HasSubstr("trial 7 of 100"));
  const Result json = ctl({"life", "--json"});
  EXPECT_EQ(json.exit_code, 0);
  EXPECT_THAT(json.out, HasSubstr(R"("relearn_budget":"100")"));
  const Result watch = ctl({"life", "--watch", "--replay"});
  EXPECT_EQ(watch.exit_code, 0) << watch.err;
  EXPECT_TRUE(life.replay_seen.load());
  EXPECT_THAT(watch.out, HasSubstr("start"));
  EXPECT_THAT(watch.out, HasSubstr(R"("trigger":"orientation")"));
  EXPECT_EQ(std::count(watch.out.begin(), watch.out.end(), '\n'), 2);
  server->Shutdown(std::chrono::system_clock::now());
  // No life there: UNAVAILABLE's exit code.
  const Result gone = ctl({"life", "--timeout", "2"});
  EXPECT_EQ(gone.exit_code, static_cast<int>(grpc::StatusCode::UNAVAILABLE)) << gone.err;
}

}  // namespace
}  // namespace yamor::yamorctl
