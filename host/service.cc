#include "host/service.h"

#include <cmath>
#include <thread>

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/health_check_service_interface.h>
#include <grpcpp/resource_quota.h>

#include "common/log.h"
#include "cpg/config_xml.h"
#include "host/builtin_robots.h"
#include "host/frames.h"
#include "host/worlds.h"

#ifndef YAMOR_VERSION
#define YAMOR_VERSION "0.0.0"
#endif

namespace yamor::host {
namespace {

using google::protobuf::Empty;
namespace v1 = yamor::v1;

// Module ids on the wire are one byte; larger request values name no module.
int ModuleId(uint32_t id) {
  if (id > static_cast<uint32_t>(cpg::kMaxModuleId)) {
    throw Error(StatusCode::kNotFound,
                "module " + std::to_string(id) + " does not exist (ids are 0..254)");
  }
  return static_cast<int>(id);
}

snp::Tristate ToTristate(v1::Switch value, std::string_view what) {
  switch (value) {
    case v1::SWITCH_UNCHANGED: return snp::Tristate::kUnchanged;
    case v1::SWITCH_ON: return snp::Tristate::kOn;
    case v1::SWITCH_OFF: return snp::Tristate::kOff;
    default: break;
  }
  throw Error(StatusCode::kInvalidArgument, std::string(what) + " switch " +
                                                std::to_string(static_cast<int>(value)) +
                                                " is not UNCHANGED, ON or OFF");
}

snp::Connector ToConnector(v1::ConnectorName value, std::string_view what) {
  const int v = static_cast<int>(value);
  if (v < 0 || v > static_cast<int>(snp::Connector::kBottom)) {
    throw Error(StatusCode::kInvalidArgument,
                std::string(what) + " " + std::to_string(v) + " is not a connector (0..5)");
  }
  return static_cast<snp::Connector>(v);
}

MotorDefect ToMotorDefect(v1::MotorDefect value) {
  switch (value) {
    case v1::MOTOR_OK: return MotorDefect::kNone;
    case v1::MOTOR_LIMP: return MotorDefect::kLimp;
    case v1::MOTOR_STUCK: return MotorDefect::kStuck;
    default: break;
  }
  throw Error(StatusCode::kInvalidArgument, "motor defect " + std::to_string(static_cast<int>(value)) +
                                                " is not MOTOR_OK, MOTOR_LIMP or MOTOR_STUCK");
}

GroundChange ToGroundChange(const v1::SetGroundRequest& request) {
  GroundChange change;
  if (request.has_friction()) change.friction = request.friction();
  if (request.has_slope()) change.slope = request.slope();
  if (request.has_slope_direction()) change.slope_direction = request.slope_direction();
  return change;
}

void SetPose(const RobotPose& pose, v1::Pose* out) {
  out->mutable_position()->set_x(pose.position[0]);
  out->mutable_position()->set_y(pose.position[1]);
  out->mutable_position()->set_z(pose.position[2]);
  out->mutable_orientation()->set_w(pose.orientation[0]);
  out->mutable_orientation()->set_x(pose.orientation[1]);
  out->mutable_orientation()->set_y(pose.orientation[2]);
  out->mutable_orientation()->set_z(pose.orientation[3]);
}

Eigen::Vector3d ToVector(const v1::Vector3& v) { return Eigen::Vector3d(v.x(), v.y(), v.z()); }

render::Camera ToCamera(const v1::Camera& in) {
  render::Camera camera;
  switch (in.kind()) {
    case v1::CAMERA_FOLLOW: camera.kind = render::CameraKind::kFollow; break;
    case v1::CAMERA_FIXED: camera.kind = render::CameraKind::kFixed; break;
    case v1::CAMERA_TOP: camera.kind = render::CameraKind::kTop; break;
    default:
      throw Error(StatusCode::kInvalidArgument,
                  "camera kind " + std::to_string(static_cast<int>(in.kind())) +
                      " is not FOLLOW, FIXED or TOP");
  }
  if (in.has_distance()) camera.distance = in.distance();
  if (in.has_elevation()) camera.elevation = in.elevation();
  if (in.has_azimuth()) camera.azimuth = in.azimuth();
  if (in.has_eye()) camera.eye = ToVector(in.eye());
  if (in.has_target()) camera.target = ToVector(in.target());
  if (in.has_height()) camera.height = in.height();
  camera.fov = in.fov();
  return camera;
}

// A pixel count from the request (values beyond int stay out of range).
int Pixels(uint32_t value) { return static_cast<int>(std::min<uint32_t>(value, 1u << 30)); }

FrameSpec ToFrameSpec(const v1::Camera& camera, uint32_t width, uint32_t height, bool hide_labels,
                      bool hide_legend) {
  FrameSpec spec{.camera = ToCamera(camera), .width = Pixels(width), .height = Pixels(height)};
  spec.options.labels = !hide_labels;
  spec.options.legend = !hide_legend;
  return spec;
}

// A guard that holds one of the service's in-flight slots.
class InFlightSlot {
 public:
  InFlightSlot(std::atomic<unsigned>& counter, unsigned limit) : counter_(counter) {
    acquired_ = counter_.fetch_add(1) < limit;
  }
  ~InFlightSlot() { counter_.fetch_sub(1); }
  InFlightSlot(const InFlightSlot&) = delete;
  InFlightSlot& operator=(const InFlightSlot&) = delete;
  bool acquired() const { return acquired_; }

 private:
  std::atomic<unsigned>& counter_;
  bool acquired_ = false;
};

}  // namespace

grpc::Status ToGrpcStatus(std::exception_ptr error) {
  try {
    std::rethrow_exception(error);
  } catch (const Error& e) {
    if (e.code() == StatusCode::kOk) return grpc::Status(grpc::StatusCode::INTERNAL, e.what());
    return grpc::Status(static_cast<grpc::StatusCode>(e.code()), e.what());
  } catch (const std::exception& e) {
    return grpc::Status(grpc::StatusCode::INTERNAL, std::string("internal error: ") + e.what());
  } catch (...) {
    return grpc::Status(grpc::StatusCode::INTERNAL, "internal error: unknown exception");
  }
}

HostServiceImpl::HostServiceImpl(RobotDriver& driver, WorkerPool& pool, ServiceOptions options)
    : driver_(driver), pool_(pool), options_(std::move(options)) {}

template <typename Body>
grpc::Status HostServiceImpl::Serve(grpc::ServerContext* context, std::string_view method,
                                    Body&& body) {
  InFlightSlot slot(in_flight_, options_.max_concurrent_calls);
  if (!slot.acquired()) {
    Log().warn("{}: refused, {} calls in flight", method, options_.max_concurrent_calls);
    return grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED,
                        "too many concurrent calls (limit " +
                            std::to_string(options_.max_concurrent_calls) + "); retry later");
  }
  if (stopping_) return grpc::Status(grpc::StatusCode::UNAVAILABLE, "yamord is shutting down");
  try {
    body();
    return grpc::Status::OK;
  } catch (...) {
    grpc::Status status = ToGrpcStatus(std::current_exception());
    // Long calls cut short by the daemon stopping are retryable elsewhere.
    if (status.error_code() == grpc::StatusCode::CANCELLED && (stopping_ || driver_.shutting_down()) &&
        !context->IsCancelled()) {
      status = grpc::Status(grpc::StatusCode::UNAVAILABLE,
                            "yamord is shutting down: " + status.error_message());
    }
    Log().debug("{}: {} {}", method, StatusCodeName(static_cast<StatusCode>(status.error_code())),
                status.error_message());
    return status;
  }
}

ResolvedWorld HostServiceImpl::Resolve(const std::string& world,
                                       const std::string& morphology_xml,
                                       const std::string& config_xml) const {
  if (world.empty() && morphology_xml.empty() && options_.default_morphology) {
    ResolvedWorld resolved{.morphology = *options_.default_morphology,
                           .name = options_.default_world};
    if (!config_xml.empty()) resolved.config = cpg::ParseConfigXml(config_xml, "<request config>");
    return resolved;
  }
  return ResolveWorld(WorldRequest{.world = world,
                                   .morphology_xml = morphology_xml,
                                   .config_xml = config_xml,
                                   .config_source = "<request config>"},
                      options_.default_world, /*allow_files=*/false);
}

CancelCheck HostServiceImpl::CancelFor(grpc::ServerContext* context) const {
  return [this, context] { return context->IsCancelled() || stopping_.load(); };
}

// ---- IYaMoRHost3 ----------------------------------------------------------------

grpc::Status HostServiceImpl::ElapsedTime(grpc::ServerContext* context, const Empty*,
                                          v1::ElapsedTimeResponse* response) {
  return Serve(context, "ElapsedTime", [&] { response->set_seconds(driver_.ElapsedTime()); });
}

namespace {

void SetPositionResponse(const RobotPose& pose, v1::RobotPositionResponse* response) {
  v1::Pose p;
  SetPose(pose, &p);
  *response->mutable_position() = p.position();
  *response->mutable_orientation() = p.orientation();
  response->set_time(pose.time);
  response->set_source(pose.source);
}

}  // namespace

grpc::Status HostServiceImpl::RobotPosition(grpc::ServerContext* context, const Empty*,
                                            v1::RobotPositionResponse* response) {
  return Serve(context, "RobotPosition",
               [&] { SetPositionResponse(driver_.RobotPosition(), response); });
}

grpc::Status HostServiceImpl::SimulatedPosition(grpc::ServerContext* context, const Empty*,
                                                v1::RobotPositionResponse* response) {
  return Serve(context, "SimulatedPosition",
               [&] { SetPositionResponse(driver_.SimulatedPosition(), response); });
}

grpc::Status HostServiceImpl::SimulationModeEnabled(grpc::ServerContext* context, const Empty*,
                                                    v1::SimulationModeEnabledResponse* response) {
  return Serve(context, "SimulationModeEnabled",
               [&] { response->set_enabled(driver_.SimulationModeEnabled()); });
}

grpc::Status HostServiceImpl::AddCoupling(grpc::ServerContext* context,
                                          const v1::AddCouplingRequest* request, Empty*) {
  return Serve(context, "AddCoupling", [&] {
    driver_.AddCoupling(ModuleId(request->from_id()), ModuleId(request->to_id()),
                        request->phase(), request->weight());
  });
}

grpc::Status HostServiceImpl::CloseSimulation(grpc::ServerContext* context, const Empty*, Empty*) {
  return Serve(context, "CloseSimulation", [&] { driver_.CloseSimulation(); });
}

grpc::Status HostServiceImpl::ConnectRobot(grpc::ServerContext* context,
                                           const v1::ConnectRobotRequest* request,
                                           v1::ConnectRobotResponse* response) {
  return Serve(context, "ConnectRobot", [&] {
    const ConnectResult r =
        driver_.ConnectRobot(request->link_timeout(), request->links_only(), CancelFor(context));
    response->set_links(static_cast<uint32_t>(r.links));
    response->set_elapsed(r.elapsed);
    response->set_frames_sent(static_cast<uint32_t>(r.frames_sent));
  });
}

grpc::Status HostServiceImpl::Flush(grpc::ServerContext* context, const Empty*,
                                    v1::FlushResponse* response) {
  return Serve(context, "Flush",
               [&] { response->set_frames_sent(static_cast<uint32_t>(driver_.Flush())); });
}

grpc::Status HostServiceImpl::GetAllModulesId(grpc::ServerContext* context, const Empty*,
                                              v1::GetAllModulesIdResponse* response) {
  return Serve(context, "GetAllModulesId", [&] {
    for (int id : driver_.GetAllModulesId()) response->add_module_ids(static_cast<uint32_t>(id));
  });
}

#define YAMOR_COUPLING_GETTER(Method, field)                                                 \
  grpc::Status HostServiceImpl::Method(grpc::ServerContext* context,                         \
                                       const v1::CouplingRequest* request,                   \
                                       v1::ValueResponse* response) {                        \
    return Serve(context, #Method, [&] {                                                     \
      response->set_value(driver_.GetCouplingValue(ModuleId(request->from_id()),            \
                                                   ModuleId(request->to_id()), field));      \
    });                                                                                      \
  }
#define YAMOR_COUPLING_SETTER(Method, field)                                                 \
  grpc::Status HostServiceImpl::Method(grpc::ServerContext* context,                         \
                                       const v1::SetCouplingValueRequest* request, Empty*) { \
    return Serve(context, #Method, [&] {                                                     \
      driver_.SetCouplingValue(ModuleId(request->from_id()), ModuleId(request->to_id()),     \
                               field, request->value());                                     \
    });                                                                                      \
  }
#define YAMOR_MODULE_GETTER(Method, field)                                                       \
  grpc::Status HostServiceImpl::Method(grpc::ServerContext* context,                             \
                                       const v1::ModuleRequest* request,                         \
                                       v1::ValueResponse* response) {                            \
    return Serve(context, #Method, [&] {                                                         \
      response->set_value(driver_.GetModuleValue(ModuleId(request->module_id()), field));        \
    });                                                                                          \
  }
#define YAMOR_MODULE_SETTER(Method, field)                                                    \
  grpc::Status HostServiceImpl::Method(grpc::ServerContext* context,                          \
                                       const v1::SetModuleValueRequest* request, Empty*) {    \
    return Serve(context, #Method, [&] {                                                      \
      driver_.SetModuleValue(ModuleId(request->module_id()), field, request->value());        \
    });                                                                                       \
  }

YAMOR_COUPLING_GETTER(GetCouplingPhase, CouplingField::kPhase)
YAMOR_COUPLING_SETTER(SetCouplingPhase, CouplingField::kPhase)
YAMOR_COUPLING_GETTER(GetCouplingWeight, CouplingField::kWeight)
YAMOR_COUPLING_SETTER(SetCouplingWeight, CouplingField::kWeight)
YAMOR_MODULE_GETTER(GetModuleAmplitude, ModuleField::kAmplitude)
YAMOR_MODULE_SETTER(SetModuleAmplitude, ModuleField::kAmplitude)
YAMOR_MODULE_GETTER(GetModuleMaxAngle, ModuleField::kMaxAngle)
YAMOR_MODULE_SETTER(SetModuleMaxAngle, ModuleField::kMaxAngle)
YAMOR_MODULE_GETTER(GetModuleMinAngle, ModuleField::kMinAngle)
YAMOR_MODULE_SETTER(SetModuleMinAngle, ModuleField::kMinAngle)
YAMOR_MODULE_GETTER(GetModuleOffset, ModuleField::kOffset)
YAMOR_MODULE_SETTER(SetModuleOffset, ModuleField::kOffset)
YAMOR_MODULE_GETTER(GetModuleSpeed, ModuleField::kSpeed)
YAMOR_MODULE_SETTER(SetModuleSpeed, ModuleField::kSpeed)

#undef YAMOR_COUPLING_GETTER
#undef YAMOR_COUPLING_SETTER
#undef YAMOR_MODULE_GETTER
#undef YAMOR_MODULE_SETTER

grpc::Status HostServiceImpl::OpenSimulation(grpc::ServerContext* context,
                                             const v1::OpenSimulationRequest* request,
                                             v1::OpenSimulationResponse* response) {
  return Serve(context, "OpenSimulation", [&] {
    ResolvedWorld world =
        Resolve(request->world(), request->morphology_xml(), request->config_xml());
    // An empty world means the daemon's default world but keeps the
    // current configuration (unless one was sent).
    if (request->world().empty() && request->morphology_xml().empty() &&
        request->config_xml().empty()) {
      world.config.reset();
    }
    const OpenedSimulation opened = driver_.OpenSimulation(
        SimulationSpec{.morphology = std::move(world.morphology),
                       .world_name = world.name,
                       .config = std::move(world.config),
                       .seed = request->seed(),
                       .time_step = request->time_step()});
    for (int id : opened.module_ids) response->add_module_ids(static_cast<uint32_t>(id));
    response->set_central_module(static_cast<uint32_t>(opened.central_module));
  });
}

grpc::Status HostServiceImpl::Refresh(grpc::ServerContext* context, const Empty*,
                                      v1::FlushResponse* response) {
  return Serve(context, "Refresh",
               [&] { response->set_frames_sent(static_cast<uint32_t>(driver_.Refresh())); });
}

grpc::Status HostServiceImpl::RemoveAllCoupling(grpc::ServerContext* context, const Empty*,
                                                Empty*) {
  return Serve(context, "RemoveAllCoupling", [&] { driver_.RemoveAllCouplings(); });
}

grpc::Status HostServiceImpl::SendControlMessage(grpc::ServerContext* context,
                                                 const v1::ControlMessageRequest* request,
                                                 Empty*) {
  return Serve(context, "SendControlMessage", [&] {
    ControlMessage message{.uart = ToTristate(request->uart(), "uart"),
                           .cpg = ToTristate(request->cpg(), "cpg"),
                           .motors = ToTristate(request->motors(), "motors"),
                           .all = request->all()};
    for (uint32_t id : request->module_ids()) message.module_ids.push_back(ModuleId(id));
    driver_.SendControlMessage(message);
  });
}

grpc::Status HostServiceImpl::Sleep(grpc::ServerContext* context, const v1::SleepRequest* request,
                                    v1::SleepResponse* response) {
  return Serve(context, "Sleep", [&] {
    response->set_time(
        driver_.Sleep(request->seconds(), request->real_time(), CancelFor(context)));
  });
}

// ---- Beyond YaMoR Host 3 --------------------------------------------------------

grpc::Status HostServiceImpl::GetInfo(grpc::ServerContext* context, const Empty*,
                                      v1::GetInfoResponse* response) {
  return Serve(context, "GetInfo", [&] {
    const DriverInfo info = driver_.Info();
    response->set_version(options_.version.empty() ? YAMOR_VERSION : options_.version);
    response->set_backend(info.backend);
    response->set_worker_capacity(pool_.size());
    response->set_world(info.world);
    response->set_master_node(static_cast<uint32_t>(info.master_node));
    response->set_connected(info.connected);
    response->set_free_run_factor(info.free_run_factor);
    response->set_max_concurrent_calls(options_.max_concurrent_calls);
    for (const std::string& name : BuiltinRobotNames()) response->add_builtin_worlds(name);
  });
}

grpc::Status HostServiceImpl::LoadConfig(grpc::ServerContext* context,
                                         const v1::LoadConfigRequest* request, Empty*) {
  return Serve(context, "LoadConfig", [&] {
    driver_.LoadConfig(request->config_xml(),
                       request->source_name().empty() ? "<request>" : request->source_name());
  });
}

grpc::Status HostServiceImpl::SaveConfig(grpc::ServerContext* context, const Empty*,
                                         v1::SaveConfigResponse* response) {
  return Serve(context, "SaveConfig", [&] { response->set_config_xml(driver_.SaveConfig()); });
}

grpc::Status HostServiceImpl::GetMorphology(grpc::ServerContext* context, const Empty*,
                                            v1::GetMorphologyResponse* response) {
  return Serve(context, "GetMorphology", [&] {
    const physics::Morphology morphology = driver_.GetMorphology();
    response->set_morphology_xml(morphology.ToXml());
    response->set_central_module(
        static_cast<uint32_t>(driver_.id_map().ToReal(morphology.central())));
  });
}

grpc::Status HostServiceImpl::ConnectModules(grpc::ServerContext* context,
                                             const v1::ConnectModulesRequest* request, Empty*) {
  return Serve(context, "ConnectModules", [&] {
    driver_.ConnectModules(ModuleId(request->from_id()),
                           ToConnector(request->from_connector(), "from_connector"),
                           ModuleId(request->to_id()),
                           ToConnector(request->to_connector(), "to_connector"),
                           request->angle_degrees());
  });
}

grpc::Status HostServiceImpl::DisconnectModule(grpc::ServerContext* context,
                                               const v1::ModuleRequest* request, Empty*) {
  return Serve(context, "DisconnectModule",
               [&] { driver_.DisconnectModule(ModuleId(request->module_id())); });
}

grpc::Status HostServiceImpl::RunTransformationScript(
    grpc::ServerContext* context, const v1::RunTransformationScriptRequest* request, Empty*) {
  return Serve(context, "RunTransformationScript", [&] {
    driver_.RunTransformationScript(request->script_xml(), CancelFor(context));
  });
}

grpc::Status HostServiceImpl::SetMotorDefect(grpc::ServerContext* context,
                                             const v1::SetMotorDefectRequest* request, Empty*) {
  return Serve(context, "SetMotorDefect", [&] {
    driver_.SetMotorDefect(ModuleId(request->module_id()), ToMotorDefect(request->defect()));
  });
}

grpc::Status HostServiceImpl::SetModuleDefect(grpc::ServerContext* context,
                                              const v1::SetModuleDefectRequest* request, Empty*) {
  return Serve(context, "SetModuleDefect", [&] {
    driver_.SetModuleDefect(ModuleId(request->module_id()), request->defective());
  });
}

grpc::Status HostServiceImpl::SetGround(grpc::ServerContext* context,
                                        const v1::SetGroundRequest* request, Empty*) {
  return Serve(context, "SetGround", [&] {
    driver_.SetGround(ToGroundChange(*request));
  });
}

grpc::Status HostServiceImpl::GetServoAngles(grpc::ServerContext* context,
                                             const v1::GetServoAnglesRequest* request,
                                             v1::GetServoAnglesResponse* response) {
  return Serve(context, "GetServoAngles", [&] {
    std::vector<int> ids;
    for (uint32_t id : request->module_ids()) ids.push_back(ModuleId(id));
    for (const auto& [id, angle] : driver_.GetServoAngles(ids)) {
      v1::ServoAngle* a = response->add_angles();
      a->set_module_id(static_cast<uint32_t>(id));
      a->set_angle(angle);
    }
  });
}

grpc::Status HostServiceImpl::GetAccelerometer(grpc::ServerContext* context,
                                               const v1::GetAccelerometerRequest* request,
                                               v1::GetAccelerometerResponse* response) {
  return Serve(context, "GetAccelerometer", [&] {
    if (request->samples() > snp::kMaxAccelerometerSamples) {
      throw Error(StatusCode::kOutOfRange,
                  "accelerometer samples " + std::to_string(request->samples()) +
                      " is outside [1, 16]");
    }
    for (const AccelerometerSample& s : driver_.GetAccelerometer(
             ModuleId(request->module_id()), static_cast<int>(request->samples()))) {
      v1::AccelerometerSample* out = response->add_samples();
      out->set_x(s.counts[0]);
      out->set_y(s.counts[1]);
      out->set_z(s.counts[2]);
      out->mutable_acceleration()->set_x(s.acceleration[0]);
      out->mutable_acceleration()->set_y(s.acceleration[1]);
      out->mutable_acceleration()->set_z(s.acceleration[2]);
    }
  });
}

grpc::Status HostServiceImpl::GetOrientation(grpc::ServerContext* context,
                                             const v1::GetOrientationRequest* request,
                                             v1::GetOrientationResponse* response) {
  return Serve(context, "GetOrientation", [&] {
    if (request->samples() > snp::kMaxAccelerometerSamples) {
      throw Error(StatusCode::kOutOfRange,
                  "orientation samples " + std::to_string(request->samples()) +
                      " is outside [1, 16]");
    }
    const v1::Vector3& r = request->reference_up();
    const ModuleOrientation o =
        driver_.GetOrientation(ModuleId(request->module_id()), static_cast<int>(request->samples()),
                               {r.x(), r.y(), r.z()});
    response->set_valid(o.valid);
    response->mutable_up()->set_x(o.up[0]);
    response->mutable_up()->set_y(o.up[1]);
    response->mutable_up()->set_z(o.up[2]);
    response->set_tilt(o.tilt);
    response->set_upside_down(o.upside_down);
    response->set_magnitude(o.magnitude);
    response->set_max_deviation(o.max_deviation);
    response->set_samples(static_cast<uint32_t>(o.samples));
  });
}

grpc::Status HostServiceImpl::TurnUpsideDown(grpc::ServerContext* context, const Empty*, Empty*) {
  return Serve(context, "TurnUpsideDown", [&] { driver_.TurnUpsideDown(); });
}

grpc::Status HostServiceImpl::ResetSimulation(grpc::ServerContext* context, const Empty*, Empty*) {
  return Serve(context, "ResetSimulation", [&] { driver_.ResetSimulation(); });
}

grpc::Status HostServiceImpl::WatchState(grpc::ServerContext* context,
                                         const v1::WatchStateRequest* request,
                                         grpc::ServerWriter<v1::StateUpdate>* writer) {
  return Serve(context, "WatchState", [&] {
    double period = request->period();
    if (!std::isfinite(period)) {
      throw Error(StatusCode::kInvalidArgument, "watch period is not finite");
    }
    if (period == 0.0) period = 0.1;
    if (period < 0.0 || period > 3600.0) {
      throw Error(StatusCode::kOutOfRange,
                  "watch period " + std::to_string(period) + " s is outside (0, 3600]");
    }
    struct WatchGuard {
      RobotDriver& driver;
      ~WatchGuard() { driver.EndWatch(); }
    };
    WatchCursor cursor = driver_.BeginWatch();
    WatchGuard guard{driver_};
    while (!context->IsCancelled() && !stopping_ && !driver_.shutting_down()) {
      std::optional<StateUpdate> update =
          driver_.WaitForState(cursor, period, std::chrono::milliseconds(100));
      if (!update) continue;
      v1::StateUpdate out;
      out.set_time(update->pose.time);
      SetPose(update->pose, out.mutable_central());
      out.mutable_velocity()->set_x(update->velocity[0]);
      out.mutable_velocity()->set_y(update->velocity[1]);
      out.mutable_velocity()->set_z(update->velocity[2]);
      for (const StateEvent& e : update->events) {
        v1::StateEvent* event = out.add_events();
        event->set_kind(e.kind);
        if (e.module_id >= 0) event->set_module_id(static_cast<uint32_t>(e.module_id));
        event->set_detail(e.detail);
      }
      if (!writer->Write(out)) break;  // the client went away
    }
    if (context->IsCancelled()) throw Error(StatusCode::kCancelled, "watch cancelled");
  });
}

grpc::Status HostServiceImpl::RenderFrame(grpc::ServerContext* context,
                                          const v1::RenderFrameRequest* request,
                                          v1::RenderFrameResponse* response) {
  return Serve(context, "RenderFrame", [&] {
    const FrameSpec spec = ToFrameSpec(request->camera(), request->width(), request->height(),
                                       request->hide_labels(), request->hide_legend());
    EncodedFrame frame = host::RenderFrame(driver_, spec, CancelFor(context));
    response->set_png(frame.png.data(), frame.png.size());
    response->set_time(frame.time);
  });
}

grpc::Status HostServiceImpl::RecordFrames(grpc::ServerContext* context,
                                           const v1::RecordFramesRequest* request,
                                           grpc::ServerWriter<v1::VideoFrame>* writer) {
  return Serve(context, "RecordFrames", [&] {
    const RecordSpec spec{
        .frame = ToFrameSpec(request->camera(), request->width(), request->height(),
                             request->hide_labels(), request->hide_legend()),
        .frame_rate = request->frame_rate(),
        .seconds = request->seconds(),
        .advance = !request->watch()};
    const CancelCheck cancel = CancelFor(context);
    bool client_gone = false;
    host::RecordFrames(
        driver_, spec,
        [&](EncodedFrame&& frame) {
          v1::VideoFrame out;
          out.set_index(frame.index);
          out.set_time(frame.time);
          out.set_png(frame.png.data(), frame.png.size());
          if (!writer->Write(out)) client_gone = true;
          return !client_gone && !stopping_;
        },
        cancel);
    if (context->IsCancelled() || client_gone) {
      throw Error(StatusCode::kCancelled, "recording cancelled");
    }
    if (stopping_) throw Error(StatusCode::kUnavailable, "yamord is shutting down");
  });
}

grpc::Status HostServiceImpl::Evaluate(grpc::ServerContext* context,
                                       const v1::EvaluateRequest* request,
                                       v1::EvaluateResponse* response) {
  return Serve(context, "Evaluate", [&] {
    std::optional<physics::Morphology> morphology;
    std::optional<cpg::RobotConfig> config;
    if (request->world().empty() && request->morphology_xml().empty()) {
      try {
        morphology = driver_.GetMorphology();  // the open world, as the robot is now
      } catch (const Error& e) {
        // No simulated world open: the default world. An open world whose
        // current body is invalid is the caller's error, not a reason to
        // evaluate another body.
        const bool no_world = e.code() == StatusCode::kUnimplemented ||
                              (e.code() == StatusCode::kFailedPrecondition &&
                               !driver_.SimulationModeEnabled());
        if (!no_world) throw;
      }
    }
    if (!morphology || !request->config_xml().empty()) {
      ResolvedWorld world =
          Resolve(request->world(), request->morphology_xml(), request->config_xml());
      if (!morphology) morphology = std::move(world.morphology);
      // Without an explicit world the daemon's configuration goes with it.
      if (!request->config_xml().empty() || !request->world().empty() ||
          !request->morphology_xml().empty()) {
        config = std::move(world.config);
      }
    }
    if (!config) config = driver_.Config();
    EvaluationSpec spec{.morphology = std::move(*morphology),
                        .config = std::move(*config),
                        .id_map = driver_.id_map(),
                        .warmup = request->warmup() == 0.0 ? kDefaultWarmup : request->warmup(),
                        .duration = request->duration() == 0.0 ? kDefaultDuration
                                                                : request->duration(),
                        .seed = request->seed(),
                        .trajectory_period = request->trajectory_period(),
                        .time_step = request->time_step()};
    for (const v1::ParameterValue& p : request->parameters()) {
      spec.parameters.emplace_back(p.name(), p.value());
    }
    for (const v1::SetMotorDefectRequest& d : request->motor_defects()) {
      spec.motor_defects.emplace_back(ModuleId(d.module_id()), ToMotorDefect(d.defect()));
    }
    for (const v1::SetModuleDefectRequest& d : request->module_defects()) {
      spec.module_defects.emplace_back(ModuleId(d.module_id()), d.defective());
    }
    if (request->has_ground()) spec.ground = ToGroundChange(request->ground());
    spec.upside_down = request->upside_down();
    if (request->has_frames()) {
      const v1::EvaluationFrames& f = request->frames();
      spec.film = EvaluationFilm{
          .frame = ToFrameSpec(f.camera(), f.width(), f.height(), f.hide_labels(), f.hide_legend()),
          .frame_rate = f.frame_rate(),
          .mp4 = f.mp4(),
          .png_frames = {f.png_frames().begin(), f.png_frames().end()}};
    }
    const CancelCheck cancel = [this, context] {
      return context->IsCancelled() || stopping_.load() || pool_.stopping();
    };
    std::future<EvaluationResult> future =
        pool_.Submit([spec = std::move(spec), cancel] { return RunEvaluation(spec, cancel); });
    EvaluationResult r = future.get();
    response->set_velocity(r.velocity);
    response->set_distance(r.distance);
    SetPose(r.final_pose, response->mutable_final_pose());
    for (const TrajectoryPoint& t : r.trajectory) {
      v1::TrajectorySample* sample = response->add_trajectory();
      sample->set_time(t.time);
      sample->mutable_position()->set_x(t.position[0]);
      sample->mutable_position()->set_y(t.position[1]);
      sample->mutable_position()->set_z(t.position[2]);
    }
    response->set_diverged(r.diverged);
    response->set_divergence(r.divergence);
    response->set_wall_seconds(r.wall_seconds);
    for (EncodedFrame& frame : r.frames) {
      v1::VideoFrame* out = response->add_frames();
      out->set_index(frame.index);
      out->set_time(frame.time);
      out->set_png(frame.png.data(), frame.png.size());
      std::vector<uint8_t>().swap(frame.png);  // one copy of the bytes at a time
    }
    response->set_mp4(r.mp4.data(), r.mp4.size());
    std::vector<uint8_t>().swap(r.mp4);
    response->set_mp4_frames(r.mp4_frames);
    response->set_video_note(r.video_note);
  });
}

grpc::Status HostServiceImpl::SetFreeRun(grpc::ServerContext* context,
                                         const v1::SetFreeRunRequest* request, Empty*) {
  return Serve(context, "SetFreeRun", [&] { driver_.SetFreeRun(request->real_time_factor()); });
}

// ---- HostServer -----------------------------------------------------------------

HostServer::HostServer(RobotDriver& driver, WorkerPool& pool, const ServerOptions& options)
    : driver_(driver) {
  service_ = std::make_unique<HostServiceImpl>(driver, pool, options.service);
  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  grpc::ServerBuilder builder;
  builder.AddListeningPort(options.listen, grpc::InsecureServerCredentials(), &port_);
  builder.RegisterService(service_.get());
  // Bound gRPC's threads: beyond the cap the library itself answers
  // RESOURCE_EXHAUSTED; below it our in-flight cap does, with a clearer text.
  grpc::ResourceQuota quota("yamord");
  quota.SetMaxThreads(static_cast<int>(options.service.max_concurrent_calls) + 16);
  builder.SetResourceQuota(quota);
  server_ = builder.BuildAndStart();
  if (!server_ || port_ == 0) {
    throw Error(StatusCode::kUnavailable, "cannot listen on " + options.listen);
  }
  if (grpc::HealthCheckServiceInterface* health = server_->GetHealthCheckService()) {
    health->SetServingStatus(true);
  }
}

HostServer::~HostServer() { Shutdown(std::chrono::seconds(1)); }

void HostServer::Shutdown(std::chrono::milliseconds grace) {
  if (shut_down_.exchange(true)) return;
  if (grpc::HealthCheckServiceInterface* health = server_->GetHealthCheckService()) {
    health->SetServingStatus(false);
  }
  // New calls now get UNAVAILABLE; long calls (Sleep, ConnectRobot, Evaluate,
  // WatchState) end at their next chunk.
  service_->BeginShutdown();
  driver_.Shutdown();
  // Drain ourselves, then stop gRPC at once: given a grace period gRPC would
  // also wait for idle client connections, not only for calls.
  const auto deadline = std::chrono::steady_clock::now() + grace;
  while (service_->in_flight() > 0 && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  if (service_->in_flight() > 0) {
    Log().warn("shutdown: {} calls still running after the grace period; cancelling them",
               service_->in_flight());
  }
  server_->Shutdown(std::chrono::system_clock::now());
  server_->Wait();
}

}  // namespace yamor::host
