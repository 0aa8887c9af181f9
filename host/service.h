// The gRPC service layer of yamord: a thin adapter that validates requests,
// calls the RobotDriver (stateful calls) or the WorkerPool (Evaluate), and
// maps every error with one ToGrpcStatus(). Plus HostServer, which builds
// and runs the gRPC server (health, reflection, thread cap).
#pragma once

#include <atomic>
#include <chrono>
#include <exception>
#include <memory>
#include <string>
#include <string_view>

#include <grpcpp/grpcpp.h>

#include "common/status.h"
#include "host/driver.h"
#include "host/builtin_robots.h"
#include "host/evaluator.h"
#include "host/worker_pool.h"
#include "host/worlds.h"
#include "yamor/v1/host.grpc.pb.h"

namespace yamor::host {

/// The gRPC status of a caught exception: yamor::Error keeps its code and
/// message; anything else is INTERNAL (with the exception's text).
grpc::Status ToGrpcStatus(std::exception_ptr error);

/// Settings of the service layer.
struct ServiceOptions {
  unsigned max_concurrent_calls = 64;  ///< Calls served at once; more get RESOURCE_EXHAUSTED.
  std::string version;                 ///< Reported by GetInfo ("" = the build's version).
  /// Name of the daemon's default world (OpenSimulation/Evaluate with an
  /// empty world); a built-in name unless `default_morphology` is set.
  std::string default_world = std::string(kDefaultWorld);
  /// The default world's morphology when it is not built in (a file from
  /// yamord's settings); null = resolve `default_world` as a built-in name.
  std::shared_ptr<const physics::Morphology> default_morphology;
};

/// The yamor.v1.Host service.
///
/// Thread-safety: every handler may run concurrently on gRPC's threads; the
/// service holds no robot state (the driver serialises the robot, the pool
/// runs Evaluate in parallel). Counters are atomics.
class HostServiceImpl final : public yamor::v1::Host::Service {
 public:
  /// Serves `driver` and `pool`, which must outlive the service.
  HostServiceImpl(RobotDriver& driver, WorkerPool& pool, ServiceOptions options);

  /// New calls get UNAVAILABLE; running Evaluate and WatchState calls end.
  void BeginShutdown() { stopping_ = true; }
  /// Calls being served now.
  unsigned in_flight() const { return in_flight_.load(); }

  // One handler per RPC of yamor.v1.Host; semantics and error codes are
  // documented in proto/yamor/v1/host.proto. Each validates, calls the driver
  // or the pool, and maps errors with ToGrpcStatus.

  // ---- IYaMoRHost3 ----
  grpc::Status ElapsedTime(grpc::ServerContext* context, const google::protobuf::Empty* request,
                           yamor::v1::ElapsedTimeResponse* response) override;
  /// The RobotPosition RPC.
  grpc::Status RobotPosition(grpc::ServerContext* context, const google::protobuf::Empty* request,
                             yamor::v1::RobotPositionResponse* response) override;
  /// The SimulatedPosition RPC.
  grpc::Status SimulatedPosition(grpc::ServerContext* context, const google::protobuf::Empty* request,
                                 yamor::v1::RobotPositionResponse* response) override;
  /// The SimulationModeEnabled RPC.
  grpc::Status SimulationModeEnabled(grpc::ServerContext* context,
                                     const google::protobuf::Empty* request,
                                     yamor::v1::SimulationModeEnabledResponse* response) override;
  /// The AddCoupling RPC.
  grpc::Status AddCoupling(grpc::ServerContext* context,
                           const yamor::v1::AddCouplingRequest* request,
                           google::protobuf::Empty* response) override;
  /// The CloseSimulation RPC.
  grpc::Status CloseSimulation(grpc::ServerContext* context, const google::protobuf::Empty* request,
                               google::protobuf::Empty* response) override;
  /// The ConnectRobot RPC.
  grpc::Status ConnectRobot(grpc::ServerContext* context,
                            const yamor::v1::ConnectRobotRequest* request,
                            yamor::v1::ConnectRobotResponse* response) override;
  /// The Flush RPC.
  grpc::Status Flush(grpc::ServerContext* context, const google::protobuf::Empty* request,
                     yamor::v1::FlushResponse* response) override;
  /// The GetAllModulesId RPC.
  grpc::Status GetAllModulesId(grpc::ServerContext* context, const google::protobuf::Empty* request,
                               yamor::v1::GetAllModulesIdResponse* response) override;
  /// The GetCouplingPhase RPC.
  grpc::Status GetCouplingPhase(grpc::ServerContext* context,
                                const yamor::v1::CouplingRequest* request,
                                yamor::v1::ValueResponse* response) override;
  /// The SetCouplingPhase RPC.
  grpc::Status SetCouplingPhase(grpc::ServerContext* context,
                                const yamor::v1::SetCouplingValueRequest* request,
                                google::protobuf::Empty* response) override;
  /// The GetCouplingWeight RPC.
  grpc::Status GetCouplingWeight(grpc::ServerContext* context,
                                 const yamor::v1::CouplingRequest* request,
                                 yamor::v1::ValueResponse* response) override;
  /// The SetCouplingWeight RPC.
  grpc::Status SetCouplingWeight(grpc::ServerContext* context,
                                 const yamor::v1::SetCouplingValueRequest* request,
                                 google::protobuf::Empty* response) override;
  /// The GetModuleAmplitude RPC.
  grpc::Status GetModuleAmplitude(grpc::ServerContext* context,
                                  const yamor::v1::ModuleRequest* request,
                                  yamor::v1::ValueResponse* response) override;
  /// The SetModuleAmplitude RPC.
  grpc::Status SetModuleAmplitude(grpc::ServerContext* context,
                                  const yamor::v1::SetModuleValueRequest* request,
                                  google::protobuf::Empty* response) override;
  /// The GetModuleMaxAngle RPC.
  grpc::Status GetModuleMaxAngle(grpc::ServerContext* context,
                                 const yamor::v1::ModuleRequest* request,
                                 yamor::v1::ValueResponse* response) override;
  /// The SetModuleMaxAngle RPC.
  grpc::Status SetModuleMaxAngle(grpc::ServerContext* context,
                                 const yamor::v1::SetModuleValueRequest* request,
                                 google::protobuf::Empty* response) override;
  /// The GetModuleMinAngle RPC.
  grpc::Status GetModuleMinAngle(grpc::ServerContext* context,
                                 const yamor::v1::ModuleRequest* request,
                                 yamor::v1::ValueResponse* response) override;
  /// The SetModuleMinAngle RPC.
  grpc::Status SetModuleMinAngle(grpc::ServerContext* context,
                                 const yamor::v1::SetModuleValueRequest* request,
                                 google::protobuf::Empty* response) override;
  /// The GetModuleOffset RPC.
  grpc::Status GetModuleOffset(grpc::ServerContext* context, const yamor::v1::ModuleRequest* request,
                               yamor::v1::ValueResponse* response) override;
  /// The SetModuleOffset RPC.
  grpc::Status SetModuleOffset(grpc::ServerContext* context,
                               const yamor::v1::SetModuleValueRequest* request,
                               google::protobuf::Empty* response) override;
  /// The GetModuleSpeed RPC.
  grpc::Status GetModuleSpeed(grpc::ServerContext* context, const yamor::v1::ModuleRequest* request,
                              yamor::v1::ValueResponse* response) override;
  /// The SetModuleSpeed RPC.
  grpc::Status SetModuleSpeed(grpc::ServerContext* context,
                              const yamor::v1::SetModuleValueRequest* request,
                              google::protobuf::Empty* response) override;
  /// The OpenSimulation RPC.
  grpc::Status OpenSimulation(grpc::ServerContext* context,
                              const yamor::v1::OpenSimulationRequest* request,
                              yamor::v1::OpenSimulationResponse* response) override;
  /// The Refresh RPC.
  grpc::Status Refresh(grpc::ServerContext* context, const google::protobuf::Empty* request,
                       yamor::v1::FlushResponse* response) override;
  /// The RemoveAllCoupling RPC.
  grpc::Status RemoveAllCoupling(grpc::ServerContext* context,
                                 const google::protobuf::Empty* request,
                                 google::protobuf::Empty* response) override;
  /// The SendControlMessage RPC.
  grpc::Status SendControlMessage(grpc::ServerContext* context,
                                  const yamor::v1::ControlMessageRequest* request,
                                  google::protobuf::Empty* response) override;
  /// The Sleep RPC.
  grpc::Status Sleep(grpc::ServerContext* context, const yamor::v1::SleepRequest* request,
                     yamor::v1::SleepResponse* response) override;

  // ---- Beyond YaMoR Host 3 ----
  /// The GetInfo RPC.
  grpc::Status GetInfo(grpc::ServerContext* context, const google::protobuf::Empty* request,
                       yamor::v1::GetInfoResponse* response) override;
  /// The LoadConfig RPC.
  grpc::Status LoadConfig(grpc::ServerContext* context, const yamor::v1::LoadConfigRequest* request,
                          google::protobuf::Empty* response) override;
  /// The SaveConfig RPC.
  grpc::Status SaveConfig(grpc::ServerContext* context, const google::protobuf::Empty* request,
                          yamor::v1::SaveConfigResponse* response) override;
  /// The GetMorphology RPC.
  grpc::Status GetMorphology(grpc::ServerContext* context, const google::protobuf::Empty* request,
                             yamor::v1::GetMorphologyResponse* response) override;
  /// The ConnectModules RPC.
  grpc::Status ConnectModules(grpc::ServerContext* context,
                              const yamor::v1::ConnectModulesRequest* request,
                              google::protobuf::Empty* response) override;
  /// The DisconnectModule RPC.
  grpc::Status DisconnectModule(grpc::ServerContext* context,
                                const yamor::v1::ModuleRequest* request,
                                google::protobuf::Empty* response) override;
  /// The RunTransformationScript RPC.
  grpc::Status RunTransformationScript(grpc::ServerContext* context,
                                       const yamor::v1::RunTransformationScriptRequest* request,
                                       google::protobuf::Empty* response) override;
  /// The SetMotorDefect RPC.
  grpc::Status SetMotorDefect(grpc::ServerContext* context,
                              const yamor::v1::SetMotorDefectRequest* request,
                              google::protobuf::Empty* response) override;
  /// The SetModuleDefect RPC.
  grpc::Status SetModuleDefect(grpc::ServerContext* context,
                               const yamor::v1::SetModuleDefectRequest* request,
                               google::protobuf::Empty* response) override;
  /// The SetGround RPC.
  grpc::Status SetGround(grpc::ServerContext* context, const yamor::v1::SetGroundRequest* request,
                         google::protobuf::Empty* response) override;
  /// The GetServoAngles RPC.
  grpc::Status GetServoAngles(grpc::ServerContext* context,
                              const yamor::v1::GetServoAnglesRequest* request,
                              yamor::v1::GetServoAnglesResponse* response) override;
  /// The GetAccelerometer RPC.
  grpc::Status GetAccelerometer(grpc::ServerContext* context,
                                const yamor::v1::GetAccelerometerRequest* request,
                                yamor::v1::GetAccelerometerResponse* response) override;
  /// The GetOrientation RPC.
  grpc::Status GetOrientation(grpc::ServerContext* context,
                              const yamor::v1::GetOrientationRequest* request,
                              yamor::v1::GetOrientationResponse* response) override;
  /// The TurnUpsideDown RPC.
  grpc::Status TurnUpsideDown(grpc::ServerContext* context, const google::protobuf::Empty* request,
                              google::protobuf::Empty* response) override;
  /// The ResetSimulation RPC.
  grpc::Status ResetSimulation(grpc::ServerContext* context, const google::protobuf::Empty* request,
                               google::protobuf::Empty* response) override;
  /// The WatchState RPC.
  grpc::Status WatchState(grpc::ServerContext* context, const yamor::v1::WatchStateRequest* request,
                          grpc::ServerWriter<yamor::v1::StateUpdate>* writer) override;
  /// The Evaluate RPC.
  grpc::Status Evaluate(grpc::ServerContext* context, const yamor::v1::EvaluateRequest* request,
                        yamor::v1::EvaluateResponse* response) override;
  /// The SetFreeRun RPC.
  grpc::Status SetFreeRun(grpc::ServerContext* context, const yamor::v1::SetFreeRunRequest* request,
                          google::protobuf::Empty* response) override;
  /// The RenderFrame RPC.
  grpc::Status RenderFrame(grpc::ServerContext* context,
                           const yamor::v1::RenderFrameRequest* request,
                           yamor::v1::RenderFrameResponse* response) override;
  /// The RecordFrames RPC.
  grpc::Status RecordFrames(grpc::ServerContext* context,
                            const yamor::v1::RecordFramesRequest* request,
                            grpc::ServerWriter<yamor::v1::VideoFrame>* writer) override;

 private:
  // Runs `body` under the in-flight cap, mapping every exception.
  template <typename Body>
  /// The Serve RPC.
  grpc::Status Serve(grpc::ServerContext* context, std::string_view method, Body&& body);
  // A cancel check for long calls: the client gave up or the daemon stops.
  CancelCheck CancelFor(grpc::ServerContext* context) const;
  // The world a request names (empty: the daemon's default world).
  ResolvedWorld Resolve(const std::string& world, const std::string& morphology_xml,
                        const std::string& config_xml) const;

  RobotDriver& driver_;
  WorkerPool& pool_;
  const ServiceOptions options_;
  std::atomic<unsigned> in_flight_{0};
  std::atomic<bool> stopping_{false};
};

/// Where and how HostServer listens.
struct ServerOptions {
  std::string listen = "127.0.0.1:2224";  ///< ADDR:PORT; port 0 picks a free port.
  ServiceOptions service;                 ///< The service's settings.
};

/// A running yamord gRPC server: the Host service, grpc.health.v1 (SERVING
/// while up) and server reflection; gRPC's thread pool is capped by a
/// ResourceQuota so a flood gets RESOURCE_EXHAUSTED, not unbounded threads.
///
/// Thread-safety: Shutdown may be called from any thread, once.
class HostServer {
 public:
  /// Builds and starts the server; UNAVAILABLE when it cannot listen.
  HostServer(RobotDriver& driver, WorkerPool& pool, const ServerOptions& options);
  /// Shuts down (1 s grace) if still running.
  ~HostServer();
  HostServer(const HostServer&) = delete;
  HostServer& operator=(const HostServer&) = delete;

  /// The bound port (the chosen one when listening on port 0).
  int port() const { return port_; }
  /// Stops accepting calls, marks health NOT_SERVING, cancels long calls
  /// (Sleep, ConnectRobot, Evaluate, WatchState) through the driver and the
  /// service, waits up to `grace` for in-flight calls, then cancels the rest.
  void Shutdown(std::chrono::milliseconds grace);
  /// The service (for counters).
  HostServiceImpl& service() { return *service_; }

 private:
  RobotDriver& driver_;
  std::unique_ptr<HostServiceImpl> service_;
  std::unique_ptr<grpc::Server> server_;
  int port_ = 0;
  std::atomic<bool> shut_down_{false};
};

}  // namespace yamor::host
