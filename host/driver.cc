#include "host/driver.h"

#include <thread>

#include <algorithm>
#include <cmath>
#include <sstream>

#include <Eigen/Core>

#include "common/format.h"
#include "common/log.h"
#include "common/status.h"
#include "cpg/config_xml.h"
#include "host/config_frames.h"
#include "host/sim_factory.h"
#include "physics/orientation.h"
#include "physics/render/snapshot.h"
#include "physics/script.h"

namespace yamor::host {

using cpg::GetCouplingField;
using cpg::GetModuleField;
using cpg::SetCouplingField;
using cpg::SetModuleField;
namespace {

using snp::Address;
using Clock = std::chrono::steady_clock;

// Scripts come with physics connector ids; the wire uses SNP's: same numbering.
static_assert(static_cast<int>(physics::ConnectorId::kFront) == static_cast<int>(snp::Connector::kFront) &&
              static_cast<int>(physics::ConnectorId::kRear) == static_cast<int>(snp::Connector::kRear) &&
              static_cast<int>(physics::ConnectorId::kLeft) == static_cast<int>(snp::Connector::kLeft) &&
              static_cast<int>(physics::ConnectorId::kRight) == static_cast<int>(snp::Connector::kRight) &&
              static_cast<int>(physics::ConnectorId::kTop) == static_cast<int>(snp::Connector::kTop) &&
              static_cast<int>(physics::ConnectorId::kBottom) == static_cast<int>(snp::Connector::kBottom));

constexpr double kMinTimeStep = 1e-5;
constexpr double kMaxTimeStep = 0.02;
constexpr double kMaxLinkTimeout = 120.0;

std::string Id(int id) { return std::to_string(id); }

double SecondsSince(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

[[noreturn]] void ThrowShutdown(std::string_view what) {
  throw Error(StatusCode::kUnavailable, std::string(what) + " interrupted: yamord is shutting down");
}

std::string_view DefectName(MotorDefect defect) {
  switch (defect) {
    case MotorDefect::kLimp: return "limp";
    case MotorDefect::kStuck: return "stuck";
    case MotorDefect::kNone: break;
  }
  return "ok";
}

}  // namespace

int RobotDriver::PendingModule::Count() const {
  return ((amplitude || offset || speed) ? 1 : 0) + (limits ? 1 : 0) + (clear_couplings ? 1 : 0) +
         static_cast<int>(couplings.size());
}

RobotDriver::RobotDriver(DriverOptions options, cpg::RobotConfig config)
    : options_(std::move(options)), config_(std::move(config)) {
  cpg::Validate(config_);
  if (!(options_.sleep_chunk > 0.0) || !std::isfinite(options_.sleep_chunk)) {
    throw Error(StatusCode::kInvalidArgument, "sleep chunk must be finite and > 0");
  }
  if (!(options_.link_timeout > 0.0) || !(options_.reply_timeout > 0.0)) {
    throw Error(StatusCode::kInvalidArgument, "link and reply timeouts must be > 0");
  }
  std::vector<int> ids;
  for (const auto& m : config_.modules) ids.push_back(m.id);
  options_.id_map.CheckInjective(ids);
  if (options_.position_from_tracker && !options_.tracker) {
    throw Error(StatusCode::kInvalidArgument,
                "the tracker as position source needs a tracker (--led-tracker HOST:PORT)");
  }
  if (options_.tracker) {
    options_.tracker->SetHandler([this](const TrackedPose& pose) { OnTrackedPose(pose); });
  }
}

RobotDriver::~RobotDriver() {
  if (options_.tracker) options_.tracker->SetHandler(nullptr);  // no call in flight after this
  Shutdown();
  if (free_run_thread_.joinable()) free_run_thread_.join();
}

// ---- Helpers -----------------------------------------------------------------

Backend& RobotDriver::RequireBackendLocked(std::string_view what) const {
  if (shutdown_) ThrowShutdown(what);
  if (!backend_) {
    throw Error(StatusCode::kFailedPrecondition,
                "no simulation open: call OpenSimulation first (needed by " + std::string(what) +
                    ")");
  }
  return *backend_;
}

SnpLink& RobotDriver::RequireSimulationLocked(std::string_view what) const {
  Backend& backend = RequireBackendLocked(what);
  if (!backend.IsSimulation()) {
    // A real robot answers no bridge specials (docs/snp.md): what only a
    // simulation can do is done by hand on the real one.
    throw Error(StatusCode::kUnimplemented,
                std::string(what) + " needs a simulated robot; the " + backend.Name() +
                    " backend drives a real robot (the real robot needs manual assembly)");
  }
  return *link_;
}

void RobotDriver::RequireConnectedLocked(std::string_view what) const {
  if (!connected_) {
    throw Error(StatusCode::kFailedPrecondition,
                "robot not connected: call ConnectRobot first (needed by " + std::string(what) +
                    ")");
  }
}

snp::Message RobotDriver::ModuleCallLocked(int id, const snp::Message& message,
                                           snp::MessageType reply) {
  return link_->ModuleCall(id, message, reply);
}

snp::Message RobotDriver::BridgeRequestLocked(const snp::Message& message,
                                              snp::MessageType reply) {
  return link_->BridgeRequest(message, reply);
}

void RobotDriver::InstallBackendLocked(std::unique_ptr<Backend> backend) {
  link_.reset();
  backend_ = std::move(backend);
  link_ = std::make_unique<SnpLink>(*backend_, options_.id_map,
                                    SnpLinkOptions{.reply_timeout = options_.reply_timeout});
  link_->SetReopenedHandler([this] { OnLinkReopenedLocked(); });  // called with mutex_ held
}

void RobotDriver::ReadSimInfoLocked() {
  // What the simulation is, asked over the link like everything else.
  const snp::Message m = BridgeRequestLocked(snp::GetSimInfo{}, snp::MessageType::kSimInfo);
  const auto& info = std::get<snp::SimInfo>(m);
  time_step_ = info.time_step;
  accelerometer_zero_ = info.accelerometer_zero;
  accelerometer_count_ = info.accelerometer_count;
}

void RobotDriver::OnLinkReopenedLocked() {
  if (connected_) relink_needed_ = true;
  connected_ = false;
  diverged_ = false;  // a restarted bridge has a fresh world
  divergence_.clear();
  PushEvent(StateEvent{.kind = "link_reopened",
                       .detail = backend_->Name() + " link reopened; the robot may have restarted"});
}

void RobotDriver::CheckDivergedLocked() {
  if (diverged_) {
    throw Error(StatusCode::kFailedPrecondition,
                "world diverged (" + divergence_ + "): call ResetSimulation or OpenSimulation");
  }
}

void RobotDriver::QueryDivergenceLocked() {
  if (!backend_ || !backend_->IsSimulation()) return;
  const snp::Message m = BridgeRequestLocked(snp::GetDivergence{}, snp::MessageType::kDivergence);
  const auto& info = std::get<snp::Divergence>(m);
  if (!info.diverged) return;
  diverged_ = true;
  divergence_ = info.reason + " at t = " + FormatRounded(info.time) + " s";
  PushEvent(StateEvent{.kind = "diverged",
                       .module_id = info.module != snp::kNoModule ? link_->Real(info.module) : -1,
                       .detail = divergence_});
  throw Error(StatusCode::kFailedPrecondition,
              "world diverged (" + divergence_ + "): call ResetSimulation or OpenSimulation");
}

void RobotDriver::StepLocked(double seconds) {
  CheckDivergedLocked();
  try {
    const snp::Message m = BridgeRequestLocked(snp::Step{.duration = seconds},
                                               snp::MessageType::kStepDone);
    SetSimTimeLocked(std::get<snp::StepDone>(m).time);
  } catch (const Error& e) {
    // The bridge refuses a Step into a diverged world: ask where and why.
    if (e.code() == StatusCode::kFailedPrecondition) QueryDivergenceLocked();
    throw;
  }
  if (state_.Watched()) RecordSampleLocked();
}

void RobotDriver::RecordSampleLocked() {
  // With the tracker as the source, its samples feed WatchState (OnTrackedPose).
  if (tracker_feed_.load() != kTrackerFeedNone) return;
  try {
    state_.RecordSample(SimulatedPoseLocked());
  } catch (const Error& e) {
    Log().debug("driver: no state sample: {}", e.what());
  }
}

RobotPose RobotDriver::SimulatedPoseLocked() {
  const snp::Message m =
      BridgeRequestLocked(snp::GetRobotPosition{}, snp::MessageType::kRobotPosition);
  const auto& p = std::get<snp::RobotPosition>(m);
  sim_clock_.store(p.time);  // a free-running bridge advances on its own
  return RobotPose{.time = p.time, .position = p.position, .orientation = p.orientation,
                   .source = "simulation"};
}

void RobotDriver::SetSimTimeLocked(double seconds) {
  sim_time_ = seconds;
  sim_clock_.store(seconds);
}

void RobotDriver::UpdateTrackerFeedLocked() {
  int feed = kTrackerFeedNone;
  if (options_.tracker && backend_) {
    if (!backend_->IsSimulation()) feed = kTrackerFeedReal;
    else if (options_.position_from_tracker) feed = kTrackerFeedSim;
  }
  tracker_epoch_.store(attached_at_.time_since_epoch().count());
  tracker_feed_.store(feed);
}

void RobotDriver::OnTrackedPose(const TrackedPose& tracked) {
  if (!state_.Watched()) return;
  RobotPose pose{.position = tracked.position, .source = "led-tracker"};
  switch (tracker_feed_.load()) {
    case kTrackerFeedReal:
      pose.time = std::chrono::duration<double>(
                      tracked.arrival - Clock::time_point(Clock::duration(tracker_epoch_.load())))
                      .count();
      break;
    case kTrackerFeedSim:
      // A frame from after the present simulation time is from before a reset.
      if (tracked.camera_time > sim_clock_.load() + 1e-6) return;
      pose.time = tracked.camera_time;
      break;
    default:
      return;
  }
  state_.RecordSample(pose);
}

void RobotDriver::CheckConfigAgainstWorldLocked(const cpg::RobotConfig& config,
                                                const physics::Morphology& morphology,
                                                const physics::Morphology* now) const {
  std::vector<int> ids;
  for (const cpg::ModuleParams& m : config.modules) ids.push_back(m.id);
  options_.id_map.CheckInjective(ids);
  for (const cpg::ModuleParams& m : config.modules) {
    const int sim = options_.id_map.ToSim(m.id);
    const bool attached = now != nullptr && now->Contains(sim) && !now->Module(sim).free;
    if (!attached && (!morphology.Contains(sim) || morphology.Module(sim).free)) {
      throw Error(StatusCode::kInvalidArgument,
                  "module " + Id(m.id) + " of the configuration" +
                      (sim != m.id ? " (simulation id " + Id(sim) + ")" : std::string()) +
                      (morphology.Contains(sim) ? " is a free module of world "
                                                : " is not in world ") +
                      morphology.source());
    }
  }
}

void RobotDriver::ResetRobotStateLocked() {
  connected_ = false;
  relink_needed_ = false;
  control_state_.clear();
  diverged_ = false;
  divergence_.clear();
  SetSimTimeLocked(0.0);
  motor_defects_.clear();
  module_defects_.clear();
  slope_ = 0.0;
  slope_direction_ = 0.0;
  pending_.clear();
}

void RobotDriver::MarkAllPendingLocked() {
  pending_.clear();
  for (const cpg::ModuleParams& m : config_.modules) {
    PendingModule& p = pending_[m.id];
    p.amplitude = p.offset = p.speed = p.limits = p.clear_couplings = true;
  }
  for (const cpg::Coupling& c : config_.couplings) pending_[c.from].couplings.insert(c.to);
}

// ---- Backend -------------------------------------------------------------------

OpenedSimulation RobotDriver::OpenSimulation(SimulationSpec spec) {
  double time_step = spec.time_step == 0.0 ? DefaultSimulationTimeStep() : spec.time_step;
  if (!std::isfinite(time_step)) {
    throw Error(StatusCode::kInvalidArgument, "time step is not finite: " + FormatRounded(time_step));
  }
  if (time_step < kMinTimeStep || time_step > kMaxTimeStep) {
    throw Error(StatusCode::kOutOfRange, "time step " + FormatRounded(time_step) + " s is outside [" +
                                             FormatRounded(kMinTimeStep) + ", " + FormatRounded(kMaxTimeStep) + "]");
  }
  Lock lock(mutex_);
  if (shutdown_) ThrowShutdown("OpenSimulation");
  cpg::RobotConfig config = spec.config ? *spec.config : config_;
  CheckConfigAgainstWorldLocked(config, spec.morphology);
  if (options_.master && !spec.morphology.Contains(options_.id_map.ToSim(*options_.master))) {
    throw Error(StatusCode::kInvalidArgument, "the master node setting " + Id(*options_.master) +
                                                  " is not a module of world " +
                                                  spec.morphology.source());
  }
  OpenedSimulation opened;
  for (const physics::MorphologyModule& m : spec.morphology.modules()) {
    opened.module_ids.push_back(options_.id_map.ToReal(m.id));
  }
  std::sort(opened.module_ids.begin(), opened.module_ids.end(), [this](int a, int b) {
    return options_.id_map.ToSim(a) < options_.id_map.ToSim(b);
  });
  opened.central_module = options_.id_map.ToReal(spec.morphology.central());
  const SimulationOptions sim_options{
      .time_step = time_step,
      .seed = spec.seed,
      .master = options_.id_map.ToSim(options_.master.value_or(config.master_id))};
  world_morphology_ = spec.morphology;
  std::unique_ptr<Backend> backend = MakeSimBackend(std::move(spec.morphology), sim_options);
  if (options_.backend_wrapper) {
    backend = options_.backend_wrapper(
        std::move(backend), {{"backend", "simulation"},
                             {"world", spec.world_name},
                             {"seed", std::to_string(spec.seed)},
                             {"time_step", FormatDouble(time_step)},
                             {"master", std::to_string(sim_options.master)},
                             {"morphology", world_morphology_->ToXml()}});
  }
  InstallBackendLocked(std::move(backend));
  ReadSimInfoLocked();
  config_ = std::move(config);
  world_name_ = spec.world_name;
  ResetRobotStateLocked();
  time_step_ = time_step;
  attached_at_ = Clock::now();
  UpdateTrackerFeedLocked();
  PushEvent(StateEvent{.kind = "opened", .detail = world_name_});
  if (state_.Watched()) RecordSampleLocked();
  wake_.notify_all();
  return opened;
}

void RobotDriver::AttachBackend(std::unique_ptr<Backend> backend, std::string world_name) {
  YAMOR_CHECK(backend != nullptr, "AttachBackend needs a backend");
  if (options_.backend_wrapper) {
    backend = options_.backend_wrapper(std::move(backend), {{"world", world_name}});
  }
  Lock lock(mutex_);
  InstallBackendLocked(std::move(backend));
  world_name_ = std::move(world_name);
  ResetRobotStateLocked();
  world_morphology_.reset();
  time_step_ = DefaultSimulationTimeStep();
  accelerometer_zero_ = 512.0;
  accelerometer_count_ = 0.0395;
  if (backend_->IsSimulation()) {
    ReadSimInfoLocked();
    try {
      world_morphology_ = physics::Morphology::Parse(link_->ReadMorphologyXml(), world_name_);
    } catch (const Error& e) {
      if (e.code() != StatusCode::kUnimplemented) throw;
      // A peer without morphology readback: configurations are not checked
      // against its world, and GetMorphology says why it cannot answer.
      Log().warn("driver: the {} backend cannot read its morphology back: {}", backend_->Name(),
                 e.what());
    }
  }
  attached_at_ = Clock::now();
  UpdateTrackerFeedLocked();
  PushEvent(StateEvent{.kind = "opened", .detail = world_name_});
}

void RobotDriver::CloseSimulation() {
  Lock lock(mutex_);
  if (!backend_) return;
  link_.reset();
  backend_.reset();
  world_morphology_.reset();
  world_name_.clear();
  ResetRobotStateLocked();
  UpdateTrackerFeedLocked();
  PushEvent(StateEvent{.kind = "closed"});
}

bool RobotDriver::SimulationModeEnabled() const {
  Lock lock(mutex_);
  return backend_ && backend_->IsSimulation();
}

void RobotDriver::ResetSimulation() {
  Lock lock(mutex_);
  Backend& backend = RequireBackendLocked("ResetSimulation");
  if (backend.IsSimulation()) {
    // Defects survive a reset of the world (they are hardware): repair them.
    for (int id : module_defects_) {
      BridgeRequestLocked(snp::SetModuleDefect{.module = static_cast<uint8_t>(id), .defective = false},
                          snp::MessageType::kSpecialAck);
    }
  }
  BridgeRequestLocked(snp::ResetSimulation{}, snp::MessageType::kSpecialAck);
  ResetRobotStateLocked();
  PushEvent(StateEvent{.kind = "reset"});
  if (state_.Watched()) RecordSampleLocked();
}

physics::Morphology RobotDriver::GetMorphology() const {
  Lock lock(mutex_);
  SnpLink& link = RequireSimulationLocked("GetMorphology");
  const std::string source =
      world_morphology_ ? world_morphology_->source() : world_name_;
  return physics::Morphology::Parse(link.ReadMorphologyXml(), source);
}

render::Scene RobotDriver::GetScene() {
  Lock lock(mutex_);
  SnpLink& link = RequireSimulationLocked("GetScene");
  CheckDivergedLocked();
  const snp::SceneSnapshot snapshot = link.ReadScene();
  return render::FromSnapshot(snapshot, [&link](int wire) { return link.Real(wire); });
}

// ---- Configuration ---------------------------------------------------------------

void RobotDriver::LoadConfig(std::string_view xml, std::string_view source_name) {
  cpg::RobotConfig config =
      cpg::ParseConfigXml(xml, source_name.empty() ? "<request>" : source_name);
  Lock lock(mutex_);
  if (backend_ && world_morphology_) {
    // A spare of the world attached since it opened (ConnectModules, a
    // script) may be configured too: then the body as it is now is asked.
    bool spare = false;
    for (const cpg::ModuleParams& m : config.modules) {
      const int sim = options_.id_map.ToSim(m.id);
      spare = spare || (world_morphology_->Contains(sim) && world_morphology_->Module(sim).free);
    }
    std::optional<physics::Morphology> now;
    if (spare && backend_->IsSimulation()) {
      now = physics::Morphology::Parse(link_->ReadMorphologyXml(), world_morphology_->source());
    }
    CheckConfigAgainstWorldLocked(config, *world_morphology_, now ? &*now : nullptr);
  } else {
    std::vector<int> ids;
    for (const cpg::ModuleParams& m : config.modules) ids.push_back(m.id);
    options_.id_map.CheckInjective(ids);
  }
  if (config.bluetooth_parent != config_.bluetooth_parent || config.master_id != config_.master_id) {
    connected_ = false;  // the network to build is another one
  }
  config_ = std::move(config);
  MarkAllPendingLocked();
  PushEvent(StateEvent{.kind = "config_loaded", .detail = std::string(source_name)});
}

std::string RobotDriver::SaveConfig() const {
  Lock lock(mutex_);
  return cpg::WriteConfigXml(config_);
}

cpg::RobotConfig RobotDriver::Config() const {
  Lock lock(mutex_);
  return config_;
}

std::vector<int> RobotDriver::GetAllModulesId() const {
  Lock lock(mutex_);
  std::vector<int> ids;
  for (const cpg::ModuleParams& m : config_.modules) ids.push_back(m.id);
  return ids;
}

double RobotDriver::GetModuleValue(int id, ModuleField field) const {
  Lock lock(mutex_);
  return GetModuleField(config_, id, field);
}

void RobotDriver::SetModuleValue(int id, ModuleField field, double value) {
  Lock lock(mutex_);
  SetModuleField(config_, id, field, value);
  PendingModule& p = pending_[id];
  switch (field) {
    case ModuleField::kAmplitude: p.amplitude = true; break;
    case ModuleField::kOffset: p.offset = true; break;
    case ModuleField::kSpeed: p.speed = true; break;
    case ModuleField::kMinAngle:
    case ModuleField::kMaxAngle: p.limits = true; break;
  }
}

double RobotDriver::GetCouplingValue(int from, int to, CouplingField field) const {
  Lock lock(mutex_);
  return GetCouplingField(config_, from, to, field);
}

void RobotDriver::SetCouplingValue(int from, int to, CouplingField field, double value) {
  Lock lock(mutex_);
  SetCouplingField(config_, from, to, field, value);
  pending_[from].couplings.insert(to);
}

void RobotDriver::AddCoupling(int from, int to, double phase, double weight) {
  Lock lock(mutex_);
  cpg::AddCoupling(config_, from, to, phase, weight);
  pending_[from].couplings.insert(to);
}

void RobotDriver::RemoveAllCouplings() {
  Lock lock(mutex_);
  config_.couplings.clear();
  for (const cpg::ModuleParams& m : config_.modules) {
    PendingModule& p = pending_[m.id];
    p.clear_couplings = true;
    p.couplings.clear();
  }
}

int RobotDriver::PendingChanges() const {
  Lock lock(mutex_);
  int n = 0;
  for (const auto& [id, p] : pending_) n += p.Count();
  return n;
}

// ---- Robot ------------------------------------------------------------------------

int RobotDriver::SendModuleConfigLocked(const cpg::ModuleParams& m, const PendingModule* only) {
  int frames = 0;
  const bool amplitude = !only || only->amplitude;
  const bool offset = !only || only->offset;
  const bool speed = !only || only->speed;
  if (amplitude || offset || speed) {
    snp::SetOscillator oscillator;
    if (amplitude) oscillator.amplitude = static_cast<float>(m.amplitude);
    if (offset) oscillator.offset = static_cast<float>(m.offset);
    if (speed) oscillator.speed = static_cast<float>(m.speed);
    ModuleCallLocked(m.id, oscillator, snp::MessageType::kAck);
    ++frames;
  }
  if (!only || only->limits) {
    ModuleCallLocked(m.id,
                     snp::SetLimits{.min_angle = static_cast<float>(m.min_angle),
                                    .max_angle = static_cast<float>(m.max_angle)},
                     snp::MessageType::kAck);
    ++frames;
  }
  if (!only || only->clear_couplings) {
    ModuleCallLocked(m.id, snp::ClearCouplings{}, snp::MessageType::kAck);
    ++frames;
  }
  for (const cpg::Coupling& c : config_.couplings) {
    if (c.from != m.id || (only && only->couplings.count(c.to) == 0)) continue;
    ModuleCallLocked(m.id,
                     snp::SetCoupling{.to = static_cast<uint8_t>(c.to),
                                      .phase = static_cast<float>(c.phase),
                                      .weight = static_cast<float>(c.weight)},
                     snp::MessageType::kAck);
    ++frames;
  }
  return frames;
}

int RobotDriver::RefreshLocked() {
  int frames = 0;
  for (const cpg::ModuleParams& m : config_.modules) {
    try {
      frames += SendModuleConfigLocked(m, nullptr);
    } catch (const Error& e) {
      MarkAllPendingLocked();
      throw Error(e.code(), std::string(e.what()) +
                                "; the configuration was sent only partly (Refresh to retry)");
    }
  }
  pending_.clear();
  return frames;
}

void RobotDriver::LinkTreeLocked(double timeout, const CancelCheck& cancel,
                                 ConnectResult& result) {
  const int master = config_.master_id;
  if (backend_->IsSimulation()) {
    BridgeRequestLocked(snp::SetMasterNode{.module = static_cast<uint8_t>(master)},
                        snp::MessageType::kSpecialAck);
    ++result.frames_sent;
  }
  std::map<int, std::vector<int>> children;
  for (const auto& [child, parent] : config_.bluetooth_parent) children[parent].push_back(child);
  const int total = static_cast<int>(config_.bluetooth_parent.size());
  std::deque<int> queue{master};
  while (!queue.empty()) {
    const int parent = queue.front();
    queue.pop_front();
    for (int child : children[parent]) {
      const std::string link = "link " + Id(parent) + " -> " + Id(child);
      const std::string progress =
          " (" + Id(result.links) + " of " + Id(total) + " links up)";
      // A radio link can miss once: retry it a bounded number of times, and
      // name the link and what the last attempt saw when it never comes up.
      const int attempts = 1 + options_.link_retries;
      bool up = false;
      bool timed_out = false;
      for (int attempt = 1; attempt <= attempts && !up; ++attempt) {
        if (shutdown_) ThrowShutdown("ConnectRobot");
        if (cancel && cancel()) {
          throw Error(StatusCode::kCancelled, "ConnectRobot cancelled during " + link + progress);
        }
        std::optional<snp::Message> reply = link_->ModuleRequest(
            parent, snp::ConnectRequest{.child = static_cast<uint8_t>(child)},
            snp::MessageType::kConnectAck, timeout);
        ++result.frames_sent;
        timed_out = !reply;
        up = reply && std::get<snp::ConnectAck>(*reply).status == snp::LinkStatus::kUp;
        if (!up && attempt < attempts) {
          Log().warn("driver: {} {} (attempt {} of {}), retrying", link,
                     timed_out ? "timed out" : "failed", attempt, attempts);
        }
      }
      const std::string tries =
          attempts == 1 ? std::string() : " (" + Id(attempts) + " attempts)";
      if (!up && timed_out) {
        throw Error(StatusCode::kUnavailable, link + " timed out after " + FormatRounded(timeout) + " s" +
                                                  tries + progress);
      }
      if (!up) {
        throw Error(StatusCode::kUnavailable, link + " failed: module " + Id(parent) +
                                                  " could not reach module " + Id(child) + tries +
                                                  progress);
      }
      ++result.links;
      queue.push_back(child);
    }
  }
}

ConnectResult RobotDriver::ConnectRobot(double link_timeout, bool links_only,
                                        const CancelCheck& cancel) {
  if (!std::isfinite(link_timeout)) {
    throw Error(StatusCode::kInvalidArgument, "link timeout is not finite: " + FormatRounded(link_timeout));
  }
  if (link_timeout < 0.0 || link_timeout > kMaxLinkTimeout) {
    throw Error(StatusCode::kOutOfRange, "link timeout " + FormatRounded(link_timeout) +
                                             " s is outside [0, " + FormatRounded(kMaxLinkTimeout) + "]");
  }
  const double timeout = link_timeout > 0.0 ? link_timeout : options_.link_timeout;
  const Clock::time_point start = Clock::now();
  Lock lock(mutex_);
  Backend& backend = RequireBackendLocked("ConnectRobot");
  const int master = config_.master_id;
  if (options_.master && *options_.master != master) {
    throw Error(StatusCode::kFailedPrecondition,
                "the configuration's bluetooth tree is rooted at module " + Id(master) +
                    " but the master node setting is " + Id(*options_.master));
  }
  connected_ = false;
  relink_needed_ = false;
  ConnectResult result;
  LinkTreeLocked(timeout, cancel, result);
  connected_ = true;
  attached_at_ = backend.IsSimulation() ? attached_at_ : Clock::now();
  UpdateTrackerFeedLocked();
  PushEvent(StateEvent{.kind = "connected", .detail = Id(result.links) + " links"});
  if (!links_only) result.frames_sent += RefreshLocked();
  result.elapsed = SecondsSince(start);
  return result;
}

int RobotDriver::Flush() {
  Lock lock(mutex_);
  RequireBackendLocked("Flush");
  RequireConnectedLocked("Flush");
  int frames = 0;
  for (const cpg::ModuleParams& m : config_.modules) {
    auto it = pending_.find(m.id);
    if (it == pending_.end()) continue;
    try {
      frames += SendModuleConfigLocked(m, &it->second);
    } catch (const Error& e) {
      int left = 0;
      for (const auto& [id, p] : pending_) left += p.Count();
      throw Error(e.code(), std::string(e.what()) + "; " + Id(left) +
                                " queued changes not sent (they stay queued)");
    }
    pending_.erase(it);
  }
  pending_.clear();  // entries of modules no longer configured
  return frames;
}

int RobotDriver::Refresh() {
  Lock lock(mutex_);
  RequireBackendLocked("Refresh");
  if (relink_needed_) return RestoreAfterReopenLocked();
  RequireConnectedLocked("Refresh");
  return RefreshLocked();
}

int RobotDriver::RestoreAfterReopenLocked() {
  Backend& backend = *backend_;
  if (backend.IsSimulation()) {
    ReadSimInfoLocked();  // a restarted bridge may run another world
    SetSimTimeLocked(std::get<snp::SimTime>(
                         BridgeRequestLocked(snp::GetSimTime{}, snp::MessageType::kSimTime))
                         .seconds);
  }
  ConnectResult result;
  result.frames_sent = backend.IsSimulation() ? 2 : 0;  // GetSimInfo, GetSimTime
  LinkTreeLocked(options_.link_timeout, nullptr, result);
  connected_ = true;
  relink_needed_ = false;
  int frames = result.frames_sent + RefreshLocked();
  // What the robot had before the loss, on top of its configuration.
  for (const auto& [id, control] : control_state_) {
    snp::Control restore = control;
    if (motor_defects_.count(id) && restore.motors == snp::Tristate::kOn) {
      restore.motors = snp::Tristate::kUnchanged;
    }
    if (restore == snp::Control{}) continue;
    ModuleCallLocked(id, restore, snp::MessageType::kAck);
    ++frames;
  }
  if (backend.IsSimulation()) {
    for (const auto& [id, defect] : motor_defects_) {
      BridgeRequestLocked(snp::SetMotorFault{.module = static_cast<uint8_t>(id),
                                             .fault = ToFault(defect)},
                          snp::MessageType::kSpecialAck);
      ++frames;
    }
    for (int id : module_defects_) {
      BridgeRequestLocked(snp::SetModuleDefect{.module = static_cast<uint8_t>(id), .defective = true},
                          snp::MessageType::kSpecialAck);
      ++frames;
    }
  }
  PushEvent(StateEvent{.kind = "restored",
                       .detail = Id(result.links) + " links, configuration, " +
                                 Id(static_cast<int>(control_state_.size())) +
                                 " modules' switches"});
  return frames;
}

void RobotDriver::SendControlMessage(const ControlMessage& message) {
  Lock lock(mutex_);
  RequireBackendLocked("SendControlMessage");
  std::vector<int> targets;
  if (message.all) {
    for (const cpg::ModuleParams& m : config_.modules) targets.push_back(m.id);
  } else {
    if (message.module_ids.empty()) {
      throw Error(StatusCode::kInvalidArgument,
                  "control message without targets: give module ids or all");
    }
    for (int id : message.module_ids) {
      if (config_.FindModule(id) == nullptr) {
        throw Error(StatusCode::kNotFound, "module " + Id(id) + " is not in the configuration");
      }
      if (std::find(targets.begin(), targets.end(), id) == targets.end()) targets.push_back(id);
    }
  }
  RequireConnectedLocked("SendControlMessage");
  for (int id : targets) {
    snp::Control control{.uart = message.uart, .cpg = message.cpg, .motors = message.motors};
    auto defect = motor_defects_.find(id);
    if (defect != motor_defects_.end() && control.motors == snp::Tristate::kOn) {
      Log().info("driver: motor-on not forwarded to module {} (motor defect)", id);
      control.motors = snp::Tristate::kUnchanged;
    }
    // "All" means the robot as configured: an inactive module's servo stays
    // unpowered, as Evaluate and ConfigurationFrames leave it; naming the
    // module powers it.
    if (message.all && control.motors == snp::Tristate::kOn &&
        IsInactive(*config_.FindModule(id))) {
      Log().debug("driver: motor-on for all skips inactive module {}", id);
      control.motors = snp::Tristate::kUnchanged;
    }
    if (control == snp::Control{}) continue;  // nothing left to change
    ModuleCallLocked(id, control, snp::MessageType::kAck);
    snp::Control& known = control_state_[id];  // kept to restore after a reopened link
    if (control.uart != snp::Tristate::kUnchanged) known.uart = control.uart;
    if (control.cpg != snp::Tristate::kUnchanged) known.cpg = control.cpg;
    if (control.motors != snp::Tristate::kUnchanged) known.motors = control.motors;
  }
}

double RobotDriver::SleepRealTime(double seconds, const CancelCheck& cancel) {
  const Clock::time_point deadline =
      Clock::now() + std::chrono::duration_cast<Clock::duration>(
                         std::chrono::duration<double>(seconds));
  {
    Lock lock(mutex_);  // only to wait on wake_; released while waiting
    while (Clock::now() < deadline) {
      if (shutdown_) ThrowShutdown("Sleep");
      if (cancel && cancel()) throw Error(StatusCode::kCancelled, "Sleep cancelled");
      wake_.wait_until(lock, std::min(deadline, Clock::now() + std::chrono::milliseconds(50)));
    }
  }
  return ElapsedTime();
}

double RobotDriver::Sleep(double seconds, bool real_time, const CancelCheck& cancel) {
  if (!std::isfinite(seconds)) {
    throw Error(StatusCode::kInvalidArgument, "sleep duration is not finite: " + FormatRounded(seconds));
  }
  if (seconds < 0.0 || seconds > options_.max_sleep) {
    throw Error(StatusCode::kOutOfRange, "sleep duration " + FormatRounded(seconds) + " s is outside [0, " +
                                             FormatRounded(options_.max_sleep) + "]");
  }
  double target = 0.0;
  double seen = 0.0;  // the simulation time this Sleep last saw
  {
    Lock lock(mutex_);
    Backend& backend = RequireBackendLocked("Sleep");
    if (!backend.IsSimulation() || real_time) {
      lock.unlock();
      return SleepRealTime(seconds, cancel);
    }
    CheckDivergedLocked();
    target = sim_time_ + seconds;
    seen = sim_time_;
  }
  while (true) {
    if (shutdown_) ThrowShutdown("Sleep");
    Lock lock(mutex_);
    if (cancel && cancel()) {
      throw Error(StatusCode::kCancelled, "Sleep cancelled at t = " + FormatRounded(sim_time_) + " s");
    }
    if (!backend_ || !backend_->IsSimulation()) {
      throw Error(StatusCode::kFailedPrecondition, "the simulation was closed during Sleep");
    }
    if (sim_time_ < seen) {
      // Another caller reset or reopened the world while this Sleep waited
      // for the robot: the time still owed counts from the new clock. (The
      // old target made a 0.1-s Sleep step the whole lost timeline again,
      // minutes of stepping; found by the soak, issue 17.)
      target = sim_time_ + (target - seen);
    }
    seen = sim_time_;
    const double remaining = target - sim_time_;
    if (remaining < 0.5 * time_step_) return sim_time_;
    const double before = sim_time_;
    StepLocked(std::min(remaining, options_.sleep_chunk));
    seen = sim_time_;
    if (!(sim_time_ > before)) return sim_time_;  // less than a step left
    lock.unlock();
    // Let callers that queued up during the chunk (ElapsedTime, Set...,
    // WatchState) take the robot before the next chunk.
    // TicketMutex: they were queued before this thread's next lock() and so
    // get the robot first, in order.
  }
}

double RobotDriver::ElapsedTime() {
  Lock lock(mutex_);
  Backend& backend = RequireBackendLocked("ElapsedTime");
  if (!backend.IsSimulation()) return SecondsSince(attached_at_);
  const snp::Message m = BridgeRequestLocked(snp::GetSimTime{}, snp::MessageType::kSimTime);
  SetSimTimeLocked(std::get<snp::SimTime>(m).seconds);
  return sim_time_;
}

RobotPose RobotDriver::RobotPosition() {
  Lock lock(mutex_);
  Backend& backend = RequireBackendLocked("RobotPosition");
  if (!backend.IsSimulation()) {
    if (!options_.tracker) {
      throw Error(StatusCode::kUnimplemented,
                  "the position of a real robot needs the LED tracker: start yamord with "
                  "--led-tracker HOST:PORT --tracker-calibration FILE (docs/camapp.md)");
    }
    const Clock::time_point epoch = attached_at_;
    lock.unlock();
    const TrackedPose tracked = options_.tracker->Latest();
    return RobotPose{.time = std::chrono::duration<double>(tracked.arrival - epoch).count(),
                     .position = tracked.position,
                     .source = "led-tracker"};
  }
  CheckDivergedLocked();
  if (!options_.position_from_tracker) return SimulatedPoseLocked();
  // What the camera sees now: the first frame captured at or after the
  // present, whose capture time cannot exceed the simulation's (a later one
  // is from before a reset). Waited for without the robot's mutex: the
  // camera reads the simulation through this driver.
  const double now = std::get<snp::SimTime>(
                         BridgeRequestLocked(snp::GetSimTime{}, snp::MessageType::kSimTime))
                         .seconds;
  SetSimTimeLocked(now);
  lock.unlock();
  const TrackedPose tracked =
      options_.tracker->CapturedBetween(now, [this] { return sim_clock_.load(); });
  return RobotPose{.time = tracked.camera_time, .position = tracked.position, .source = "led-tracker"};
}

RobotPose RobotDriver::SimulatedPosition() {
  Lock lock(mutex_);
  RequireSimulationLocked("SimulatedPosition");
  CheckDivergedLocked();
  return SimulatedPoseLocked();
}

std::vector<std::pair<int, double>> RobotDriver::GetServoAngles(const std::vector<int>& ids) {
  Lock lock(mutex_);
  RequireBackendLocked("GetServoAngles");
  std::vector<int> targets = ids;
  if (targets.empty()) {
    for (const cpg::ModuleParams& m : config_.modules) targets.push_back(m.id);
  }
  for (int id : targets) {
    if (config_.FindModule(id) == nullptr) {
      throw Error(StatusCode::kNotFound, "module " + Id(id) + " is not in the configuration");
    }
  }
  RequireConnectedLocked("GetServoAngles");
  std::vector<std::pair<int, double>> angles;
  for (int id : targets) {
    const snp::Message m =
        ModuleCallLocked(id, snp::ReadServoAngle{}, snp::MessageType::kServoAngle);
    angles.emplace_back(id, std::get<snp::ServoAngle>(m).angle);
  }
  return angles;
}

std::vector<AccelerometerSample> RobotDriver::GetAccelerometer(int id, int samples) {
  if (samples == 0) samples = 1;
  if (samples < 1 || samples > static_cast<int>(snp::kMaxAccelerometerSamples)) {
    throw Error(StatusCode::kOutOfRange,
                "accelerometer samples " + Id(samples) + " is outside [1, 16]");
  }
  Lock lock(mutex_);
  RequireBackendLocked("GetAccelerometer");
  if (config_.FindModule(id) == nullptr) {
    throw Error(StatusCode::kNotFound, "module " + Id(id) + " is not in the configuration");
  }
  RequireConnectedLocked("GetAccelerometer");
  snp::Message m;
  try {
    m = ModuleCallLocked(id, snp::ReadAccelerometer{.sample_count = static_cast<uint8_t>(samples)},
                         snp::MessageType::kAccelerometer);
  } catch (const Error& e) {
    if (e.code() != StatusCode::kFailedPrecondition) throw;
    throw Error(e.code(), std::string(e.what()) + ": switch its UART on with a control message");
  }
  std::vector<AccelerometerSample> out;
  for (const snp::AccelerometerSample& s : std::get<snp::Accelerometer>(m).samples) {
    AccelerometerSample sample;
    sample.counts = {s.x, s.y, s.z};
    for (int axis = 0; axis < 3; ++axis) {
      sample.acceleration[axis] = (sample.counts[axis] - accelerometer_zero_) * accelerometer_count_;
    }
    out.push_back(sample);
  }
  return out;
}

ModuleOrientation RobotDriver::GetOrientation(int id, int samples,
                                              std::array<double, 3> reference_up) {
  if (samples == 0) samples = static_cast<int>(snp::kMaxAccelerometerSamples);
  const Eigen::Vector3d reference(reference_up[0], reference_up[1], reference_up[2]);
  if (!reference.allFinite()) {
    throw Error(StatusCode::kInvalidArgument, "orientation reference_up must be finite, got (" +
                                                  FormatDouble(reference.x()) + ", " +
                                                  FormatDouble(reference.y()) + ", " +
                                                  FormatDouble(reference.z()) + ")");
  }
  const std::vector<AccelerometerSample> readings = GetAccelerometer(id, samples);
  physics::OrientationOptions options;
  options.window = static_cast<int>(readings.size());
  options.upside_down_enter = kUpsideDownTilt;
  options.upside_down_leave = kUpsideDownTilt;
  if (reference.norm() > 1e-12) options.up_axis = reference;
  physics::OrientationEstimator estimator(options);
  ModuleOrientation out;
  for (const AccelerometerSample& s : readings) {
    const Eigen::Vector3d f(s.acceleration[0], s.acceleration[1], s.acceleration[2]);
    out.max_deviation = std::max(out.max_deviation, std::abs(f.norm() - options.gravity));
    const physics::OrientationEstimate& e = estimator.Add(f);
    out.valid = e.valid;
    out.up = {e.up.x(), e.up.y(), e.up.z()};
    out.tilt = e.tilt;
    out.upside_down = e.valid && e.upside_down;
  }
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const AccelerometerSample& s : readings) {
    mean += Eigen::Vector3d(s.acceleration[0], s.acceleration[1], s.acceleration[2]);
  }
  out.samples = static_cast<int>(readings.size());
  out.magnitude = readings.empty() ? 0.0 : (mean / double(readings.size())).norm();
  return out;
}

void RobotDriver::SetMotorDefect(int id, MotorDefect defect) {
  Lock lock(mutex_);
  if (shutdown_) ThrowShutdown("SetMotorDefect");
  if (config_.FindModule(id) == nullptr) {
    throw Error(StatusCode::kNotFound, "module " + Id(id) + " is not in the configuration");
  }
  const bool simulation = backend_ && backend_->IsSimulation();
  auto set_fault = [&](MotorDefect d) {
    BridgeRequestLocked(snp::SetMotorFault{.module = static_cast<uint8_t>(id), .fault = ToFault(d)},
                        snp::MessageType::kSpecialAck);
  };
  if (defect != MotorDefect::kNone) {
    if (backend_ && connected_) {
      ModuleCallLocked(id, snp::Control{.motors = snp::Tristate::kOff}, snp::MessageType::kAck);
    }
    if (simulation) set_fault(defect);
    motor_defects_[id] = defect;
    PushEvent(StateEvent{.kind = "defect_set", .module_id = id,
                         .detail = "motor " + std::string(DefectName(defect))});
  } else {
    if (simulation) set_fault(MotorDefect::kNone);
    motor_defects_.erase(id);
    PushEvent(StateEvent{.kind = "defect_cleared", .module_id = id, .detail = "motor"});
  }
}

void RobotDriver::SetModuleDefect(int id, bool defective) {
  Lock lock(mutex_);
  RequireSimulationLocked("SetModuleDefect");
  if (id < 0 || id > cpg::kMaxModuleId ||
      (world_morphology_ && !world_morphology_->Contains(link_->Wire(id)))) {
    throw Error(StatusCode::kNotFound, "module " + Id(id) + " is not in the world");
  }
  BridgeRequestLocked(snp::SetModuleDefect{.module = static_cast<uint8_t>(id), .defective = defective},
                      snp::MessageType::kSpecialAck);
  if (defective) {
    module_defects_.insert(id);
  } else {
    module_defects_.erase(id);
  }
  PushEvent(StateEvent{.kind = defective ? "defect_set" : "defect_cleared", .module_id = id,
                       .detail = "module"});
}

snp::MotorFault ToFault(MotorDefect defect) {
  switch (defect) {
    case MotorDefect::kLimp: return snp::MotorFault::kLimp;
    case MotorDefect::kStuck: return snp::MotorFault::kStuck;
    case MotorDefect::kNone: break;
  }
  return snp::MotorFault::kNone;
}

void CheckGroundValues(const GroundChange& change) {
  auto check_finite = [](const std::optional<double>& v, std::string_view what) {
    if (v && !std::isfinite(*v)) {
      throw Error(StatusCode::kInvalidArgument, std::string(what) + " is not finite: " + FormatRounded(*v));
    }
  };
  check_finite(change.friction, "ground friction");
  check_finite(change.slope, "slope");
  check_finite(change.slope_direction, "slope direction");
  if (change.friction && !(*change.friction > 0.0 && *change.friction <= 100.0)) {
    throw Error(StatusCode::kOutOfRange,
                "ground friction " + FormatRounded(*change.friction) + " is outside (0, 100]");
  }
  if (change.slope && !(*change.slope >= 0.0 && *change.slope < M_PI / 2)) {
    throw Error(StatusCode::kOutOfRange, "slope " + FormatRounded(*change.slope) + " rad is outside [0, pi/2)");
  }
}

void RobotDriver::SetGround(const GroundChange& change) {
  CheckGroundValues(change);
  if (!change.friction && !change.slope && !change.slope_direction) {
    throw Error(StatusCode::kInvalidArgument,
                "ground change without friction, slope or slope direction");
  }
  Lock lock(mutex_);
  RequireSimulationLocked("SetGround");
  const snp::Message m = BridgeRequestLocked(
      snp::SetGround{.friction = change.friction,
                     .slope = change.slope,
                     .slope_direction = change.slope_direction},
      snp::MessageType::kGround);
  const auto& ground = std::get<snp::Ground>(m);
  slope_ = ground.slope;
  slope_direction_ = ground.slope_direction;
  PushEvent(StateEvent{.kind = "ground_changed",
                       .detail = "friction " + FormatRounded(ground.friction) + ", slope " +
                                 FormatRounded(slope_) + " rad towards " + FormatRounded(slope_direction_) + " rad"});
}

void RobotDriver::TurnUpsideDown() {
  Lock lock(mutex_);
  RequireSimulationLocked("TurnUpsideDown");
  CheckDivergedLocked();
  BridgeRequestLocked(snp::TurnUpsideDown{}, snp::MessageType::kSpecialAck);
  PushEvent(StateEvent{.kind = "turned_upside_down"});
  if (state_.Watched()) RecordSampleLocked();
}

void RobotDriver::ConnectModules(int from, snp::Connector from_connector, int to,
                                 snp::Connector to_connector, double angle_degrees) {
  if (!std::isfinite(angle_degrees)) {
    throw Error(StatusCode::kInvalidArgument, "connection angle is not finite");
  }
  const double steps = angle_degrees / 15.0;
  if (angle_degrees < 0.0 || angle_degrees >= 360.0 || std::fabs(steps - std::round(steps)) > 1e-9) {
    throw Error(StatusCode::kInvalidArgument, "connection angle " + FormatRounded(angle_degrees) +
                                                  " degrees is not a multiple of 15 in [0, 360)");
  }
  for (int id : {from, to}) {
    if (id < 0 || id > cpg::kMaxModuleId) {
      throw Error(StatusCode::kNotFound, "module " + Id(id) + " does not exist (ids are 0..254)");
    }
  }
  if (from == to) {
    throw Error(StatusCode::kInvalidArgument, "module " + Id(from) + " cannot connect to itself");
  }
  Lock lock(mutex_);
  RequireBackendLocked("ConnectModules");
  BridgeRequestLocked(snp::ConnectModules{.from = static_cast<uint8_t>(from),
                                          .from_connector = from_connector,
                                          .to = static_cast<uint8_t>(to),
                                          .to_connector = to_connector,
                                          .angle_index = static_cast<uint8_t>(std::lround(steps))},
                      snp::MessageType::kSpecialAck);
  PushEvent(StateEvent{.kind = "module_connected", .module_id = from,
                       .detail = "to module " + Id(to)});
}

void RobotDriver::DisconnectModule(int id) {
  if (id < 0 || id > cpg::kMaxModuleId) {
    throw Error(StatusCode::kNotFound, "module " + Id(id) + " does not exist (ids are 0..254)");
  }
  Lock lock(mutex_);
  RequireBackendLocked("DisconnectModule");
  BridgeRequestLocked(snp::DisconnectModule{.module = static_cast<uint8_t>(id)},
                      snp::MessageType::kSpecialAck);
  PushEvent(StateEvent{.kind = "module_disconnected", .module_id = id});
}

void RobotDriver::RunTransformationScript(std::string_view xml, const CancelCheck& cancel) {
  // Parsed (and so validated) whole before anything runs; errors carry the line.
  const physics::TransformationScript script = physics::TransformationScript::Parse(xml, "script");
  // Each command goes to the robot as SNP, like every other call.
  for (const physics::ScriptCommand& c : script.commands()) {
    if (cancel && cancel()) {
      throw Error(StatusCode::kCancelled, "script cancelled before line " + Id(c.line));
    }
    try {
      switch (c.kind) {
        case physics::ScriptCommand::Kind::kConnect:
          ConnectModules(c.connection.from,
                         static_cast<snp::Connector>(c.connection.from_connector),
                         c.connection.to, static_cast<snp::Connector>(c.connection.to_connector),
                         15.0 * c.connection.angle_steps);
          break;
        case physics::ScriptCommand::Kind::kDisconnect:
          DisconnectModule(c.id);
          break;
        case physics::ScriptCommand::Kind::kPause:
          Sleep(c.delay_ms / 1000.0, false, cancel);
          break;
      }
    } catch (const Error& e) {
      throw Error(e.code(), "script:" + Id(c.line) + ": " + e.what());
    }
  }
}

void RobotDriver::SetFreeRun(double real_time_factor) {
  if (!std::isfinite(real_time_factor)) {
    throw Error(StatusCode::kInvalidArgument,
                "real-time factor is not finite: " + FormatRounded(real_time_factor));
  }
  if (real_time_factor < 0.0 || real_time_factor > 100.0) {
    throw Error(StatusCode::kOutOfRange,
                "real-time factor " + FormatRounded(real_time_factor) + " is outside [0, 100]");
  }
  Lock lock(mutex_);
  if (shutdown_) ThrowShutdown("SetFreeRun");
  if (real_time_factor > 0.0) {
    Backend& backend = RequireBackendLocked("SetFreeRun");
    if (!backend.IsSimulation()) {
      throw Error(StatusCode::kFailedPrecondition, "free-run mode needs a simulation");
    }
    if (!free_run_thread_.joinable()) free_run_thread_ = std::thread([this] { FreeRunLoop(); });
  }
  free_run_factor_ = real_time_factor;
  wake_.notify_all();
}

void RobotDriver::FreeRunLoop() {
  Lock lock(mutex_);
  Clock::time_point last = Clock::now();
  double debt = 0.0;  // simulated seconds owed to the wall clock
  while (!shutdown_) {
    wake_.wait_for(lock, std::chrono::milliseconds(20));
    if (shutdown_) break;
    const Clock::time_point now = Clock::now();
    const double wall = std::chrono::duration<double>(now - last).count();
    last = now;
    if (free_run_factor_ <= 0.0 || !backend_ || !backend_->IsSimulation() || diverged_) {
      debt = 0.0;
      continue;
    }
    // A slow machine does not catch up in bursts: at most a quarter second owed.
    debt = std::min(debt + wall * free_run_factor_, 0.25 * free_run_factor_ + time_step_);
    const double steps = std::floor(debt / time_step_);
    if (steps < 1.0) continue;
    // A background thread catches everything and leaves the daemon serving:
    // a diverged world idles until reset (diverged_ is set and reported);
    // anything else stops free-run and says why in WatchState.
    std::string stopped;
    try {
      const double before = sim_time_;
      StepLocked(steps * time_step_);
      debt -= sim_time_ - before;
    } catch (const Error& e) {
      if (!diverged_) stopped = e.what();
      debt = 0.0;
    } catch (const std::exception& e) {
      stopped = std::string("internal error: ") + e.what();
    } catch (...) {
      stopped = "internal error: unknown exception";
    }
    if (!stopped.empty()) {
      Log().error("free-run stopped: {}", stopped);
      free_run_factor_ = 0.0;
      debt = 0.0;
      PushEvent(StateEvent{.kind = "free_run_stopped", .detail = stopped});
    }
  }
}

// ---- State stream -------------------------------------------------------------

WatchCursor RobotDriver::BeginWatch() {
  state_.AddWatcher();
  {
    Lock lock(mutex_);
    if (backend_ && backend_->IsSimulation() && !diverged_) RecordSampleLocked();
  }
  if (tracker_feed_.load() != kTrackerFeedNone) {
    // The tracker's latest position, if fresh, so the first update is immediate.
    try {
      OnTrackedPose(options_.tracker->Latest());
    } catch (const Error& e) {
      Log().debug("driver: no tracked sample yet: {}", e.what());
    }
  }
  return state_.NewCursor();
}

void RobotDriver::EndWatch() { state_.RemoveWatcher(); }

std::optional<StateUpdate> RobotDriver::WaitForState(WatchCursor& cursor, double period,
                                                     std::chrono::milliseconds wait) {
  return state_.Wait(cursor, period, wait);
}

// ---- Daemon ----------------------------------------------------------------------

DriverInfo RobotDriver::Info() const {
  Lock lock(mutex_);
  return DriverInfo{.backend = backend_ ? backend_->Name() : "none",
                    .world = world_name_,
                    .master_node = config_.master_id,
                    .connected = connected_,
                    .free_run_factor = free_run_factor_};
}

void RobotDriver::Shutdown() {
  {
    Lock lock(mutex_);
    shutdown_ = true;
    free_run_factor_ = 0.0;
  }
  wake_.notify_all();
  state_.Shutdown();
}

}  // namespace yamor::host
