#include "host/evaluator.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

#include "bridge/robot.h"
#include "common/log.h"
#include "common/status.h"
#include "cpg/parameters.h"
#include "host/sim_backend.h"
#include "physics/world.h"

namespace yamor::host {

using cpg::ApplyParameters;
namespace {

using snp::Address;

constexpr double kMaxEvaluatedTime = 3600.0;  // simulated seconds per evaluation
constexpr std::size_t kMaxTrajectorySamples = 100000;
constexpr double kChunk = 0.1;  // simulated seconds between cancellation checks
constexpr double kMinTimeStep = 1e-5;
constexpr double kMaxTimeStep = 0.02;
constexpr int64_t kMaxSteps = 20'000'000;  // bounds the work one request can ask for

std::string Num(double v) {
  std::ostringstream out;
  out << v;
  return out.str();
}

void CheckTiming(double value, std::string_view what, bool allow_zero) {
  if (!std::isfinite(value)) {
    throw Error(StatusCode::kInvalidArgument, std::string(what) + " is not finite: " + Num(value));
  }
  if (value < 0.0 || (!allow_zero && value == 0.0) || value > kMaxEvaluatedTime) {
    throw Error(StatusCode::kOutOfRange, std::string(what) + " " + Num(value) + " s is outside " +
                                             (allow_zero ? "[0, " : "(0, ") +
                                             Num(kMaxEvaluatedTime) + "]");
  }
}

// The configuration with every id translated to simulation ids.
cpg::RobotConfig ToSimulationIds(const cpg::RobotConfig& config, const IdMap& map) {
  cpg::RobotConfig out;
  for (cpg::ModuleParams m : config.modules) {
    m.id = map.ToSim(m.id);
    out.modules.push_back(m);
  }
  for (cpg::Coupling c : config.couplings) {
    c.from = map.ToSim(c.from);
    c.to = map.ToSim(c.to);
    out.couplings.push_back(c);
  }
  for (const auto& [child, parent] : config.bluetooth_parent) {
    out.bluetooth_parent[map.ToSim(child)] = map.ToSim(parent);
  }
  out.master_id = map.ToSim(config.master_id);
  return out;
}

// Runs the emulated robot through SNP frames, as the driver would.
class Session {
 public:
  Session(const physics::Morphology& morphology, const bridge::RobotOptions& options)
      : backend_(morphology, options) {}

  // Sends a configuration frame and checks its reply.
  void Configure(const snp::Frame& frame) {
    backend_.Send(frame);
    bool answered = false;
    while (std::optional<snp::Frame> reply = backend_.Receive(std::chrono::milliseconds(0))) {
      answered = true;
      const snp::Message m = snp::DecodeMessage(*reply);
      if (const auto* ack = std::get_if<snp::Ack>(&m); ack && ack->status != StatusCode::kOk) {
        throw Error(ack->status, "module " + std::to_string(reply->source.id) + " refused " +
                                     std::string(snp::MessageTypeName(ack->acked)) + " (" +
                                     std::string(StatusCodeName(ack->status)) + ")");
      }
      if (const auto* ack = std::get_if<snp::ConnectAck>(&m);
          ack && ack->status != snp::LinkStatus::kUp) {
        throw Error(StatusCode::kInvalidArgument,
                    "bluetooth link " + std::to_string(reply->source.id) + " -> " +
                        std::to_string(ack->child) + " failed");
      }
    }
    if (!answered) {
      throw Error(StatusCode::kUnavailable, "module " + std::to_string(frame.destination.id) +
                                                " did not answer " +
                                                std::string(snp::MessageTypeName(frame.type)));
    }
  }

  // Advances by `steps` physics steps; false when the world diverged.
  bool Step(int64_t steps, double time_step) {
    backend_.Send(snp::MakeFrame(Address::Host(), Address::Bridge(),
                                 snp::Step{.duration = static_cast<double>(steps) * time_step}));
    std::optional<snp::Frame> reply = backend_.Receive(std::chrono::milliseconds(0));
    if (world().Diverged()) return false;
    if (!reply) throw Error(StatusCode::kInternal, "the simulation did not answer Step");
    const snp::Message m = snp::DecodeMessage(*reply);
    if (const auto* error = std::get_if<snp::SpecialError>(&m)) {
      throw Error(error->code, "Step failed: " + error->text);
    }
    return true;
  }

  RobotPose Position() {
    backend_.Send(snp::MakeFrame(Address::Host(), Address::Bridge(), snp::GetRobotPosition{}));
    std::optional<snp::Frame> reply = backend_.Receive(std::chrono::milliseconds(0));
    if (!reply) throw Error(StatusCode::kInternal, "the simulation did not answer GetRobotPosition");
    const snp::Message m = snp::DecodeMessage(*reply);
    if (const auto* error = std::get_if<snp::SpecialError>(&m)) {
      throw Error(error->code, "GetRobotPosition failed: " + error->text);
    }
    const auto& p = std::get<snp::RobotPosition>(m);
    return RobotPose{.time = p.time, .position = p.position, .orientation = p.orientation,
                     .source = "simulation"};
  }

  const physics::World& world() { return backend_.SimulatedRobot()->world(); }

 private:
  SimBackend backend_;
};

}  // namespace

EvaluationResult RunEvaluation(const EvaluationSpec& spec, const CancelCheck& cancel) {
  const auto wall_start = std::chrono::steady_clock::now();
  CheckTiming(spec.warmup, "warm-up", /*allow_zero=*/true);
  CheckTiming(spec.duration, "duration", /*allow_zero=*/false);
  CheckTiming(spec.warmup + spec.duration, "warm-up + duration", false);
  if (!std::isfinite(spec.trajectory_period)) {
    throw Error(StatusCode::kInvalidArgument, "trajectory period is not finite");
  }
  if (spec.trajectory_period < 0.0) {
    throw Error(StatusCode::kOutOfRange,
                "trajectory period " + Num(spec.trajectory_period) + " s is negative");
  }
  const double time_step =
      spec.time_step == 0.0 ? physics::WorldOptions().time_step : spec.time_step;
  if (!std::isfinite(time_step)) {
    throw Error(StatusCode::kInvalidArgument, "time step is not finite: " + Num(time_step));
  }
  if (time_step < kMinTimeStep || time_step > kMaxTimeStep) {
    throw Error(StatusCode::kOutOfRange, "time step " + Num(time_step) + " s is outside [" +
                                             Num(kMinTimeStep) + ", " + Num(kMaxTimeStep) + "]");
  }
  auto steps_of = [&](double seconds) { return std::llround(seconds / time_step); };
  const int64_t warm_steps = steps_of(spec.warmup);
  const int64_t end_steps = steps_of(spec.warmup + spec.duration);
  if (end_steps > kMaxSteps) {
    throw Error(StatusCode::kOutOfRange,
                "warm-up + duration of " + Num(spec.warmup + spec.duration) + " s at a step of " +
                    Num(time_step) + " s is more than " + std::to_string(kMaxSteps) + " steps");
  }
  const int64_t sample_every =
      spec.trajectory_period > 0.0 ? std::max<int64_t>(1, steps_of(spec.trajectory_period)) : 0;
  if (sample_every > 0 && static_cast<std::size_t>(end_steps / sample_every) > kMaxTrajectorySamples) {
    throw Error(StatusCode::kOutOfRange,
                "trajectory period " + Num(spec.trajectory_period) + " s gives more than " +
                    std::to_string(kMaxTrajectorySamples) + " samples");
  }

  cpg::RobotConfig config = spec.config;
  ApplyParameters(config, spec.parameters);
  cpg::Validate(config);
  std::vector<int> ids;
  for (const cpg::ModuleParams& m : config.modules) ids.push_back(m.id);
  spec.id_map.CheckInjective(ids);
  const cpg::RobotConfig wire = ToSimulationIds(config, spec.id_map);
  for (const cpg::ModuleParams& m : wire.modules) {
    if (!spec.morphology.Contains(m.id) || spec.morphology.Module(m.id).free) {
      throw Error(StatusCode::kInvalidArgument,
                  "module " + std::to_string(spec.id_map.ToReal(m.id)) +
                      " of the configuration is not part of world " + spec.morphology.source());
    }
  }

  bridge::RobotOptions options;
  options.world.time_step = time_step;
  options.world.seed = spec.seed;
  options.phase_seed = spec.seed;
  options.master = wire.master_id;
  Session session(spec.morphology, options);
  for (const snp::Frame& frame : bridge::ConfigurationFrames(wire)) session.Configure(frame);

  EvaluationResult result;
  const int64_t chunk = std::max<int64_t>(1, steps_of(kChunk));
  RobotPose start_pose = session.Position();
  result.final_pose = start_pose;
  if (sample_every > 0) result.trajectory.push_back({start_pose.time, start_pose.position});
  int64_t step = 0;
  while (step < end_steps) {
    if (cancel && cancel()) {
      throw Error(StatusCode::kCancelled,
                  "evaluation cancelled at t = " + Num(static_cast<double>(step) * time_step) + " s");
    }
    int64_t next = std::min(end_steps, step + chunk);
    if (step < warm_steps) next = std::min(next, warm_steps);
    if (sample_every > 0) next = std::min(next, (step / sample_every + 1) * sample_every);
    if (!session.Step(next - step, time_step)) {
      const physics::DivergenceInfo& info = session.world().Divergence();
      result.diverged = true;
      result.divergence = info.reason + " at t = " + Num(session.world().Time()) + " s";
      result.velocity = 0.0;
      result.distance = 0.0;
      Log().info("evaluate: world diverged: {}", result.divergence);
      break;
    }
    step = next;
    const bool at_warmup = step == warm_steps;
    const bool at_sample = sample_every > 0 && step % sample_every == 0;
    if (at_warmup || at_sample || step == end_steps) {
      const RobotPose pose = session.Position();
      result.final_pose = pose;
      if (at_warmup) start_pose = pose;
      if (at_sample) result.trajectory.push_back({pose.time, pose.position});
    }
  }
  if (!result.diverged) {
    const double dx = result.final_pose.position[0] - start_pose.position[0];
    const double dy = result.final_pose.position[1] - start_pose.position[1];
    result.distance = std::hypot(dx, dy);
    result.velocity = result.distance / spec.duration;
  }
  result.wall_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return result;
}

// ---- WorkerPool -------------------------------------------------------------------

WorkerPool::WorkerPool(unsigned workers) {
  if (workers == 0) workers = std::max(1u, std::thread::hardware_concurrency());
  for (unsigned i = 0; i < workers; ++i) threads_.emplace_back([this] { WorkerLoop(); });
}

WorkerPool::~WorkerPool() { Shutdown(); }

void WorkerPool::Enqueue(std::function<void()> job) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_) throw Error(StatusCode::kUnavailable, "the evaluation pool is shutting down");
    jobs_.push_back(std::move(job));
  }
  cv_.notify_one();
}

std::size_t WorkerPool::queued() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return jobs_.size();
}

bool WorkerPool::stopping() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stopping_;
}

void WorkerPool::Shutdown() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  cv_.notify_all();
  for (std::thread& t : threads_) {
    if (t.joinable() && t.get_id() != std::this_thread::get_id()) t.join();
  }
}

void WorkerPool::WorkerLoop() {
  while (true) {
    std::function<void()> job;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      cv_.wait(lock, [this] { return stopping_ || !jobs_.empty(); });
      if (jobs_.empty()) return;  // stopping and drained
      job = std::move(jobs_.front());
      jobs_.pop_front();
    }
    job();  // packaged_task stores exceptions in the future
  }
}

}  // namespace yamor::host
