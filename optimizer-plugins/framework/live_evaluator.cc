#include "optimizer-plugins/framework/live_evaluator.h"

#include <google/protobuf/empty.pb.h>
#include <grpcpp/grpcpp.h>
#include <spdlog/fmt/fmt.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <map>
#include <mutex>
#include <optional>
#include <utility>

#include "common/log.h"
#include "common/status.h"
#include "cpg/config_xml.h"
#include "cpg/parameters.h"
#include "optimizer-plugins/framework/host_rpc.h"
#include "yamor/v1/host.grpc.pb.h"
#include "yamor/v1/host.pb.h"

namespace yamor::optimizer {
namespace {

namespace v1 = yamor::v1;
using google::protobuf::Empty;
using Clock = std::chrono::steady_clock;
using client::HostClient;

// Robot time left below this ends a measurement [s]: far below any physics
// step, far above the rounding of summed sleeps.
constexpr double kTimeTolerance = 1e-6;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

void CheckOption(bool ok, const char* name, double value, const char* rule) {
  if (!ok || !std::isfinite(value)) {
    throw Error(StatusCode::kInvalidArgument,
                fmt::format("live evaluator option {} must be {}, got {}", name, rule, value));
  }
}

// The CPG period of a configuration: 1 / smallest non-zero speed, capped.
double PeriodOf(const cpg::RobotConfig& config, double max_period) {
  double slowest = 0.0;
  for (const cpg::ModuleParams& m : config.modules) {
    if (m.speed > 0.0 && (slowest == 0.0 || m.speed < slowest)) slowest = m.speed;
  }
  return slowest > 0.0 ? std::min(1.0 / slowest, max_period) : max_period;
}

// One RobotPosition sample.
struct Sample {
  double x = 0;
  double y = 0;
  double time = 0;
  std::string source;
};

// How robot time advances during one trial.
struct TimeMode {
  bool simulated = false;  // the daemon runs a simulation
  double free_run = 0.0;   // its free-run factor (0: off)
  // Virtual time: the world moves only when a Sleep steps it.
  bool Virtual() const { return simulated && free_run == 0.0; }
  // Robot seconds per wall-clock second when not virtual.
  double Rate() const { return simulated ? free_run : 1.0; }
};

// Channels of the live evaluator: reconnect soon after a daemon comes back.
constexpr client::ChannelOptions kLiveChannel{
    .reconnect_initial = 0.1, .reconnect_max = 1.0, .own_connection = true};

}  // namespace

LivePreparation PrepareLiveRobot(const HostAddress& address, const std::string& config_xml,
                                 const std::string& source_name, double deadline) {
  HostClient host(address.ToString(), deadline, kLiveChannel);
  LivePreparation done;
  v1::LoadConfigRequest load;
  load.set_config_xml(config_xml);
  load.set_source_name(source_name);
  host.Call(&v1::Host::Stub::LoadConfig, load, "LoadConfig " + source_name);
  const v1::GetInfoResponse info = host.Call(&v1::Host::Stub::GetInfo, Empty(), "GetInfo");
  done.backend = info.backend();
  if (!info.connected()) {
    const v1::ConnectRobotResponse connected =
        host.Call(&v1::Host::Stub::ConnectRobot, v1::ConnectRobotRequest(), "ConnectRobot");
    done.connected_now = true;
    done.links = static_cast<int>(connected.links());
  } else {
    host.Call(&v1::Host::Stub::Refresh, Empty(), "Refresh");
  }
  v1::ControlMessageRequest control;
  control.set_uart(v1::SWITCH_ON);
  control.set_cpg(v1::SWITCH_ON);
  control.set_motors(v1::SWITCH_ON);
  control.set_all(true);
  host.Call(&v1::Host::Stub::SendControlMessage, control, "SendControlMessage");
  return done;
}

struct LiveEvaluator::Impl {
  Impl(std::shared_ptr<grpc::Channel> channel_in, std::string name_in, LiveOptions options_in);

  std::vector<Evaluation> EvaluateBatch(const std::vector<Candidate>& batch);
  LiveMeasurement Measure(double periods);
  void Apply(const Candidate& candidate);
  void RequestStop();

  // One unary call under the option's deadline plus `extra` seconds;
  // RequestStop cancels it. Throws kCancelled once stopped, else the
  // client's error naming `what`.
  template <typename Request, typename Response>
  Response Call(HostClient::Unary<Request, Response> method, const Request& request,
                const std::string& what, double extra = 0.0);
  [[noreturn]] void ThrowStopped() const;

  // Checks the robot is connected and reads how time advances.
  TimeMode Prepare();
  double Elapsed();
  cpg::RobotConfig CurrentConfig();
  // Sets every parameter of `candidate` (validated first on a copy of the
  // daemon's configuration, so a refused candidate changes nothing) and
  // flushes; returns the configuration now on the robot. `index` names the
  // candidate in errors (-1: Apply).
  cpg::RobotConfig ApplyLocked(const Candidate& candidate, long long index);
  // Lets `seconds` of robot time pass.
  void Advance(double seconds, const TimeMode& mode);
  Sample Position();
  LiveMeasurement MeasureLocked(double period, double periods, const TimeMode& mode);
  void AddRobotSeconds(double seconds);

  const std::string name;
  const LiveOptions options;
  std::unique_ptr<HostClient> host;  // RequestStop cancels its calls

  std::mutex run_mu;  // one trial (or measurement) at a time: one robot
  std::mutex wake_mu;
  std::condition_variable wake;  // RequestStop wakes wall-clock waits
  std::atomic<bool> stop{false};
  std::atomic<bool> simulated{false};
  std::atomic<long long> trials{0};
  mutable std::mutex stats_mu;
  double robot_seconds = 0.0;  // guarded by stats_mu
};

LiveEvaluator::Impl::Impl(std::shared_ptr<grpc::Channel> channel_in, std::string name_in,
                          LiveOptions options_in)
    : name(std::move(name_in)), options(options_in) {
  CheckOption(options.settle_periods >= 0, "settle_periods", options.settle_periods, ">= 0");
  CheckOption(options.measure_periods > 0, "measure_periods", options.measure_periods, "> 0");
  CheckOption(options.sample_interval > 0, "sample_interval", options.sample_interval, "> 0");
  CheckOption(options.rpc_deadline > 0, "rpc_deadline", options.rpc_deadline, "> 0");
  CheckOption(options.max_period > 0, "max_period", options.max_period, "> 0");
  std::shared_ptr<grpc::Channel> channel = std::move(channel_in);
  if (!channel) throw Error(StatusCode::kInvalidArgument, "live evaluator without a channel");
  host = std::make_unique<HostClient>(std::move(channel), name, options.rpc_deadline);
  const v1::GetInfoResponse info = Call(&v1::Host::Stub::GetInfo, Empty(), "GetInfo");
  if (!info.connected()) {
    throw Error(StatusCode::kFailedPrecondition,
                "live robot " + name + " has no robot connected (backend " + info.backend() +
                    "; ConnectRobot first)");
  }
  simulated.store(Call(&v1::Host::Stub::SimulationModeEnabled, Empty(), "SimulationModeEnabled")
                      .enabled());
  Log().info("live evaluator: {} ({}, {})", name, info.backend(),
             simulated.load() ? "virtual time" : "real time");
}

template <typename Request, typename Response>
Response LiveEvaluator::Impl::Call(HostClient::Unary<Request, Response> method,
                                   const Request& request, const std::string& what, double extra) {
  if (stop.load()) ThrowStopped();
  try {
    return host->Call(method, request, what, {.deadline = options.rpc_deadline + extra});
  } catch (const Error&) {
    if (stop.load()) ThrowStopped();
    throw;
  }
}

void LiveEvaluator::Impl::ThrowStopped() const {
  throw Error(StatusCode::kCancelled, "live evaluation on " + name + " stopped");
}

void LiveEvaluator::Impl::RequestStop() {
  std::lock_guard lock(wake_mu);
  stop.store(true);
  host->Cancel();
  wake.notify_all();
}

TimeMode LiveEvaluator::Impl::Prepare() {
  const auto info = Call(&v1::Host::Stub::GetInfo, Empty(), "GetInfo");
  if (!info.connected()) {
    throw Error(StatusCode::kFailedPrecondition,
                "live robot " + name + " has no robot connected (ConnectRobot first)");
  }
  TimeMode mode;
  mode.simulated =
      Call(&v1::Host::Stub::SimulationModeEnabled, Empty(), "SimulationModeEnabled").enabled();
  mode.free_run = mode.simulated ? std::max(0.0, info.free_run_factor()) : 0.0;
  simulated.store(mode.simulated);
  return mode;
}

double LiveEvaluator::Impl::Elapsed() {
  return Call(&v1::Host::Stub::ElapsedTime, Empty(), "ElapsedTime").seconds();
}

cpg::RobotConfig LiveEvaluator::Impl::CurrentConfig() {
  const auto saved = Call(&v1::Host::Stub::SaveConfig, Empty(), "SaveConfig");
  return cpg::ParseConfigXml(saved.config_xml(), "configuration of live robot " + name);
}

cpg::RobotConfig LiveEvaluator::Impl::ApplyLocked(const Candidate& candidate, long long index) {
  const std::string which =
      (index >= 0 ? fmt::format("candidate {} ", index) : std::string("candidate ")) +
      FormatCandidate(candidate);
  const cpg::RobotConfig before = CurrentConfig();
  cpg::RobotConfig after = before;
  try {
    cpg::ApplyParameters(after, candidate.parameters);
  } catch (const Error& e) {
    throw Error(e.code(), "live robot " + name + ": " + which + ": " + e.what());
  }

  auto set = [&](const std::string& parameter, const cpg::ParameterName& parsed, double value) {
    const std::string what = which + ": parameter '" + parameter + "'";
    if (parsed.coupling) {
      v1::SetCouplingValueRequest request;
      request.set_from_id(static_cast<uint32_t>(parsed.from));
      request.set_to_id(static_cast<uint32_t>(parsed.to));
      request.set_value(value);
      Call(parsed.coupling_field == cpg::CouplingField::kPhase ? &v1::Host::Stub::SetCouplingPhase
                                                               : &v1::Host::Stub::SetCouplingWeight,
           request, what);
    } else {
      v1::SetModuleValueRequest request;
      request.set_module_id(static_cast<uint32_t>(parsed.id));
      request.set_value(value);
      auto method = &v1::Host::Stub::SetModuleAmplitude;
      switch (parsed.module_field) {
        case cpg::ModuleField::kAmplitude: method = &v1::Host::Stub::SetModuleAmplitude; break;
        case cpg::ModuleField::kOffset: method = &v1::Host::Stub::SetModuleOffset; break;
        case cpg::ModuleField::kSpeed: method = &v1::Host::Stub::SetModuleSpeed; break;
        case cpg::ModuleField::kMinAngle: method = &v1::Host::Stub::SetModuleMinAngle; break;
        case cpg::ModuleField::kMaxAngle: method = &v1::Host::Stub::SetModuleMaxAngle; break;
      }
      Call(method, request, what);
    }
  };

  // Oscillator and coupling values in the candidate's order; the limits of
  // each module last, in the order that never crosses min >= max on the way
  // (the daemon checks each setter against the other limit).
  struct Limits {
    std::optional<std::string> min_name;
    std::optional<std::string> max_name;
  };
  std::map<int, Limits> limits;
  for (const auto& [parameter, value] : candidate.parameters) {
    const cpg::ParameterName parsed = cpg::ParseParameterName(parameter);  // valid: applied above
    if (!parsed.coupling && parsed.module_field == cpg::ModuleField::kMinAngle) {
      limits[parsed.id].min_name = parameter;
    } else if (!parsed.coupling && parsed.module_field == cpg::ModuleField::kMaxAngle) {
      limits[parsed.id].max_name = parameter;
    } else {
      set(parameter, parsed, value);
    }
  }
  for (const auto& [id, names] : limits) {
    const cpg::ModuleParams& old_limits = *before.FindModule(id);
    const cpg::ModuleParams& new_limits = *after.FindModule(id);
    auto set_min = [&] {
      if (names.min_name) {
        set(*names.min_name, cpg::ParseParameterName(*names.min_name), new_limits.min_angle);
      }
    };
    auto set_max = [&] {
      if (names.max_name) {
        set(*names.max_name, cpg::ParseParameterName(*names.max_name), new_limits.max_angle);
      }
    };
    if (new_limits.min_angle >= old_limits.max_angle) {
      set_max();
      set_min();
    } else {
      set_min();
      set_max();
    }
  }
  Call(&v1::Host::Stub::Flush, Empty(), which + ": Flush");
  return after;
}

void LiveEvaluator::Impl::Advance(double seconds, const TimeMode& mode) {
  if (!(seconds > 0.0)) return;
  if (mode.Virtual()) {
    v1::SleepRequest request;
    request.set_seconds(seconds);
    Call(&v1::Host::Stub::Sleep, request, fmt::format("Sleep {} s", seconds), seconds);
    return;
  }
  // A real robot, or a simulation in free run: robot time passes with the clock.
  const double wall = seconds / mode.Rate();
  std::unique_lock lock(wake_mu);
  wake.wait_for(lock, std::chrono::duration<double>(wall), [this] { return stop.load(); });
  if (stop.load()) ThrowStopped();
}

Sample LiveEvaluator::Impl::Position() {
  const auto p = Call(&v1::Host::Stub::RobotPosition, Empty(), "RobotPosition");
  if (!std::isfinite(p.position().x()) || !std::isfinite(p.position().y()) ||
      !std::isfinite(p.time())) {
    throw Error(StatusCode::kUnavailable,
                "live robot " + name + " returned a non-finite position or time");
  }
  return Sample{.x = p.position().x(), .y = p.position().y(), .time = p.time(),
                .source = p.source()};
}

LiveMeasurement LiveEvaluator::Impl::MeasureLocked(double period, double periods,
                                                   const TimeMode& mode) {
  const double span = period * periods;
  const Sample first = Position();
  Sample last = first;
  int samples = 1;
  const double end = first.time + span;
  const Clock::time_point wall_start = Clock::now();
  // A real robot whose position time stops (a frozen tracker the daemon
  // still accepts) must not hold the run forever.
  const double wall_limit = mode.Virtual() ? 0.0 : 2.0 * span / mode.Rate() + 30.0;
  while (end - last.time > kTimeTolerance) {
    if (stop.load()) ThrowStopped();
    Advance(std::min(options.sample_interval, end - last.time), mode);
    const Sample next = Position();
    ++samples;
    const bool progressed = next.time > last.time;
    last = next;
    // Less than a physics step left: the world cannot step closer to the end.
    if (mode.Virtual() && !progressed) break;
    if (!mode.Virtual() && SecondsSince(wall_start) > wall_limit) {
      throw Error(StatusCode::kUnavailable,
                  fmt::format("live robot {}: robot time reached only {} s of the {} s "
                              "measurement after {} s of wall time",
                              name, last.time - first.time, span, SecondsSince(wall_start)));
    }
  }
  LiveMeasurement m;
  m.start_time = first.time;
  m.end_time = last.time;
  m.period = period;
  m.samples = samples;
  m.position_source = last.source;
  m.distance = std::hypot(last.x - first.x, last.y - first.y);
  const double measured = last.time - first.time;
  if (!(measured > 0.0)) {
    throw Error(StatusCode::kUnavailable,
                fmt::format("live robot {}: robot time did not advance during a {} s measurement",
                            name, span));
  }
  m.velocity = m.distance / measured;
  return m;
}

void LiveEvaluator::Impl::AddRobotSeconds(double seconds) {
  std::lock_guard lock(stats_mu);
  robot_seconds += std::max(0.0, seconds);
}

std::vector<Evaluation> LiveEvaluator::Impl::EvaluateBatch(const std::vector<Candidate>& batch) {
  std::lock_guard run(run_mu);
  if (stop.load()) ThrowStopped();
  std::vector<Evaluation> results;
  results.reserve(batch.size());
  for (std::size_t i = 0; i < batch.size(); ++i) {
    const Clock::time_point wall_start = Clock::now();
    const TimeMode mode = Prepare();
    const double begin = Elapsed();
    const cpg::RobotConfig config = ApplyLocked(batch[i], static_cast<long long>(i));
    const double period = PeriodOf(config, options.max_period);
    Advance(options.settle_periods * period, mode);
    const LiveMeasurement m = MeasureLocked(period, options.measure_periods, mode);
    const double spent = Elapsed() - begin;
    AddRobotSeconds(spent);
    trials.fetch_add(1);
    Evaluation e;
    e.velocity = m.velocity;
    e.distance = m.distance;
    e.host = name;
    e.wall_seconds = SecondsSince(wall_start);
    e.robot_seconds = std::max(0.0, spent);
    Log().debug("live {} candidate {}: {:.4f} m/s over {} samples ({} s period, {} s robot time)",
                name, i, m.velocity, m.samples, period, spent);
    results.push_back(std::move(e));
  }
  return results;
}

LiveMeasurement LiveEvaluator::Impl::Measure(double periods) {
  if (periods == 0.0) periods = options.measure_periods;
  CheckOption(periods > 0, "periods", periods, "> 0");
  std::lock_guard run(run_mu);
  if (stop.load()) ThrowStopped();
  const TimeMode mode = Prepare();
  const double begin = Elapsed();
  const LiveMeasurement m = MeasureLocked(PeriodOf(CurrentConfig(), options.max_period), periods, mode);
  AddRobotSeconds(Elapsed() - begin);
  return m;
}

void LiveEvaluator::Impl::Apply(const Candidate& candidate) {
  std::lock_guard run(run_mu);
  if (stop.load()) ThrowStopped();
  Prepare();
  ApplyLocked(candidate, -1);
}

// ---- LiveEvaluator ---------------------------------------------------------------

LiveEvaluator::LiveEvaluator(const HostAddress& address, LiveOptions options)
    : LiveEvaluator(client::MakeChannel(address.ToString(), kLiveChannel), address.ToString(),
                    options) {}

LiveEvaluator::LiveEvaluator(std::shared_ptr<grpc::Channel> channel, std::string name,
                             LiveOptions options)
    : impl_(std::make_unique<Impl>(std::move(channel), std::move(name), options)) {}

LiveEvaluator::~LiveEvaluator() = default;

std::vector<Evaluation> LiveEvaluator::EvaluateBatch(const std::vector<Candidate>& batch) {
  return impl_->EvaluateBatch(batch);
}

void LiveEvaluator::RequestStop() { impl_->RequestStop(); }

LiveMeasurement LiveEvaluator::Measure(double periods) { return impl_->Measure(periods); }

void LiveEvaluator::Apply(const Candidate& candidate) { impl_->Apply(candidate); }

bool LiveEvaluator::Simulated() const { return impl_->simulated.load(); }

long long LiveEvaluator::Trials() const { return impl_->trials.load(); }

double LiveEvaluator::RobotSeconds() const {
  std::lock_guard lock(impl_->stats_mu);
  return impl_->robot_seconds;
}

}  // namespace yamor::optimizer
