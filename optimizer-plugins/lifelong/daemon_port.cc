#include "optimizer-plugins/lifelong/daemon_port.h"

#include <grpcpp/grpcpp.h>

#include <chrono>
#include <cmath>
#include <set>

#include "common/format.h"
#include "common/log.h"
#include "common/status.h"
#include "physics/module_graph.h"
#include "physics/morphology.h"

namespace yamor::lifelong {
namespace {

using Clock = std::chrono::system_clock;

std::chrono::system_clock::time_point DeadlineAfter(double seconds) {
  return Clock::now() + std::chrono::milliseconds(static_cast<long long>(seconds * 1000));
}

// A failed RPC as a yamor::Error naming the call and the daemon. A deadline
// passing means the daemon stopped answering: for the runner it is gone.
[[noreturn]] void Throw(const grpc::Status& s, const std::string& what, const std::string& daemon) {
  StatusCode code = static_cast<StatusCode>(s.error_code());
  if (code == StatusCode::kDeadlineExceeded) code = StatusCode::kUnavailable;
  throw Error(code, what + " on " + daemon + ": " + s.error_message());
}

// Kinds whose module_id field is meaningful (proto3 cannot tell 0 from unset).
bool HasModule(const std::string& kind) {
  static const std::set<std::string> kinds = {"module_connected", "module_disconnected", "defect_set",
                                              "defect_cleared"};
  return kinds.count(kind) > 0;
}

}  // namespace

DaemonPort::DaemonPort(const optimizer::HostAddress& address, DaemonPortOptions options)
    : address_(address), name_(address.ToString()), options_(std::move(options)) {
  if (options_.accelerometer_samples < 1 || options_.accelerometer_samples > 16) {
    throw Error(StatusCode::kInvalidArgument, "accelerometer samples " +
                                                  std::to_string(options_.accelerometer_samples) +
                                                  " is outside 1..16");
  }
  channel_ = grpc::CreateChannel(name_, grpc::InsecureChannelCredentials());
  stub_ = v1::Host::NewStub(channel_);
  watch_ = std::thread([this] { WatchLoop(); });
}

DaemonPort::~DaemonPort() {
  {
    std::lock_guard lock(events_mu_);
    shutdown_ = true;
    if (watch_context_) watch_context_->TryCancel();
  }
  events_cv_.notify_all();
  watch_.join();
}

void DaemonPort::WatchLoop() {
  double backoff = 0.2;
  while (true) {
    auto context = std::make_shared<grpc::ClientContext>();
    {
      std::lock_guard lock(events_mu_);
      if (shutdown_) return;
      watch_context_ = context;
    }
    bool got = false;
    try {
      v1::WatchStateRequest request;
      request.set_period(options_.watch_period);
      auto reader = stub_->WatchState(context.get(), request);
      v1::StateUpdate update;
      while (reader->Read(&update)) {
        got = true;
        if (update.events_size() == 0) continue;
        std::lock_guard lock(events_mu_);
        for (const v1::StateEvent& e : update.events()) {
          events_.push_back(RobotEvent{.time = update.time(),
                                       .kind = e.kind(),
                                       .module_id = HasModule(e.kind()) ? static_cast<int>(e.module_id()) : -1,
                                       .detail = e.detail()});
        }
        events_cv_.notify_all();
      }
      reader->Finish();
    } catch (const std::exception& e) {
      Log().warn("lifelong: event stream of {}: {}", name_, e.what());
    }
    std::unique_lock lock(events_mu_);
    watch_context_.reset();
    if (shutdown_) return;
    backoff = got ? 0.2 : std::min(backoff * 2, 2.0);
    events_cv_.wait_for(lock, std::chrono::milliseconds(static_cast<int>(backoff * 1000)),
                        [this] { return shutdown_; });
  }
}

void DaemonPort::CheckStop() const {
  if (stop_.load()) throw Error(StatusCode::kCancelled, "stopped");
}

void DaemonPort::RequestStop() {
  stop_.store(true);
  std::lock_guard lock(live_mu_);
  if (live_) live_->RequestStop();
}

double DaemonPort::Now() {
  CheckStop();
  grpc::ClientContext context;
  context.set_deadline(DeadlineAfter(options_.rpc_deadline));
  v1::ElapsedTimeResponse response;
  const grpc::Status s = stub_->ElapsedTime(&context, google::protobuf::Empty(), &response);
  if (!s.ok()) Throw(s, "ElapsedTime", name_);
  return response.seconds();
}

bool DaemonPort::Simulated() {
  if (!simulated_) {
    grpc::ClientContext context;
    context.set_deadline(DeadlineAfter(options_.rpc_deadline));
    v1::GetInfoResponse response;
    const grpc::Status s = stub_->GetInfo(&context, google::protobuf::Empty(), &response);
    if (!s.ok()) Throw(s, "GetInfo", name_);
    simulated_ = response.backend() == "simulation";
  }
  return *simulated_;
}

void DaemonPort::BeforeMotion() {
  if (!before_motion_) return;
  if (before_motion_(Now())) {
    std::lock_guard lock(events_mu_);
    await_events_ = true;
  }
}

optimizer::LiveEvaluator& DaemonPort::Live() {
  std::lock_guard lock(live_mu_);
  if (!live_) live_ = std::make_unique<optimizer::LiveEvaluator>(channel_, name_, options_.live);
  if (stop_.load()) live_->RequestStop();
  return *live_;
}

std::unique_ptr<optimizer::LiveEvaluator> DaemonPort::NewLiveEvaluator() {
  CheckStop();
  return std::make_unique<optimizer::LiveEvaluator>(channel_, name_, options_.live);
}

Window DaemonPort::Measure(double periods) {
  CheckStop();
  BeforeMotion();
  const optimizer::LiveMeasurement m = Live().Measure(periods);
  return Window{.start_time = m.start_time, .end_time = m.end_time, .velocity = m.velocity, .period = m.period};
}

void DaemonPort::Settle(double periods) {
  CheckStop();
  if (periods <= 0) return;
  BeforeMotion();
  Live().Measure(periods);
}

std::vector<RobotEvent> DaemonPort::TakeEvents() {
  std::unique_lock lock(events_mu_);
  if (await_events_) {
    // A change was just made: give the stream a moment to bring its events.
    events_cv_.wait_for(lock, std::chrono::seconds(2), [this] { return !events_.empty() || shutdown_; });
    await_events_ = false;
  }
  return std::exchange(events_, {});
}

AccelReading DaemonPort::ReadAccelerometer() {
  CheckStop();
  AccelReading reading;
  if (central_ < 0) {
    try {
      Body();
    } catch (const Error& e) {
      if (e.code() == StatusCode::kUnavailable) throw;
      reading.error = e.what();
      return reading;
    }
  }
  grpc::ClientContext context;
  context.set_deadline(DeadlineAfter(options_.rpc_deadline));
  v1::GetAccelerometerRequest request;
  request.set_module_id(static_cast<uint32_t>(central_));
  request.set_samples(static_cast<uint32_t>(options_.accelerometer_samples));
  v1::GetAccelerometerResponse response;
  const grpc::Status s = stub_->GetAccelerometer(&context, request, &response);
  if (!s.ok()) {
    if (s.error_code() == grpc::StatusCode::UNAVAILABLE || s.error_code() == grpc::StatusCode::DEADLINE_EXCEEDED) {
      Throw(s, "GetAccelerometer", name_);
    }
    reading.error = "GetAccelerometer: " + s.error_message();
    return reading;
  }
  const int n = response.samples_size();
  if (n == 0) {
    reading.error = "GetAccelerometer gave no samples";
    return reading;
  }
  for (const auto& sample : response.samples()) {
    reading.mean[0] += sample.acceleration().x() / n;
    reading.mean[1] += sample.acceleration().y() / n;
    reading.mean[2] += sample.acceleration().z() / n;
  }
  double sum = 0;
  for (const auto& sample : response.samples()) {
    const double dx = sample.acceleration().x() - reading.mean[0];
    const double dy = sample.acceleration().y() - reading.mean[1];
    const double dz = sample.acceleration().z() - reading.mean[2];
    sum += dx * dx + dy * dy + dz * dz;
  }
  reading.spread = std::sqrt(sum / n);
  reading.samples = n;
  reading.valid = true;
  return reading;
}

std::pair<cpg::ModuleGraph, std::string> DaemonPort::Body() {
  CheckStop();
  grpc::ClientContext context;
  context.set_deadline(DeadlineAfter(options_.rpc_deadline));
  v1::GetMorphologyResponse response;
  const grpc::Status s = stub_->GetMorphology(&context, google::protobuf::Empty(), &response);
  std::string xml;
  if (s.ok()) {
    xml = response.morphology_xml();
  } else if (s.error_code() == grpc::StatusCode::UNIMPLEMENTED && !options_.morphology_xml.empty()) {
    xml = options_.morphology_xml;  // a real robot: the body the user described
  } else if (s.error_code() == grpc::StatusCode::UNIMPLEMENTED) {
    throw Error(StatusCode::kFailedPrecondition,
                name_ + " cannot tell the robot's body (" + s.error_message() +
                    "); give the robot's morphology with --morphology");
  } else {
    Throw(s, "GetMorphology", name_);
  }
  const physics::Morphology morphology = physics::Morphology::Parse(xml, name_);
  central_ = morphology.central();
  return {physics::ModuleGraphOf(morphology), xml};
}

void DaemonPort::Walk(const std::string& config_xml) {
  CheckStop();
  auto deadline = [&](grpc::ClientContext& c) { c.set_deadline(DeadlineAfter(options_.rpc_deadline)); };
  {
    grpc::ClientContext context;
    deadline(context);
    v1::LoadConfigRequest request;
    request.set_config_xml(config_xml);
    request.set_source_name("yamor-lifelong gait");
    google::protobuf::Empty response;
    const grpc::Status s = stub_->LoadConfig(&context, request, &response);
    if (!s.ok()) Throw(s, "LoadConfig", name_);
  }
  bool connected = false;
  {
    grpc::ClientContext context;
    deadline(context);
    v1::GetInfoResponse response;
    const grpc::Status s = stub_->GetInfo(&context, google::protobuf::Empty(), &response);
    if (!s.ok()) Throw(s, "GetInfo", name_);
    connected = response.connected();
    simulated_ = response.backend() == "simulation";
  }
  if (connected) {
    grpc::ClientContext context;
    deadline(context);
    v1::FlushResponse response;
    const grpc::Status s = stub_->Flush(&context, google::protobuf::Empty(), &response);
    if (!s.ok()) Throw(s, "Flush", name_);
  } else {
    grpc::ClientContext context;
    context.set_deadline(DeadlineAfter(options_.rpc_deadline + 60));
    v1::ConnectRobotRequest request;
    request.set_link_timeout(options_.connect_timeout);
    v1::ConnectRobotResponse response;
    const grpc::Status s = stub_->ConnectRobot(&context, request, &response);
    if (!s.ok()) Throw(s, "ConnectRobot", name_);
  }
  {
    grpc::ClientContext context;
    deadline(context);
    v1::ControlMessageRequest request;
    request.set_uart(v1::SWITCH_ON);
    request.set_cpg(v1::SWITCH_ON);
    request.set_motors(v1::SWITCH_ON);
    request.set_all(true);
    google::protobuf::Empty response;
    const grpc::Status s = stub_->SendControlMessage(&context, request, &response);
    if (!s.ok()) Throw(s, "SendControlMessage", name_);
  }
  // A fresh evaluator reads the new configuration's speeds.
  std::lock_guard lock(live_mu_);
  live_.reset();
}

Reattachment DaemonPort::Reattach(const std::string& config_xml, const std::function<bool()>& stop) {
  double wait = options_.reattach_initial;
  while (true) {
    if (stop()) throw Error(StatusCode::kCancelled, "stopped while waiting for " + name_);
    try {
      grpc::ClientContext context;
      context.set_deadline(DeadlineAfter(options_.rpc_deadline));
      v1::GetInfoResponse info;
      const grpc::Status s = stub_->GetInfo(&context, google::protobuf::Empty(), &info);
      if (!s.ok()) Throw(s, "GetInfo", name_);
      simulated_.reset();
      central_ = -1;
      const bool restarted = !info.connected();
      if (restarted && on_restart_) on_restart_();
      Walk(config_xml);
      return Reattachment{.robot_time = Now(), .restarted = restarted};
    } catch (const Error& e) {
      if (e.code() != StatusCode::kUnavailable) throw;
      Log().debug("lifelong: {} not back yet: {}", name_, e.what());
    }
    const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(static_cast<int>(wait * 1000));
    while (std::chrono::steady_clock::now() < until && !stop()) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    wait = std::min(wait * 2, options_.reattach_max);
  }
}

}  // namespace yamor::lifelong
