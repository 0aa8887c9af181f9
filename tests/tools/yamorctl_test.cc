// yamorctl against a recording fake of yamor.v1.Host: every command reaches
// its RPC with the right request and a deadline, output (readable and JSON)
// and exit codes follow the status. The real daemon is driven end to end by
// tests/python/test_yamorctl.py.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include "common/status.h"
#include "tools/yamorctl/yamorctl.h"
#include "yamor/v1/host.grpc.pb.h"

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
#undef YAMOR_FAKE

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

}  // namespace
}  // namespace yamor::yamorctl
