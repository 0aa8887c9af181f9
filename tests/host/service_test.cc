// The gRPC service over a real server on 127.0.0.1:0 inside the test.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <span>
#include <string>
#include <thread>

#include "host/service.h"
#include "host/sim_backend.h"
#include "host/worlds.h"
#include "physics/render/image.h"
#include "tests/host/grpc_util.h"
#include "tests/host/test_util.h"

namespace yamor::host {
namespace {

namespace v1 = yamor::v1;
using google::protobuf::Empty;

// Calls a unary stub method with a deadline.
template <typename Request, typename Response>
grpc::Status Call(v1::Host::Stub& stub,
                  grpc::Status (v1::Host::Stub::*method)(grpc::ClientContext*, const Request&,
                                                         Response*),
                  const Request& request, Response* response = nullptr) {
  grpc::ClientContext context;
  testing::SetDeadline(context, 60);
  Response scratch;
  return (stub.*method)(&context, request, response ? response : &scratch);
}

class ServiceTest : public ::testing::Test {
 protected:
  void Start(unsigned max_concurrent_calls = 64) {
    driver_ = std::make_unique<RobotDriver>(DriverOptions{}, testing::QuadrupedConfig());
    ResolvedWorld world = ResolveWorld(WorldRequest{.world = "quadruped"}, kDefaultWorld, false);
    driver_->OpenSimulation(SimulationSpec{.morphology = std::move(world.morphology),
                                           .world_name = "quadruped"});
    pool_ = std::make_unique<WorkerPool>(2);
    server_ = std::make_unique<HostServer>(
        *driver_, *pool_,
        ServerOptions{.listen = "127.0.0.1:0",
                      .service = {.max_concurrent_calls = max_concurrent_calls}});
    channel_ = grpc::CreateChannel("127.0.0.1:" + std::to_string(server_->port()),
                                   grpc::InsecureChannelCredentials());
    stub_ = v1::Host::NewStub(channel_);
  }
  void SetUp() override { Start(); }
  void TearDown() override {
    server_->Shutdown(std::chrono::seconds(2));
    pool_->Shutdown();
  }
  void Restart(unsigned max_concurrent_calls) {
    TearDown();
    Start(max_concurrent_calls);
  }

  std::unique_ptr<RobotDriver> driver_;
  std::unique_ptr<WorkerPool> pool_;
  std::unique_ptr<HostServer> server_;
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::Host::Stub> stub_;
};

#define EXPECT_OK(expr)                                                        \
  do {                                                                         \
    const grpc::Status status_ = (expr);                                       \
    EXPECT_TRUE(status_.ok()) << #expr << ": " << status_.error_code() << " " \
                              << status_.error_message();                      \
  } while (false)

TEST(ToGrpcStatusTest, KeepsYamorCodesAndMapsEverythingElseToInternal) {
  auto status_of = [](auto thrower) {
    try {
      thrower();
    } catch (...) {
      return ToGrpcStatus(std::current_exception());
    }
    return grpc::Status::OK;
  };
  grpc::Status s = status_of([] { throw Error(StatusCode::kNotFound, "module 9 is absent"); });
  EXPECT_EQ(s.error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(s.error_message(), "module 9 is absent");
  s = status_of([] { throw Error(StatusCode::kResourceExhausted, "full"); });
  EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  s = status_of([] { throw std::runtime_error("boom"); });
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INTERNAL);
  EXPECT_NE(s.error_message().find("boom"), std::string::npos);
  s = status_of([] { throw 42; });
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INTERNAL);
}

TEST_F(ServiceTest, EveryRpcWorks) {
  v1::Host::Stub& stub = *stub_;
  v1::GetInfoResponse info;
  EXPECT_OK(Call(stub, &v1::Host::Stub::GetInfo, Empty(), &info));
  EXPECT_EQ(info.version(), YAMOR_VERSION);
  EXPECT_EQ(info.backend(), "simulation");
  EXPECT_EQ(info.worker_capacity(), 2u);
  EXPECT_EQ(info.world(), "quadruped");
  EXPECT_EQ(info.master_node(), 4u);
  EXPECT_FALSE(info.connected());
  EXPECT_EQ(info.max_concurrent_calls(), 64u);
  EXPECT_GE(info.builtin_worlds_size(), 6);

  v1::SimulationModeEnabledResponse mode;
  EXPECT_OK(Call(stub, &v1::Host::Stub::SimulationModeEnabled, Empty(), &mode));
  EXPECT_TRUE(mode.enabled());
  v1::GetAllModulesIdResponse ids;
  EXPECT_OK(Call(stub, &v1::Host::Stub::GetAllModulesId, Empty(), &ids));
  EXPECT_EQ(ids.module_ids_size(), 9);

  v1::OpenSimulationRequest open;
  open.set_world("quadruped");
  open.set_seed(3);
  v1::OpenSimulationResponse opened;
  EXPECT_OK(Call(stub, &v1::Host::Stub::OpenSimulation, open, &opened));
  EXPECT_EQ(opened.module_ids_size(), 9);
  EXPECT_EQ(opened.central_module(), 4u);
  v1::GetMorphologyResponse morphology;
  EXPECT_OK(Call(stub, &v1::Host::Stub::GetMorphology, Empty(), &morphology));
  EXPECT_NE(morphology.morphology_xml().find("<morphology"), std::string::npos);
  EXPECT_EQ(morphology.central_module(), 4u);

  v1::SaveConfigResponse saved;
  EXPECT_OK(Call(stub, &v1::Host::Stub::SaveConfig, Empty(), &saved));
  EXPECT_NE(saved.config_xml().find("realid=\"8\""), std::string::npos);
  v1::LoadConfigRequest load;
  load.set_config_xml(saved.config_xml());
  load.set_source_name("saved.xml");
  EXPECT_OK(Call(stub, &v1::Host::Stub::LoadConfig, load));

  v1::ConnectRobotResponse connected;
  EXPECT_OK(Call(stub, &v1::Host::Stub::ConnectRobot, v1::ConnectRobotRequest(), &connected));
  EXPECT_EQ(connected.links(), 8u);
  EXPECT_EQ(connected.frames_sent(), 1u + 8u + 27u + 16u);
  v1::ControlMessageRequest control;
  control.set_uart(v1::SWITCH_ON);
  control.set_cpg(v1::SWITCH_ON);
  control.set_motors(v1::SWITCH_ON);
  control.set_all(true);
  EXPECT_OK(Call(stub, &v1::Host::Stub::SendControlMessage, control));

  using ModuleGetter = grpc::Status (v1::Host::Stub::*)(grpc::ClientContext*,
                                                       const v1::ModuleRequest&,
                                                       v1::ValueResponse*);
  using ModuleSetter = grpc::Status (v1::Host::Stub::*)(grpc::ClientContext*,
                                                       const v1::SetModuleValueRequest&, Empty*);
  const std::tuple<ModuleGetter, ModuleSetter, double> fields[] = {
      {&v1::Host::Stub::GetModuleAmplitude, &v1::Host::Stub::SetModuleAmplitude, 0.7},
      {&v1::Host::Stub::GetModuleOffset, &v1::Host::Stub::SetModuleOffset, 0.1},
      {&v1::Host::Stub::GetModuleSpeed, &v1::Host::Stub::SetModuleSpeed, 0.4},
      {&v1::Host::Stub::GetModuleMinAngle, &v1::Host::Stub::SetModuleMinAngle, -0.7},
      {&v1::Host::Stub::GetModuleMaxAngle, &v1::Host::Stub::SetModuleMaxAngle, 0.75},
  };
  for (const auto& [getter, setter, value] : fields) {
    v1::SetModuleValueRequest set;
    set.set_module_id(1);
    set.set_value(value);
    EXPECT_OK(Call(stub, setter, set));
    v1::ModuleRequest get;
    get.set_module_id(1);
    v1::ValueResponse got;
    EXPECT_OK(Call(stub, getter, get, &got));
    EXPECT_DOUBLE_EQ(got.value(), value);
  }
  v1::AddCouplingRequest add;
  add.set_from_id(5);
  add.set_to_id(6);
  add.set_phase(0.3);
  add.set_weight(0.5);
  EXPECT_OK(Call(stub, &v1::Host::Stub::AddCoupling, add));
  v1::SetCouplingValueRequest set_coupling;
  set_coupling.set_from_id(5);
  set_coupling.set_to_id(6);
  set_coupling.set_value(0.4);
  EXPECT_OK(Call(stub, &v1::Host::Stub::SetCouplingPhase, set_coupling));
  set_coupling.set_value(2.0);
  EXPECT_OK(Call(stub, &v1::Host::Stub::SetCouplingWeight, set_coupling));
  v1::CouplingRequest coupling;
  coupling.set_from_id(5);
  coupling.set_to_id(6);
  v1::ValueResponse value;
  EXPECT_OK(Call(stub, &v1::Host::Stub::GetCouplingPhase, coupling, &value));
  EXPECT_DOUBLE_EQ(value.value(), 0.4);
  EXPECT_OK(Call(stub, &v1::Host::Stub::GetCouplingWeight, coupling, &value));
  EXPECT_DOUBLE_EQ(value.value(), 2.0);
  v1::FlushResponse flushed;
  EXPECT_OK(Call(stub, &v1::Host::Stub::Flush, Empty(), &flushed));
  EXPECT_EQ(flushed.frames_sent(), 3u) << "oscillator + limits of module 1, coupling 5 -> 6";
  EXPECT_OK(Call(stub, &v1::Host::Stub::Refresh, Empty(), &flushed));
  EXPECT_EQ(flushed.frames_sent(), 27u + 17u);

  v1::SleepRequest sleep;
  sleep.set_seconds(1.0);
  v1::SleepResponse slept;
  EXPECT_OK(Call(stub, &v1::Host::Stub::Sleep, sleep, &slept));
  EXPECT_NEAR(slept.time(), 1.0, 1e-9);
  v1::ElapsedTimeResponse elapsed;
  EXPECT_OK(Call(stub, &v1::Host::Stub::ElapsedTime, Empty(), &elapsed));
  EXPECT_NEAR(elapsed.seconds(), 1.0, 1e-9);
  v1::RobotPositionResponse position;
  EXPECT_OK(Call(stub, &v1::Host::Stub::RobotPosition, Empty(), &position));
  EXPECT_EQ(position.source(), "simulation");
  EXPECT_NEAR(position.time(), 1.0, 1e-9);
  EXPECT_GT(position.position().z(), 0.0);

  v1::GetServoAnglesResponse angles;
  EXPECT_OK(Call(stub, &v1::Host::Stub::GetServoAngles, v1::GetServoAnglesRequest(), &angles));
  EXPECT_EQ(angles.angles_size(), 9);
  v1::GetAccelerometerRequest accel;
  accel.set_module_id(4);
  accel.set_samples(2);
  v1::GetAccelerometerResponse samples;
  EXPECT_OK(Call(stub, &v1::Host::Stub::GetAccelerometer, accel, &samples));
  EXPECT_EQ(samples.samples_size(), 2);

  v1::SetMotorDefectRequest motor;
  motor.set_module_id(2);
  motor.set_defect(v1::MOTOR_LIMP);
  EXPECT_OK(Call(stub, &v1::Host::Stub::SetMotorDefect, motor));
  v1::SetModuleDefectRequest module_defect;
  module_defect.set_module_id(5);
  module_defect.set_defective(true);
  EXPECT_OK(Call(stub, &v1::Host::Stub::SetModuleDefect, module_defect));
  v1::SetGroundRequest ground;
  ground.set_friction(0.5);
  ground.set_slope(0.05);
  EXPECT_OK(Call(stub, &v1::Host::Stub::SetGround, ground));

  v1::EvaluateRequest evaluate;
  evaluate.set_warmup(0.5);
  evaluate.set_duration(1.0);
  evaluate.set_seed(1);
  evaluate.set_trajectory_period(0.5);
  auto* parameter = evaluate.add_parameters();
  parameter->set_name("amplitude.0");
  parameter->set_value(0.5);
  v1::EvaluateResponse evaluated;
  EXPECT_OK(Call(stub, &v1::Host::Stub::Evaluate, evaluate, &evaluated));
  EXPECT_TRUE(std::isfinite(evaluated.velocity()));
  EXPECT_FALSE(evaluated.diverged());
  EXPECT_EQ(evaluated.trajectory_size(), 4);
  EXPECT_GT(evaluated.wall_seconds(), 0.0);

  v1::SetFreeRunRequest free_run;
  free_run.set_real_time_factor(0.0);
  EXPECT_OK(Call(stub, &v1::Host::Stub::SetFreeRun, free_run));
  v1::RunTransformationScriptRequest script;
  script.set_script_xml("<script><pause delay=\"50\"/></script>");
  EXPECT_OK(Call(stub, &v1::Host::Stub::RunTransformationScript, script));
  EXPECT_OK(Call(stub, &v1::Host::Stub::ElapsedTime, Empty(), &elapsed));
  EXPECT_NEAR(elapsed.seconds(), 1.05, 1e-9);

  // Take knee 5 off and screw it back on (as configs/worlds/quadruped.xml
  // has it). A bridge without reconfiguration answers a clear UNIMPLEMENTED.
  const grpc::StatusCode reconfiguration =
      testing::BridgeReconfigures() ? grpc::StatusCode::OK : grpc::StatusCode::UNIMPLEMENTED;
  v1::ModuleRequest module;
  module.set_module_id(5);
  EXPECT_EQ(Call(stub, &v1::Host::Stub::DisconnectModule, module).error_code(), reconfiguration);
  v1::ConnectModulesRequest connect_modules;
  connect_modules.set_from_id(5);
  connect_modules.set_from_connector(v1::CONNECTOR_FRONT);
  connect_modules.set_to_id(0);
  connect_modules.set_to_connector(v1::CONNECTOR_REAR);
  connect_modules.set_angle_degrees(270);
  EXPECT_EQ(Call(stub, &v1::Host::Stub::ConnectModules, connect_modules).error_code(),
            reconfiguration);

  EXPECT_OK(Call(stub, &v1::Host::Stub::RemoveAllCoupling, Empty()));
  EXPECT_EQ(Call(stub, &v1::Host::Stub::GetCouplingPhase, coupling).error_code(),
            grpc::StatusCode::NOT_FOUND);
  EXPECT_OK(Call(stub, &v1::Host::Stub::ResetSimulation, Empty()));
  EXPECT_OK(Call(stub, &v1::Host::Stub::ElapsedTime, Empty(), &elapsed));
  EXPECT_EQ(elapsed.seconds(), 0.0);
  EXPECT_OK(Call(stub, &v1::Host::Stub::CloseSimulation, Empty()));
  EXPECT_OK(Call(stub, &v1::Host::Stub::SimulationModeEnabled, Empty(), &mode));
  EXPECT_FALSE(mode.enabled());
  EXPECT_OK(Call(stub, &v1::Host::Stub::GetInfo, Empty(), &info));
  EXPECT_EQ(info.backend(), "none");
}

TEST_F(ServiceTest, WatchStateStreamsPosesAndEvents) {
  grpc::ClientContext context;
  testing::SetDeadline(context, 60);
  v1::WatchStateRequest request;
  request.set_period(0.25);
  std::unique_ptr<grpc::ClientReader<v1::StateUpdate>> reader = stub_->WatchState(&context, request);
  v1::StateUpdate update;
  ASSERT_TRUE(reader->Read(&update)) << "the first update comes at once";
  EXPECT_EQ(update.time(), 0.0);
  std::thread driver_calls([&] {
    v1::ConnectRobotRequest connect;
    EXPECT_OK(Call(*stub_, &v1::Host::Stub::ConnectRobot, connect));
    v1::SleepRequest sleep;
    sleep.set_seconds(1.0);
    EXPECT_OK(Call(*stub_, &v1::Host::Stub::Sleep, sleep));
  });
  bool saw_connected = false;
  double last_time = 0.0;
  while (last_time < 1.0 - 1e-9 && reader->Read(&update)) {
    for (const v1::StateEvent& e : update.events()) saw_connected |= e.kind() == "connected";
    EXPECT_GE(update.time(), last_time);
    last_time = update.time();
  }
  driver_calls.join();
  EXPECT_TRUE(saw_connected);
  EXPECT_NEAR(last_time, 1.0, 1e-9);
  context.TryCancel();
  while (reader->Read(&update)) {
  }
  const grpc::Status status = reader->Finish();
  EXPECT_EQ(status.error_code(), grpc::StatusCode::CANCELLED) << status.error_message();
}

// RenderFrame / RecordFrames: codes for bad input before the robot is
// touched, frames while another client drives the robot, no robot lock
// while a stream waits on its client.
TEST_F(ServiceTest, FramesRefuseBadInputAndLeaveTheRobotAlone) {
  using Code = grpc::StatusCode;
  auto render = [&](uint32_t width, uint32_t height, const v1::Camera& camera) {
    v1::RenderFrameRequest request;
    request.set_width(width);
    request.set_height(height);
    *request.mutable_camera() = camera;
    v1::RenderFrameResponse response;
    return Call(*stub_, &v1::Host::Stub::RenderFrame, request, &response);
  };
  v1::Camera follow;
  EXPECT_EQ(render(0, 480, follow).error_code(), Code::OUT_OF_RANGE);
  EXPECT_EQ(render(640, 4097, follow).error_message(), "frame height 4097 is outside 1..4096");
  v1::Camera nan = follow;
  nan.set_elevation(std::nan(""));
  EXPECT_EQ(render(64, 48, nan).error_message(), "camera elevation is not finite: nan");
  v1::Camera degenerate;
  degenerate.set_kind(v1::CAMERA_FIXED);
  degenerate.mutable_eye()->set_z(1.0);
  degenerate.mutable_target()->set_z(1.0);
  EXPECT_EQ(render(64, 48, degenerate).error_code(), Code::INVALID_ARGUMENT);
  v1::Camera bad_kind;
  bad_kind.set_kind(static_cast<v1::CameraKind>(7));
  EXPECT_EQ(render(64, 48, bad_kind).error_code(), Code::INVALID_ARGUMENT);

  auto record = [&](double rate, double seconds) {
    grpc::ClientContext context;
    testing::SetDeadline(context, 60);
    v1::RecordFramesRequest request;
    request.set_width(32);
    request.set_height(24);
    request.set_frame_rate(rate);
    request.set_seconds(seconds);
    auto reader = stub_->RecordFrames(&context, request);
    v1::VideoFrame frame;
    int frames = 0;
    while (reader->Read(&frame)) ++frames;
    const grpc::Status status = reader->Finish();
    return std::make_pair(status.error_code(), frames);
  };
  EXPECT_EQ(record(0, 1), std::make_pair(Code::OUT_OF_RANGE, 0));
  EXPECT_EQ(record(std::nan(""), 1), std::make_pair(Code::INVALID_ARGUMENT, 0));
  EXPECT_EQ(record(25, 0), std::make_pair(Code::OUT_OF_RANGE, 0));
  EXPECT_EQ(record(240, 3600), std::make_pair(Code::OUT_OF_RANGE, 0));  // too many frames
  v1::ElapsedTimeResponse time;
  EXPECT_OK(Call(*stub_, &v1::Host::Stub::ElapsedTime, Empty(), &time));
  EXPECT_EQ(time.seconds(), 0.0) << "a refused recording never steps the world";

  v1::RenderFrameRequest request;
  request.set_width(64);
  request.set_height(48);
  v1::RenderFrameResponse response;
  const grpc::Status status = Call(*stub_, &v1::Host::Stub::RenderFrame, request, &response);
  if (status.error_code() == Code::UNAVAILABLE) GTEST_SKIP() << status.error_message();
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(response.png().substr(1, 3), "PNG");
  EXPECT_EQ(response.time(), 0.0);

  // A stream whose client does not read: the server blocks in Write without
  // the robot, so other calls go on.
  grpc::ClientContext context;
  testing::SetDeadline(context, 60);
  v1::RecordFramesRequest slow;
  slow.set_width(400);
  slow.set_height(300);
  slow.set_frame_rate(10);
  slow.set_seconds(100);
  auto reader = stub_->RecordFrames(&context, slow);
  v1::VideoFrame frame;
  ASSERT_TRUE(reader->Read(&frame));
  EXPECT_EQ(frame.index(), 0u);
  for (int i = 0; i < 5; ++i) EXPECT_OK(Call(*stub_, &v1::Host::Stub::ElapsedTime, Empty(), &time));
  EXPECT_OK(Call(*stub_, &v1::Host::Stub::ConnectRobot, v1::ConnectRobotRequest()));
  ASSERT_TRUE(reader->Read(&frame));
  EXPECT_EQ(frame.index(), 1u);
  EXPECT_NEAR(frame.time(), 0.1, 1e-9);
  context.TryCancel();
  while (reader->Read(&frame)) {
  }
  EXPECT_EQ(reader->Finish().error_code(), Code::CANCELLED);
}

TEST_F(ServiceTest, ParallelEvaluationsBothSucceed) {
  v1::EvaluateRequest request;
  request.set_world("quadruped");
  request.set_warmup(0.5);
  request.set_duration(1.0);
  request.set_seed(11);
  v1::EvaluateResponse a, b;
  grpc::Status sa, sb;
  std::thread first([&] { sa = Call(*stub_, &v1::Host::Stub::Evaluate, request, &a); });
  std::thread second([&] { sb = Call(*stub_, &v1::Host::Stub::Evaluate, request, &b); });
  first.join();
  second.join();
  EXPECT_OK(sa);
  EXPECT_OK(sb);
  EXPECT_EQ(a.velocity(), b.velocity());
}

// Issue 14: EvaluateRequest.frames films the evaluation; bad frame options
// are refused, naming the value, before any world is built.
TEST_F(ServiceTest, EvaluateReturnsTheFramesOfTheEvaluation) {
  using Code = grpc::StatusCode;
  v1::EvaluateRequest request;
  request.set_world("quadruped");
  request.set_warmup(0.5);
  request.set_duration(1.0);
  request.set_seed(5);
  v1::EvaluateResponse plain;
  EXPECT_OK(Call(*stub_, &v1::Host::Stub::Evaluate, request, &plain));
  EXPECT_EQ(plain.frames_size(), 0);

  auto filmed = [&](const std::function<void(v1::EvaluationFrames&)>& change,
                    v1::EvaluateResponse* response) {
    v1::EvaluateRequest r = request;
    v1::EvaluationFrames* frames = r.mutable_frames();
    frames->set_width(40);
    frames->set_height(30);
    frames->set_frame_rate(4);
    frames->set_hide_legend(true);
    change(*frames);
    return Call(*stub_, &v1::Host::Stub::Evaluate, r, response);
  };
  v1::EvaluateResponse response;
  EXPECT_EQ(filmed([](v1::EvaluationFrames& f) { f.set_width(0); }, &response).error_message(),
            "frame width 0 is outside 1..4096");
  EXPECT_EQ(filmed([](v1::EvaluationFrames& f) { f.set_height(100000); }, &response).error_code(),
            Code::OUT_OF_RANGE);
  EXPECT_EQ(filmed([](v1::EvaluationFrames& f) { f.set_frame_rate(0); }, &response).error_message(),
            "frame rate 0 per second is outside (0, 240]");
  const grpc::Status nan = filmed(
      [](v1::EvaluationFrames& f) { f.mutable_camera()->set_distance(std::nan("")); }, &response);
  EXPECT_EQ(nan.error_code(), Code::INVALID_ARGUMENT);
  EXPECT_EQ(nan.error_message(), "camera distance is not finite: nan");
  const grpc::Status kind = filmed(
      [](v1::EvaluationFrames& f) { f.mutable_camera()->set_kind(static_cast<v1::CameraKind>(9)); },
      &response);
  EXPECT_EQ(kind.error_code(), Code::INVALID_ARGUMENT);

  const grpc::Status status = filmed([](v1::EvaluationFrames&) {}, &response);
  if (status.error_code() == Code::UNAVAILABLE) GTEST_SKIP() << status.error_message();
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(response.velocity(), plain.velocity());
  ASSERT_EQ(response.frames_size(), 6) << "1.5 s at 4 frames per second";
  for (int i = 0; i < response.frames_size(); ++i) {
    const v1::VideoFrame& frame = response.frames(i);
    EXPECT_EQ(frame.index(), static_cast<uint32_t>(i));
    EXPECT_NEAR(frame.time(), 0.25 * i, 1e-9);
    const std::string& png = frame.png();
    const render::Image image = render::DecodePng(
        std::span(reinterpret_cast<const uint8_t*>(png.data()), png.size()));
    EXPECT_EQ(image.width, 40);
    EXPECT_EQ(image.height, 30);
  }
}

// Issue 13 §2: the evaluated robot's condition travels in the request and
// its values are checked with the canonical codes, naming the value.
TEST_F(ServiceTest, EvaluateTakesTheRobotsCondition) {
  v1::EvaluateRequest healthy;
  healthy.set_world("quadruped");
  healthy.set_warmup(1.0);
  healthy.set_duration(2.0);
  healthy.set_seed(3);
  v1::EvaluateResponse base;
  EXPECT_OK(Call(*stub_, &v1::Host::Stub::Evaluate, healthy, &base));
  ASSERT_GT(base.velocity(), 0.0);
  auto velocity = [&](const std::function<void(v1::EvaluateRequest&)>& change) {
    v1::EvaluateRequest request = healthy;
    change(request);
    v1::EvaluateResponse response;
    EXPECT_OK(Call(*stub_, &v1::Host::Stub::Evaluate, request, &response));
    return response.velocity();
  };
  EXPECT_NE(velocity([](v1::EvaluateRequest& r) {
              auto* d = r.add_motor_defects();
              d->set_module_id(2);
              d->set_defect(v1::MOTOR_LIMP);
            }),
            base.velocity());
  EXPECT_NE(velocity([](v1::EvaluateRequest& r) {
              auto* d = r.add_module_defects();
              d->set_module_id(3);
              d->set_defective(true);
            }),
            base.velocity());
  EXPECT_NE(velocity([](v1::EvaluateRequest& r) { r.mutable_ground()->set_friction(0.05); }),
            base.velocity());
  EXPECT_NE(velocity([](v1::EvaluateRequest& r) { r.set_upside_down(true); }), base.velocity());
  EXPECT_EQ(velocity([](v1::EvaluateRequest& r) { r.mutable_ground(); }), base.velocity())
      << "an empty ground message changes nothing";

  struct Case {
    std::function<void(v1::EvaluateRequest&)> change;
    grpc::StatusCode code;
    std::string mention;
  };
  const Case cases[] = {
      {[](v1::EvaluateRequest& r) { r.add_motor_defects()->set_module_id(77); },
       grpc::StatusCode::NOT_FOUND, "module 77"},
      {[](v1::EvaluateRequest& r) { r.add_motor_defects()->set_module_id(1000); },
       grpc::StatusCode::NOT_FOUND, "module 1000"},
      {[](v1::EvaluateRequest& r) {
         auto* d = r.add_motor_defects();
         d->set_module_id(2);
         d->set_defect(static_cast<v1::MotorDefect>(9));
       },
       grpc::StatusCode::INVALID_ARGUMENT, "motor defect 9"},
      {[](v1::EvaluateRequest& r) {
         auto* d = r.add_module_defects();
         d->set_module_id(88);
         d->set_defective(true);
       },
       grpc::StatusCode::NOT_FOUND, "module 88"},
      {[](v1::EvaluateRequest& r) { r.mutable_ground()->set_friction(NAN); },
       grpc::StatusCode::INVALID_ARGUMENT, "friction"},
      {[](v1::EvaluateRequest& r) { r.mutable_ground()->set_slope(1.6); },
       grpc::StatusCode::OUT_OF_RANGE, "slope"},
  };
  for (const Case& c : cases) {
    v1::EvaluateRequest request = healthy;
    c.change(request);
    const grpc::Status status = Call(*stub_, &v1::Host::Stub::Evaluate, request);
    EXPECT_EQ(status.error_code(), c.code) << status.error_message();
    EXPECT_NE(status.error_message().find(c.mention), std::string::npos) << status.error_message();
  }
}

// Issue 12 §0: after a transformation, GetMorphology and an Evaluate on the
// open world use the robot as it is now.
TEST_F(ServiceTest, GetMorphologyAndEvaluateUseTheTransformedRobot) {
  v1::Host::Stub& stub = *stub_;
  v1::EvaluateRequest evaluate;  // on the open world
  evaluate.set_warmup(1.0);
  evaluate.set_duration(2.0);
  evaluate.set_seed(4);
  v1::GetMorphologyResponse before;
  EXPECT_OK(Call(stub, &v1::Host::Stub::GetMorphology, Empty(), &before));
  v1::EvaluateResponse old_body;
  EXPECT_OK(Call(stub, &v1::Host::Stub::Evaluate, evaluate, &old_body));

  v1::RunTransformationScriptRequest script;
  script.set_script_xml(testing::ReadSourceFile("configs/scripts/quadruped-transform.xml"));
  ASSERT_FALSE(script.script_xml().empty());
  EXPECT_OK(Call(stub, &v1::Host::Stub::RunTransformationScript, script));
  v1::GetMorphologyResponse after;
  EXPECT_OK(Call(stub, &v1::Host::Stub::GetMorphology, Empty(), &after));
  EXPECT_NE(after.morphology_xml(), before.morphology_xml());
  const std::string& xml = after.morphology_xml();
  EXPECT_NE(xml.find(R"(idfrom="7" connfrom="front" idto="5" connto="rear")"), std::string::npos)
      << xml;
  EXPECT_NE(xml.find(R"(idfrom="8" connfrom="front" idto="6" connto="rear")"), std::string::npos)
      << xml;
  EXPECT_EQ(xml.find(R"(idfrom="7" connfrom="front" idto="2")"), std::string::npos) << xml;
  EXPECT_EQ(xml.find(R"(idfrom="8" connfrom="front" idto="3")"), std::string::npos) << xml;
  EXPECT_EQ(after.central_module(), 4u);

  v1::EvaluateResponse new_body;
  EXPECT_OK(Call(stub, &v1::Host::Stub::Evaluate, evaluate, &new_body));
  EXPECT_FALSE(old_body.diverged());
  EXPECT_FALSE(new_body.diverged());
  EXPECT_NE(new_body.velocity(), old_body.velocity()) << "the transformed body walks differently";
  // Bit for bit what the transformed morphology gives when named explicitly,
  // and the initial one still gives the old velocity.
  v1::EvaluateRequest given = evaluate;
  given.set_morphology_xml(after.morphology_xml());
  v1::EvaluateResponse given_new;
  EXPECT_OK(Call(stub, &v1::Host::Stub::Evaluate, given, &given_new));
  EXPECT_EQ(given_new.velocity(), new_body.velocity());
  EXPECT_EQ(given_new.distance(), new_body.distance());
  given.set_morphology_xml(before.morphology_xml());
  v1::EvaluateResponse given_old;
  EXPECT_OK(Call(stub, &v1::Host::Stub::Evaluate, given, &given_old));
  EXPECT_EQ(given_old.velocity(), old_body.velocity());

  // Reset brings the initial body back.
  EXPECT_OK(Call(stub, &v1::Host::Stub::ResetSimulation, Empty()));
  v1::GetMorphologyResponse reset;
  EXPECT_OK(Call(stub, &v1::Host::Stub::GetMorphology, Empty(), &reset));
  EXPECT_EQ(reset.morphology_xml(), before.morphology_xml());
}

// Issue 13 (7.5.2): a world's static boxes travel with its morphology: an
// opened world keeps them (GetMorphology), Evaluate on the open world and on
// a given morphology simulates them, and bad boxes are refused naming them.
TEST_F(ServiceTest, StaticBoxesTravelWithTheWorldIntoEvaluate) {
  v1::Host::Stub& stub = *stub_;
  v1::GetMorphologyResponse plain;
  EXPECT_OK(Call(stub, &v1::Host::Stub::GetMorphology, Empty(), &plain));
  std::string xml = plain.morphology_xml();
  // A platform 3 m wide and 30 cm high: the robot stays on it in 3 s.
  xml.insert(xml.rfind("</morphology>"),
             "  <box name=\"platform\" size=\"3 3 0.3\" position=\"0 0 0.15\"/>\n");
  v1::OpenSimulationRequest open;
  open.set_morphology_xml(xml);
  open.set_seed(3);
  EXPECT_OK(Call(stub, &v1::Host::Stub::OpenSimulation, open));
  v1::GetMorphologyResponse morphology;
  EXPECT_OK(Call(stub, &v1::Host::Stub::GetMorphology, Empty(), &morphology));
  EXPECT_NE(morphology.morphology_xml().find("<box name=\"platform\" size=\"3 3 0.3\""),
            std::string::npos)
      << morphology.morphology_xml();

  v1::EvaluateRequest evaluate;  // on the open world
  evaluate.set_config_xml(testing::ReadSourceFile("configs/robots/quadruped.xml"));
  evaluate.set_warmup(1.0);
  evaluate.set_duration(2.0);
  evaluate.set_seed(4);
  v1::EvaluateResponse on_platform;
  EXPECT_OK(Call(stub, &v1::Host::Stub::Evaluate, evaluate, &on_platform));
  EXPECT_FALSE(on_platform.diverged()) << on_platform.divergence();
  EXPECT_GT(on_platform.final_pose().position().z(), 0.3);
  v1::EvaluateRequest given = evaluate;
  given.set_morphology_xml(xml);
  v1::EvaluateResponse given_platform;
  EXPECT_OK(Call(stub, &v1::Host::Stub::Evaluate, given, &given_platform));
  EXPECT_EQ(given_platform.velocity(), on_platform.velocity());
  EXPECT_EQ(given_platform.final_pose().position().z(), on_platform.final_pose().position().z());
  given.set_morphology_xml(plain.morphology_xml());
  v1::EvaluateResponse on_floor;
  EXPECT_OK(Call(stub, &v1::Host::Stub::Evaluate, given, &on_floor));
  EXPECT_LT(on_floor.final_pose().position().z(), 0.2);
  EXPECT_NEAR(on_floor.final_pose().position().z() + 0.3, on_platform.final_pose().position().z(),
              0.02);

  // Bad boxes: the value and the box named, never a crash.
  struct Case {
    std::string box;
    std::string mention;
  };
  const Case cases[] = {
      {"<box name=\"flat\" size=\"1 1 0\"/>", "box \"flat\": size=\"1 1 0\""},
      {"<box name=\"nan\" size=\"1 1 1\" position=\"nan 0 0\"/>", "position=\"nan 0 0\""},
      {"<box name=\"wall\" size=\"0.05 0.6 0.2\" position=\"0.09 0 0.1\"/>",
       "box \"wall\""},
  };
  for (const Case& c : cases) {
    std::string bad = plain.morphology_xml();
    bad.insert(bad.rfind("</morphology>"), "  " + c.box + "\n");
    v1::EvaluateRequest request = evaluate;
    request.set_morphology_xml(bad);
    const grpc::Status evaluated = Call(stub, &v1::Host::Stub::Evaluate, request);
    EXPECT_EQ(evaluated.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << c.box;
    EXPECT_NE(evaluated.error_message().find(c.mention), std::string::npos)
        << evaluated.error_message();
    v1::OpenSimulationRequest reopen;
    reopen.set_morphology_xml(bad);
    const grpc::Status opened = Call(stub, &v1::Host::Stub::OpenSimulation, reopen);
    EXPECT_EQ(opened.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << c.box;
    EXPECT_NE(opened.error_message().find(c.mention), std::string::npos) << opened.error_message();
  }
}

// An open world whose body has no valid morphology is an error for
// GetMorphology and for Evaluate on the open world, never another body.
TEST_F(ServiceTest, AnOpenWorldWithoutAValidMorphologyIsAFailedPrecondition) {
  auto backend = std::make_unique<SimBackend>(testing::SnakeWithSpares(), bridge::RobotOptions{});
  physics::World& world = backend->robot().world();
  driver_->AttachBackend(std::move(backend), "snake+spares");
  testing::MakeUnplaceable(world);
  const grpc::Status morphology = Call(*stub_, &v1::Host::Stub::GetMorphology, Empty());
  EXPECT_EQ(morphology.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_NE(morphology.error_message().find("starting angles"), std::string::npos)
      << morphology.error_message();
  v1::EvaluateRequest evaluate;
  evaluate.set_warmup(0.1);
  evaluate.set_duration(0.1);
  const grpc::Status evaluated = Call(*stub_, &v1::Host::Stub::Evaluate, evaluate);
  EXPECT_EQ(evaluated.error_code(), grpc::StatusCode::FAILED_PRECONDITION)
      << evaluated.error_message();
  // Without an open world Evaluate still uses the default one.
  EXPECT_OK(Call(*stub_, &v1::Host::Stub::CloseSimulation, Empty()));
  EXPECT_OK(Call(*stub_, &v1::Host::Stub::Evaluate, evaluate));
}

TEST_F(ServiceTest, AFloodGetsResourceExhausted) {
  Restart(/*max_concurrent_calls=*/1);
  grpc::ClientContext sleeping;
  testing::SetDeadline(sleeping, 60);
  v1::SleepRequest sleep;
  sleep.set_seconds(600.0);
  sleep.set_real_time(true);
  v1::SleepResponse slept;
  grpc::Status sleep_status;
  std::thread sleeper([&] { sleep_status = stub_->Sleep(&sleeping, sleep, &slept); });
  while (server_->service().in_flight() == 0) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  const grpc::Status refused = Call(*stub_, &v1::Host::Stub::GetInfo, Empty());
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << refused.error_message();
  sleeping.TryCancel();
  sleeper.join();
  EXPECT_EQ(sleep_status.error_code(), grpc::StatusCode::CANCELLED);
  while (server_->service().in_flight() != 0) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  EXPECT_OK(Call(*stub_, &v1::Host::Stub::GetInfo, Empty()));
}

TEST_F(ServiceTest, HealthAndReflectionAreServed) {
  int serving = 0;
  EXPECT_OK(testing::HealthCheck(channel_, "", &serving));
  EXPECT_EQ(serving, 1) << "SERVING";
  std::vector<std::string> services;
  EXPECT_OK(testing::ListServices(channel_, &services));
  EXPECT_NE(std::find(services.begin(), services.end(), "yamor.v1.Host"), services.end());
}

// Bad requests: each must fail with its code, and the server must go on.
TEST_F(ServiceTest, BadRequestsGetTheirCodesAndTheServerSurvives) {
  v1::Host::Stub& stub = *stub_;
  using Code = grpc::StatusCode;
  struct Case {
    std::string name;
    std::function<grpc::Status()> call;
    Code code;
  };
  auto module = [](uint32_t id) {
    v1::ModuleRequest r;
    r.set_module_id(id);
    return r;
  };
  auto set_module = [](uint32_t id, double value) {
    v1::SetModuleValueRequest r;
    r.set_module_id(id);
    r.set_value(value);
    return r;
  };
  auto coupling = [](uint32_t from, uint32_t to) {
    v1::CouplingRequest r;
    r.set_from_id(from);
    r.set_to_id(to);
    return r;
  };
  auto set_coupling = [](uint32_t from, uint32_t to, double value) {
    v1::SetCouplingValueRequest r;
    r.set_from_id(from);
    r.set_to_id(to);
    r.set_value(value);
    return r;
  };
  auto add_coupling = [](uint32_t from, uint32_t to, double phase, double weight) {
    v1::AddCouplingRequest r;
    r.set_from_id(from);
    r.set_to_id(to);
    r.set_phase(phase);
    r.set_weight(weight);
    return r;
  };
  auto control_all_on = [] {
    v1::ControlMessageRequest r;
    r.set_uart(v1::SWITCH_ON);
    r.set_cpg(v1::SWITCH_ON);
    r.set_motors(v1::SWITCH_ON);
    r.set_all(true);
    return r;
  };
  auto open = [](std::string world, std::string morphology, double time_step) {
    v1::OpenSimulationRequest r;
    r.set_world(world);
    r.set_morphology_xml(morphology);
    r.set_time_step(time_step);
    return r;
  };
  auto sleep = [](double seconds) {
    v1::SleepRequest r;
    r.set_seconds(seconds);
    return r;
  };
  auto connect = [](double timeout) {
    v1::ConnectRobotRequest r;
    r.set_link_timeout(timeout);
    return r;
  };
  auto ground = [](std::optional<double> friction, std::optional<double> slope) {
    v1::SetGroundRequest r;
    if (friction) r.set_friction(*friction);
    if (slope) r.set_slope(*slope);
    return r;
  };
  auto evaluate = [](std::string parameter, double value, double warmup, double duration) {
    v1::EvaluateRequest r;
    if (!parameter.empty()) {
      auto* p = r.add_parameters();
      p->set_name(parameter);
      p->set_value(value);
    }
    r.set_warmup(warmup);
    r.set_duration(duration);
    return r;
  };
  auto script = [](std::string xml) {
    v1::RunTransformationScriptRequest r;
    r.set_script_xml(xml);
    return r;
  };
  auto load = [](std::string xml) {
    v1::LoadConfigRequest r;
    r.set_config_xml(xml);
    r.set_source_name("bad.xml");
    return r;
  };
  const double nan = std::nan("");
  const double inf = INFINITY;
  auto C = [&](auto method, auto request) {
    return [&stub, method, request]() { return Call(stub, method, request); };
  };
  using S = v1::Host::Stub;
  std::vector<Case> cases = {
      // Robot not connected yet.
      {"Flush before connect", C(&S::Flush, Empty()), Code::FAILED_PRECONDITION},
      {"Refresh before connect", C(&S::Refresh, Empty()), Code::FAILED_PRECONDITION},
      {"control before connect", C(&S::SendControlMessage, control_all_on()), Code::FAILED_PRECONDITION},
      {"servo angles before connect", C(&S::GetServoAngles, v1::GetServoAnglesRequest()),
       Code::FAILED_PRECONDITION},
      // Unknown modules and couplings, bad values.
      {"get amplitude of module 42", C(&S::GetModuleAmplitude, module(42)), Code::NOT_FOUND},
      {"get speed of module 1000", C(&S::GetModuleSpeed, module(1000)), Code::NOT_FOUND},
      {"set speed of module 42", C(&S::SetModuleSpeed, set_module(42, 0.1)), Code::NOT_FOUND},
      {"amplitude NaN", C(&S::SetModuleAmplitude, set_module(1, nan)), Code::INVALID_ARGUMENT},
      {"offset inf", C(&S::SetModuleOffset, set_module(1, inf)), Code::INVALID_ARGUMENT},
      {"amplitude negative", C(&S::SetModuleAmplitude, set_module(1, -0.5)), Code::OUT_OF_RANGE},
      {"speed 50 Hz", C(&S::SetModuleSpeed, set_module(1, 50)), Code::OUT_OF_RANGE},
      {"min angle above max", C(&S::SetModuleMinAngle, set_module(0, 1.0)), Code::OUT_OF_RANGE},
      {"max angle below min", C(&S::SetModuleMaxAngle, set_module(0, -1.0)), Code::OUT_OF_RANGE},
      {"max angle NaN", C(&S::SetModuleMaxAngle, set_module(0, nan)), Code::INVALID_ARGUMENT},
      {"max angle 10 rad", C(&S::SetModuleMaxAngle, set_module(0, 10)), Code::OUT_OF_RANGE},
      {"phase of absent coupling", C(&S::GetCouplingPhase, coupling(0, 8)), Code::NOT_FOUND},
      {"weight of coupling to 300", C(&S::GetCouplingWeight, coupling(0, 300)), Code::NOT_FOUND},
      {"set phase of absent coupling", C(&S::SetCouplingPhase, set_coupling(0, 8, 1)), Code::NOT_FOUND},
      {"weight NaN", C(&S::SetCouplingWeight, set_coupling(0, 1, nan)), Code::INVALID_ARGUMENT},
      {"weight 1e6", C(&S::SetCouplingWeight, set_coupling(0, 1, 1e6)), Code::OUT_OF_RANGE},
      {"self coupling", C(&S::AddCoupling, add_coupling(3, 3, 0, 1)), Code::INVALID_ARGUMENT},
      {"coupling to unknown module", C(&S::AddCoupling, add_coupling(3, 99, 0, 1)), Code::NOT_FOUND},
      {"coupling phase NaN", C(&S::AddCoupling, add_coupling(3, 4, nan, 1)), Code::INVALID_ARGUMENT},
      // Configurations and worlds.
      {"malformed config XML", C(&S::LoadConfig, load("<yamorconfig>\n<modulelist>")),
       Code::INVALID_ARGUMENT},
      {"empty config", C(&S::LoadConfig, load("")), Code::INVALID_ARGUMENT},
      {"config module missing from the world",
       C(&S::LoadConfig, load("<yamorconfig master=\"40\"><modulelist><module realid=\"40\" "
                              "amplitude=\"0\" offset=\"0\" speed=\"0\" minangle=\"-1\" "
                              "maxangle=\"1\"/></modulelist></yamorconfig>")),
       Code::INVALID_ARGUMENT},
      {"unknown world", C(&S::OpenSimulation, open("unicorn", "", 0)), Code::NOT_FOUND},
      {"world file over the network",
       C(&S::OpenSimulation, open(testing::kSourceDir + "/configs/worlds/snake.xml", "", 0)),
       Code::NOT_FOUND},
      {"malformed morphology", C(&S::OpenSimulation, open("", "<morphology", 0)),
       Code::INVALID_ARGUMENT},
      {"negative time step", C(&S::OpenSimulation, open("quadruped", "", -1)), Code::OUT_OF_RANGE},
      {"NaN time step", C(&S::OpenSimulation, open("quadruped", "", nan)), Code::INVALID_ARGUMENT},
      // Time.
      {"sleep negative", C(&S::Sleep, sleep(-1)), Code::OUT_OF_RANGE},
      {"sleep NaN", C(&S::Sleep, sleep(nan)), Code::INVALID_ARGUMENT},
      {"sleep a year", C(&S::Sleep, sleep(3.2e7)), Code::OUT_OF_RANGE},
      {"link timeout NaN", C(&S::ConnectRobot, connect(nan)), Code::INVALID_ARGUMENT},
      {"link timeout negative", C(&S::ConnectRobot, connect(-1)), Code::OUT_OF_RANGE},
      // Control, faults, ground.
      {"control switch 7",
       [&] {
         v1::ControlMessageRequest r = control_all_on();
         r.set_uart(static_cast<v1::Switch>(7));
         return Call(stub, &S::SendControlMessage, r);
       },
       Code::INVALID_ARGUMENT},
      {"motor defect of module 42",
       [&] {
         v1::SetMotorDefectRequest r;
         r.set_module_id(42);
         r.set_defect(v1::MOTOR_LIMP);
         return Call(stub, &S::SetMotorDefect, r);
       },
       Code::NOT_FOUND},
      {"motor defect kind 9",
       [&] {
         v1::SetMotorDefectRequest r;
         r.set_module_id(1);
         r.set_defect(static_cast<v1::MotorDefect>(9));
         return Call(stub, &S::SetMotorDefect, r);
       },
       Code::INVALID_ARGUMENT},
      {"module defect of module 300",
       [&] {
         v1::SetModuleDefectRequest r;
         r.set_module_id(300);
         r.set_defective(true);
         return Call(stub, &S::SetModuleDefect, r);
       },
       Code::NOT_FOUND},
      {"negative friction", C(&S::SetGround, ground(-1.0, std::nullopt)), Code::OUT_OF_RANGE},
      {"NaN friction", C(&S::SetGround, ground(nan, std::nullopt)), Code::INVALID_ARGUMENT},
      {"slope of 2 rad", C(&S::SetGround, ground(std::nullopt, 2.0)), Code::OUT_OF_RANGE},
      {"empty ground change", C(&S::SetGround, ground(std::nullopt, std::nullopt)),
       Code::INVALID_ARGUMENT},
      {"accelerometer 99 samples",
       [&] {
         v1::GetAccelerometerRequest r;
         r.set_module_id(4);
         r.set_samples(99);
         return Call(stub, &S::GetAccelerometer, r);
       },
       Code::OUT_OF_RANGE},
      // Physical reconfiguration.
      {"connection angle 7 degrees",
       [&] {
         v1::ConnectModulesRequest r;
         r.set_from_id(5);
         r.set_to_id(4);
         r.set_angle_degrees(7);
         return Call(stub, &S::ConnectModules, r);
       },
       Code::INVALID_ARGUMENT},
      {"connector 9",
       [&] {
         v1::ConnectModulesRequest r;
         r.set_from_id(5);
         r.set_to_id(4);
         r.set_from_connector(static_cast<v1::ConnectorName>(9));
         return Call(stub, &S::ConnectModules, r);
       },
       Code::INVALID_ARGUMENT},
      {"script with unknown command", C(&S::RunTransformationScript, script("<script><fly/></script>")),
       Code::INVALID_ARGUMENT},
      {"script that is not XML", C(&S::RunTransformationScript, script("not xml")),
       Code::INVALID_ARGUMENT},
      {"script connecting a module that is in the robot",
       C(&S::RunTransformationScript,
         script("<script><connect idfrom=\"5\" connfrom=\"front\" idto=\"4\" connto=\"top\"/></script>")),
       testing::BridgeReconfigures() ? Code::FAILED_PRECONDITION : Code::UNIMPLEMENTED},
      // Evaluate.
      {"evaluate unknown parameter", C(&S::Evaluate, evaluate("torque.3", 1, 0.1, 0.1)),
       Code::INVALID_ARGUMENT},
      {"evaluate unknown module", C(&S::Evaluate, evaluate("amplitude.42", 0.5, 0.1, 0.1)),
       Code::NOT_FOUND},
      {"evaluate absent coupling", C(&S::Evaluate, evaluate("phase.0.8", 0.5, 0.1, 0.1)),
       Code::NOT_FOUND},
      {"evaluate negative amplitude", C(&S::Evaluate, evaluate("amplitude.3", -1, 0.1, 0.1)),
       Code::OUT_OF_RANGE},
      {"evaluate negative duration", C(&S::Evaluate, evaluate("", 0, 0.1, -1)), Code::OUT_OF_RANGE},
      {"evaluate NaN warm-up", C(&S::Evaluate, evaluate("", 0, nan, 1)), Code::INVALID_ARGUMENT},
      {"evaluate unknown world",
       [&] {
         v1::EvaluateRequest r;
         r.set_world("unicorn");
         return Call(stub, &S::Evaluate, r);
       },
       Code::NOT_FOUND},
      {"evaluate malformed config",
       [&] {
         v1::EvaluateRequest r;
         r.set_config_xml("<x");
         return Call(stub, &S::Evaluate, r);
       },
       Code::INVALID_ARGUMENT},
      {"free-run factor -1",
       [&] {
         v1::SetFreeRunRequest r;
         r.set_real_time_factor(-1);
         return Call(stub, &S::SetFreeRun, r);
       },
       Code::OUT_OF_RANGE},
      {"free-run factor NaN",
       [&] {
         v1::SetFreeRunRequest r;
         r.set_real_time_factor(nan);
         return Call(stub, &S::SetFreeRun, r);
       },
       Code::INVALID_ARGUMENT},
      {"watch period -1",
       [&] {
         grpc::ClientContext context;
         testing::SetDeadline(context);
         v1::WatchStateRequest r;
         r.set_period(-1);
         auto reader = stub.WatchState(&context, r);
         v1::StateUpdate u;
         while (reader->Read(&u)) {
         }
         return reader->Finish();
       },
       Code::OUT_OF_RANGE},
      // Connected: what needs a link or a switch.
      {"connect (setup)", C(&S::ConnectRobot, connect(0)), Code::OK},
      {"accelerometer with UART off",
       [&] {
         v1::GetAccelerometerRequest r;
         r.set_module_id(4);
         return Call(stub, &S::GetAccelerometer, r);
       },
       Code::FAILED_PRECONDITION},
      {"servo angle of module 77",
       [&] {
         v1::GetServoAnglesRequest r;
         r.add_module_ids(77);
         return Call(stub, &S::GetServoAngles, r);
       },
       Code::NOT_FOUND},
      {"control without targets",
       [&] {
         v1::ControlMessageRequest r = control_all_on();
         r.set_all(false);
         return Call(stub, &S::SendControlMessage, r);
       },
       Code::INVALID_ARGUMENT},
      {"control of module 77",
       [&] {
         v1::ControlMessageRequest r = control_all_on();
         r.set_all(false);
         r.add_module_ids(77);
         return Call(stub, &S::SendControlMessage, r);
       },
       Code::NOT_FOUND},
      // No simulation open.
      {"close (setup)", C(&S::CloseSimulation, Empty()), Code::OK},
      {"sleep without simulation", C(&S::Sleep, sleep(1)), Code::FAILED_PRECONDITION},
      {"position without simulation", C(&S::RobotPosition, Empty()), Code::FAILED_PRECONDITION},
      {"time without simulation", C(&S::ElapsedTime, Empty()), Code::FAILED_PRECONDITION},
      {"connect without simulation", C(&S::ConnectRobot, connect(0)), Code::FAILED_PRECONDITION},
      {"morphology without simulation", C(&S::GetMorphology, Empty()), Code::FAILED_PRECONDITION},
      {"reset without simulation", C(&S::ResetSimulation, Empty()), Code::FAILED_PRECONDITION},
      {"upside down without simulation", C(&S::TurnUpsideDown, Empty()),
       Code::FAILED_PRECONDITION},
      {"ground without simulation", C(&S::SetGround, ground(1.0, std::nullopt)),
       Code::FAILED_PRECONDITION},
      {"free-run without simulation",
       [&] {
         v1::SetFreeRunRequest r;
         r.set_real_time_factor(1);
         return Call(stub, &S::SetFreeRun, r);
       },
       Code::FAILED_PRECONDITION},
  };
  int bad = 0;
  for (const Case& c : cases) {
    const grpc::Status status = c.call();
    EXPECT_EQ(status.error_code(), c.code) << c.name << ": " << status.error_message();
    if (c.code != Code::OK) {
      ++bad;
      EXPECT_FALSE(status.error_message().empty()) << c.name;
    }
    v1::GetInfoResponse info;
    ASSERT_TRUE(Call(stub, &S::GetInfo, Empty(), &info).ok()) << "server gone after " << c.name;
  }
  EXPECT_GE(bad, 40);
}

TEST_F(ServiceTest, MalformedXmlErrorsNameTheLine) {
  v1::LoadConfigRequest load;
  load.set_config_xml("<?xml version=\"1.0\"?>\n<yamorconfig>\n<modulelist>\n<module realid=\"1\"");
  load.set_source_name("robot.xml");
  const grpc::Status status = Call(*stub_, &v1::Host::Stub::LoadConfig, load);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("robot.xml:"), std::string::npos) << status.error_message();
}

}  // namespace
}  // namespace yamor::host
