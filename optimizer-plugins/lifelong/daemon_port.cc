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

using google::protobuf::Empty;

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
  const std::shared_ptr<grpc::Channel> channel = client::MakeChannel(name_);
  host_ = std::make_unique<client::HostClient>(channel, name_, options_.rpc_deadline);
  watch_host_ = std::make_unique<client::HostClient>(channel, name_, options_.rpc_deadline);
  watch_ = std::thread([this] { WatchLoop(); });
}

DaemonPort::~DaemonPort() {
  {
    std::lock_guard lock(events_mu_);
    shutdown_ = true;
  }
  watch_host_->Cancel();
  events_cv_.notify_all();
  watch_.join();
}

void DaemonPort::WatchLoop() {
  double backoff = 0.2;
  while (true) {
    {
      std::lock_guard lock(events_mu_);
      if (shutdown_) return;
    }
    bool got = false;
    try {
      v1::WatchStateRequest request;
      request.set_period(options_.watch_period);
      // No deadline: the stream lasts as long as the daemon; the destructor cancels it.
      watch_host_->TryStream(&v1::Host::Stub::WatchState, request, [&](const v1::StateUpdate& update) {
        got = true;
        if (update.events_size() == 0) return true;
        std::lock_guard lock(events_mu_);
        for (const v1::StateEvent& e : update.events()) {
          events_.push_back(RobotEvent{.time = update.time(),
                                       .kind = e.kind(),
                                       .module_id = HasModule(e.kind()) ? static_cast<int>(e.module_id()) : -1,
                                       .detail = e.detail()});
        }
        events_cv_.notify_all();
        return true;
      });
    } catch (const std::exception& e) {
      Log().warn("lifelong: event stream of {}: {}", name_, e.what());
    }
    std::unique_lock lock(events_mu_);
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
  return host_->Call(&v1::Host::Stub::ElapsedTime, Empty(), "ElapsedTime").seconds();
}

bool DaemonPort::Simulated() {
  if (!simulated_) {
    simulated_ = host_->Call(&v1::Host::Stub::GetInfo, Empty(), "GetInfo").backend() == "simulation";
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
  if (!live_) live_ = std::make_unique<optimizer::LiveEvaluator>(host_->channel(), name_, options_.live);
  if (stop_.load()) live_->RequestStop();
  return *live_;
}

std::unique_ptr<optimizer::LiveEvaluator> DaemonPort::NewLiveEvaluator() {
  CheckStop();
  return std::make_unique<optimizer::LiveEvaluator>(host_->channel(), name_, options_.live);
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
  v1::GetAccelerometerRequest request;
  request.set_module_id(static_cast<uint32_t>(central_));
  request.set_samples(static_cast<uint32_t>(options_.accelerometer_samples));
  v1::GetAccelerometerResponse response;
  try {
    response = host_->Call(&v1::Host::Stub::GetAccelerometer, request, "GetAccelerometer");
  } catch (const Error& e) {
    if (e.code() == StatusCode::kUnavailable) throw;  // the daemon is gone
    reading.error = e.what();  // this robot cannot tell: no orientation
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
  std::string xml;
  try {
    xml = host_->Call(&v1::Host::Stub::GetMorphology, Empty(), "GetMorphology").morphology_xml();
  } catch (const Error& e) {
    if (e.code() != StatusCode::kUnimplemented) throw;
    if (options_.morphology_xml.empty()) {
      throw Error(StatusCode::kFailedPrecondition,
                  name_ + " cannot tell the robot's body (" + e.what() +
                      "); give the robot's morphology with --morphology");
    }
    xml = options_.morphology_xml;  // a real robot: the body the user described
  }
  const physics::Morphology morphology = physics::Morphology::Parse(xml, name_);
  central_ = morphology.central();
  return {physics::ModuleGraphOf(morphology), xml};
}

void DaemonPort::Walk(const std::string& config_xml) {
  CheckStop();
  v1::LoadConfigRequest load;
  load.set_config_xml(config_xml);
  load.set_source_name("yamor-lifelong gait");
  host_->Call(&v1::Host::Stub::LoadConfig, load, "LoadConfig");
  const v1::GetInfoResponse info = host_->Call(&v1::Host::Stub::GetInfo, Empty(), "GetInfo");
  simulated_ = info.backend() == "simulation";
  if (info.connected()) {
    host_->Call(&v1::Host::Stub::Flush, Empty(), "Flush");
  } else {
    v1::ConnectRobotRequest connect;
    connect.set_link_timeout(options_.connect_timeout);
    host_->Call(&v1::Host::Stub::ConnectRobot, connect, "ConnectRobot",
                {.deadline = options_.rpc_deadline + 60});
  }
  v1::ControlMessageRequest control;
  control.set_uart(v1::SWITCH_ON);
  control.set_cpg(v1::SWITCH_ON);
  control.set_motors(v1::SWITCH_ON);
  control.set_all(true);
  host_->Call(&v1::Host::Stub::SendControlMessage, control, "SendControlMessage");
  // A fresh evaluator reads the new configuration's speeds.
  std::lock_guard lock(live_mu_);
  live_.reset();
}

Reattachment DaemonPort::Reattach(const std::string& config_xml, const std::function<bool()>& stop) {
  double wait = options_.reattach_initial;
  while (true) {
    if (stop()) throw Error(StatusCode::kCancelled, "stopped while waiting for " + name_);
    try {
      const v1::GetInfoResponse info = host_->Call(&v1::Host::Stub::GetInfo, Empty(), "GetInfo");
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
