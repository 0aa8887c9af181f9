#include "bridge/robot.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <set>
#include <string>
#include <utility>

#include "common/log.h"
#include "common/status.h"
#include "bridge/scene.h"
#include "physics/module.h"
#include "physics/render/snapshot.h"
#include "proto/snp/scene.h"

namespace yamor::bridge {
namespace {

// The wire's connector codes and physics' enum are the same list in the same
// order (docs/snp.md, physics/module.h); casting between them relies on it.
static_assert(static_cast<int>(snp::Connector::kFront) == static_cast<int>(physics::ConnectorId::kFront));
static_assert(static_cast<int>(snp::Connector::kRear) == static_cast<int>(physics::ConnectorId::kRear));
static_assert(static_cast<int>(snp::Connector::kLeft) == static_cast<int>(physics::ConnectorId::kLeft));
static_assert(static_cast<int>(snp::Connector::kRight) == static_cast<int>(physics::ConnectorId::kRight));
static_assert(static_cast<int>(snp::Connector::kTop) == static_cast<int>(physics::ConnectorId::kTop));
static_assert(static_cast<int>(snp::Connector::kBottom) == static_cast<int>(physics::ConnectorId::kBottom));

using snp::Address;

// Bounds the firmware accepts (beyond them a module answers OUT_OF_RANGE):
// a servo cannot follow faster oscillations, and larger angles are
// meaningless for a ±90° servo — they only invite numerical trouble.
constexpr double kMaxSpeedHz = 10.0;
constexpr double kMaxAngleMagnitude = 2.0 * M_PI;
constexpr double kMaxCouplingWeight = 1000.0;
constexpr double kMaxGroundFriction = 100.0;

// The accelerometer board samples at 100 Hz; reads return recent samples.
constexpr double kAccelerometerPeriod = 0.01;
constexpr std::size_t kAccelerometerHistory = snp::kMaxAccelerometerSamples;

snp::Ack MakeAck(snp::MessageType type, StatusCode code) {
  return snp::Ack{.acked = type, .status = code};
}

std::string Truncate(std::string text) {
  if (text.size() > snp::kMaxErrorTextSize) text.resize(snp::kMaxErrorTextSize);
  // The wire carries printable ASCII only.
  for (char& c : text) {
    if (c < 0x20 || c > 0x7e) c = '?';
  }
  return text;
}

}  // namespace

Robot::Robot(physics::Morphology morphology, RobotOptions options)
    : options_(std::move(options)), world_(std::move(morphology), options_.world) {
  master_ = options_.master.value_or(world_.CentralModule());
  if (!world_.morphology().Contains(master_)) {
    throw Error(StatusCode::kNotFound,
                "master node " + std::to_string(master_) + " is not a module of " +
                    world_.morphology().source());
  }
  if (!(options_.max_step_duration > 0.0) || !std::isfinite(options_.max_step_duration)) {
    throw Error(StatusCode::kInvalidArgument, "max_step_duration must be finite and > 0");
  }
  PowerOn();
}

void Robot::PowerOn() {
  // Defects are hardware: they survive a power cycle.
  std::set<int> defective;
  for (const auto& [id, fw] : firmware_) {
    if (fw.oscillator_dead) defective.insert(id);
  }
  firmware_.clear();
  for (int id : world_.ModuleIds()) {
    ModuleFirmware fw;
    fw.id = id;
    fw.oscillator_dead = defective.count(id) != 0;
    firmware_.emplace(id, fw);
    world_.SetMotorEnabled(id, false);
  }
  link_parent_.clear();
  timers_.clear();
  accelerometer_history_.clear();
  network_ = cpg::Network();
  network_state_ = cpg::NetworkState();
  network_dirty_ = true;
}

void Robot::Reset() {
  world_.Reset();
  slope_ = 0.0;
  slope_direction_ = 0.0;
  PowerOn();
}

bool Robot::Reachable(int id) const {
  // Links only ever go to modules that were unlinked, so this walk ends.
  for (int hops = 0; hops <= static_cast<int>(firmware_.size()); ++hops) {
    if (id == master_) return true;
    auto it = link_parent_.find(id);
    if (it == link_parent_.end()) return false;
    id = it->second;
  }
  return false;
}

const ModuleFirmware& Robot::Firmware(int id) const {
  auto it = firmware_.find(id);
  if (it == firmware_.end()) {
    throw Error(StatusCode::kNotFound, "module " + std::to_string(id) + " is not in the robot");
  }
  return it->second;
}

ModuleFirmware& Robot::MutableFirmware(int id) {
  return const_cast<ModuleFirmware&>(std::as_const(*this).Firmware(id));
}

void Robot::SetModuleDefect(int id, bool defective) {
  ModuleFirmware& fw = MutableFirmware(id);
  world_.SetModuleDefect(id, defective);
  fw.oscillator_dead = defective;
}

void Robot::HandleFrame(const snp::Frame& frame, std::vector<snp::Frame>& out) {
  ++stats_.frames_in;
  const std::size_t out_before = out.size();
  if (frame.source.kind != snp::NodeKind::kHost) {
    // Only the host talks to the robot; module chatter is not for us.
    Log().debug("bridge: ignoring frame from {}", snp::ToString(frame.source));
    return;
  }
  snp::Message message;
  try {
    message = snp::DecodeMessage(frame);
  } catch (const Error& e) {
    ++stats_.rejected;
    Log().warn("bridge: rejected frame to {}: {}", snp::ToString(frame.destination), e.what());
    if (frame.destination.kind == snp::NodeKind::kBridge) {
      out.push_back(snp::MakeFrame(
          Address::Bridge(), Address::Host(),
          snp::SpecialError{.acked = frame.type, .code = e.code(), .text = Truncate(e.what())}));
    }
    stats_.frames_out += out.size() - out_before;
    return;
  }
  if (frame.destination.kind == snp::NodeKind::kBridge) {
    HandleBridgeCommand(message, out);
  } else if (frame.destination.kind == snp::NodeKind::kModule) {
    HandleModuleFrame(frame, message, out);
  }
  stats_.frames_out += out.size() - out_before;
}

void Robot::HandleBytes(std::span<const uint8_t> bytes, std::vector<uint8_t>& out) {
  decode_events_.clear();
  decoder_.Feed(bytes, decode_events_);
  for (const snp::DecodeEvent& event : decode_events_) {
    if (const auto* decoded = std::get_if<snp::DecodedFrame>(&event)) {
      reply_scratch_.clear();
      HandleFrame(decoded->frame, reply_scratch_);
      for (const snp::Frame& reply : reply_scratch_) snp::AppendEncodedFrame(reply, out);
    } else {
      const auto& error = std::get<snp::DecodeError>(event);
      ++stats_.decode_errors;
      Log().debug("bridge: skipped bytes at offset {}: {}", error.offset(), error.reason());
    }
  }
}

void Robot::HandleModuleFrame(const snp::Frame& frame, const snp::Message& message,
                              std::vector<snp::Frame>& out) {
  if (frame.destination.IsBroadcast()) {
    // Every reachable module applies it; nobody answers a broadcast.
    for (auto& [id, fw] : firmware_) {
      if (!Reachable(id)) continue;
      try {
        Apply(fw, message);
      } catch (const Error& e) {
        Log().warn("bridge: module {} refused broadcast {}: {}", id,
                   snp::MessageTypeName(frame.type), e.what());
      }
    }
    return;
  }
  const int id = frame.destination.id;
  if (firmware_.count(id) == 0 || !Reachable(id)) {
    ++stats_.dropped_unreachable;
    Log().debug("bridge: module {} is not linked; {} dropped", id,
                snp::MessageTypeName(frame.type));
    return;
  }
  std::optional<snp::Message> reply;
  try {
    reply = Apply(firmware_.at(id), message);
  } catch (const Error& e) {
    ++stats_.rejected;
    reply = MakeAck(frame.type, e.code());
  }
  if (reply) out.push_back(snp::MakeFrame(Address::Module(static_cast<uint8_t>(id)),
                                          Address::Host(), *reply));
}

std::optional<snp::Message> Robot::Apply(ModuleFirmware& fw, const snp::Message& message) {
  const snp::MessageType type = snp::TypeOf(message);
  if (const auto* m = std::get_if<snp::ConnectRequest>(&message)) {
    const int child = m->child;
    const bool exists = firmware_.count(child) != 0;
    auto linked = link_parent_.find(child);
    bool up = false;
    if (linked != link_parent_.end()) {
      up = linked->second == fw.id;  // already our child: idempotent
    } else {
      up = exists && child != fw.id && child != master_;
      if (up) {
        link_parent_[child] = fw.id;
        fw.links.push_back(child);
      }
    }
    if (!up) {
      Log().debug("bridge: module {} could not link to {}", fw.id, child);
    }
    return snp::ConnectAck{.child = m->child,
                           .status = up ? snp::LinkStatus::kUp : snp::LinkStatus::kFailed};
  }
  if (const auto* m = std::get_if<snp::Control>(&message)) {
    auto apply = [](snp::Tristate t, bool& flag) {
      if (t == snp::Tristate::kOn) flag = true;
      if (t == snp::Tristate::kOff) flag = false;
    };
    apply(m->uart, fw.uart);
    apply(m->cpg, fw.cpg);
    apply(m->motors, fw.motors);
    world_.SetMotorEnabled(fw.id, fw.motors);
    if (!fw.uart) accelerometer_history_.erase(fw.id);
    return MakeAck(type, StatusCode::kOk);
  }
  if (const auto* m = std::get_if<snp::SetOscillator>(&message)) {
    if (m->amplitude && !(*m->amplitude >= 0.0f && *m->amplitude <= kMaxAngleMagnitude)) {
      return MakeAck(type, StatusCode::kOutOfRange);
    }
    if (m->offset && !(std::fabs(*m->offset) <= kMaxAngleMagnitude)) {
      return MakeAck(type, StatusCode::kOutOfRange);
    }
    if (m->speed && !(*m->speed >= 0.0f && *m->speed <= kMaxSpeedHz)) {
      return MakeAck(type, StatusCode::kOutOfRange);
    }
    if (m->amplitude) fw.amplitude = *m->amplitude;
    if (m->offset) fw.offset = *m->offset;
    if (m->speed) fw.speed = *m->speed;
    network_dirty_ = true;
    return MakeAck(type, StatusCode::kOk);
  }
  if (const auto* m = std::get_if<snp::SetLimits>(&message)) {
    if (!(m->min_angle < m->max_angle) || std::fabs(m->min_angle) > kMaxAngleMagnitude ||
        std::fabs(m->max_angle) > kMaxAngleMagnitude) {
      return MakeAck(type, StatusCode::kOutOfRange);
    }
    fw.min_angle = m->min_angle;
    fw.max_angle = m->max_angle;
    network_dirty_ = true;
    return MakeAck(type, StatusCode::kOk);
  }
  if (const auto* m = std::get_if<snp::SetCoupling>(&message)) {
    if (m->to == fw.id) return MakeAck(type, StatusCode::kInvalidArgument);
    // Any finite phase is fine (it is periodic); weights are bounded.
    if (!(std::fabs(m->weight) <= kMaxCouplingWeight)) {
      return MakeAck(type, StatusCode::kOutOfRange);
    }
    fw.couplings[m->to] = FirmwareCoupling{.phase = m->phase, .weight = m->weight};
    network_dirty_ = true;
    return MakeAck(type, StatusCode::kOk);
  }
  if (std::holds_alternative<snp::ClearCouplings>(message)) {
    fw.couplings.clear();
    network_dirty_ = true;
    return MakeAck(type, StatusCode::kOk);
  }
  if (std::holds_alternative<snp::ReadServoAngle>(message)) {
    return snp::ServoAngle{.angle = static_cast<float>(world_.ServoAngle(fw.id))};
  }
  if (const auto* m = std::get_if<snp::ReadAccelerometer>(&message)) {
    if (!fw.uart || world_.Presence(fw.id) == physics::ModulePresence::kPutAway) {
      return MakeAck(type, StatusCode::kFailedPrecondition);
    }
    auto& history = accelerometer_history_[fw.id];
    if (history.empty()) history.push_back(world_.Accelerometer(fw.id));
    snp::Accelerometer reply;
    const std::size_t n = std::min<std::size_t>(m->sample_count, history.size());
    for (std::size_t i = history.size() - n; i < history.size(); ++i) {
      const auto& counts = history[i].counts;
      reply.samples.push_back(snp::AccelerometerSample{.x = static_cast<int16_t>(counts[0]),
                                                       .y = static_cast<int16_t>(counts[1]),
                                                       .z = static_cast<int16_t>(counts[2])});
    }
    return reply;
  }
  // Replies (Ack, ConnectAck, ServoAngle, Accelerometer) sent to a module.
  return MakeAck(type, StatusCode::kUnimplemented);
}

void Robot::HandleBridgeCommand(const snp::Message& message, std::vector<snp::Frame>& out) {
  const snp::MessageType type = snp::TypeOf(message);
  auto reply = [&](const snp::Message& m) {
    out.push_back(snp::MakeFrame(Address::Bridge(), Address::Host(), m));
  };
  auto fail = [&](StatusCode code, const std::string& text) {
    ++stats_.rejected;
    reply(snp::SpecialError{.acked = type, .code = code, .text = Truncate(text)});
  };
  try {
    if (std::holds_alternative<snp::GetSimTime>(message)) {
      reply(snp::SimTime{.seconds = Time()});
    } else if (const auto* m = std::get_if<snp::Step>(&message)) {
      if (!(m->duration >= 0.0 && m->duration <= options_.max_step_duration)) {
        fail(StatusCode::kOutOfRange, "step duration " + std::to_string(m->duration) +
                                          " s is outside [0, " +
                                          std::to_string(options_.max_step_duration) + "]");
        return;
      }
      // A diverged world does not step: the host hears it on the Step itself
      // (one round trip per step, not a GetDivergence after each).
      if (world_.Diverged()) {
        fail(StatusCode::kFailedPrecondition, "the world is diverged; GetDivergence says why");
        return;
      }
      Advance(m->duration, out);
      if (world_.Diverged()) {
        fail(StatusCode::kFailedPrecondition,
             "the world diverged during the step; GetDivergence says why");
        return;
      }
      reply(snp::StepDone{.time = Time()});
    } else if (const auto* m = std::get_if<snp::SetTimer>(&message)) {
      if (!(m->delay >= 0.0 && m->delay <= options_.max_step_duration)) {
        fail(StatusCode::kOutOfRange, "timer delay " + std::to_string(m->delay) + " s is out of range");
        return;
      }
      timers_.emplace(Time() + m->delay, m->timer_id);
      reply(snp::SpecialAck{.acked = type});
    } else if (std::holds_alternative<snp::GetRobotPosition>(message)) {
      const Eigen::Vector3d p = world_.CentralPosition();
      const Eigen::Quaterniond q = world_.CentralOrientation();
      reply(snp::RobotPosition{.time = Time(),
                               .position = {p.x(), p.y(), p.z()},
                               .orientation = {q.w(), q.x(), q.y(), q.z()}});
    } else if (const auto* m = std::get_if<snp::SetMasterNode>(&message)) {
      if (firmware_.count(m->module) == 0) {
        fail(StatusCode::kNotFound, "master node " + std::to_string(m->module) + " is not a module");
        return;
      }
      // A new master means a new bluetooth network: every link drops.
      master_ = m->module;
      link_parent_.clear();
      for (auto& [id, fw] : firmware_) fw.links.clear();
      reply(snp::SpecialAck{.acked = type});
    } else if (const auto* m = std::get_if<snp::ConnectModules>(&message)) {
      // The world is frozen while the module is placed and joined (physics).
      world_.Connect(m->from, static_cast<physics::ConnectorId>(m->from_connector), m->to,
                     static_cast<physics::ConnectorId>(m->to_connector), m->angle_index);
      reply(snp::SpecialAck{.acked = type});
    } else if (const auto* m = std::get_if<snp::DisconnectModule>(&message)) {
      // Put away, as the thesis's Physical Links window did (C.2.7).
      world_.Disconnect(m->module, /*put_away=*/true);
      accelerometer_history_.erase(m->module);
      reply(snp::SpecialAck{.acked = type});
    } else if (std::holds_alternative<snp::ResetSimulation>(message)) {
      Reset();
      reply(snp::SpecialAck{.acked = type});
    } else if (const auto* m = std::get_if<snp::SetGround>(&message)) {
      if (m->friction && !(*m->friction > 0.0 && *m->friction <= kMaxGroundFriction)) {
        fail(StatusCode::kOutOfRange, "ground friction " + std::to_string(*m->friction) +
                                          " is outside (0, 100]");
        return;
      }
      const double slope = m->slope.value_or(slope_);
      const double direction = m->slope_direction.value_or(slope_direction_);
      if (m->slope || m->slope_direction) world_.SetSlope(slope, direction);  // validates
      if (m->friction) world_.SetGroundFriction(*m->friction);
      slope_ = slope;
      slope_direction_ = direction;
      reply(snp::Ground{.friction = world_.GroundFriction(),
                        .slope = slope_,
                        .slope_direction = slope_direction_});
    } else if (const auto* m = std::get_if<snp::SetMotorFault>(&message)) {
      Firmware(m->module);  // NOT_FOUND for a module not in the robot
      physics::MotorFault fault = physics::MotorFault::kNone;
      if (m->fault == snp::MotorFault::kLimp) fault = physics::MotorFault::kLimp;
      if (m->fault == snp::MotorFault::kStuck) fault = physics::MotorFault::kStuck;
      world_.SetMotorFault(m->module, fault);
      reply(snp::SpecialAck{.acked = type});
    } else if (const auto* m = std::get_if<snp::SetModuleDefect>(&message)) {
      SetModuleDefect(m->module, m->defective);
      reply(snp::SpecialAck{.acked = type});
    } else if (std::holds_alternative<snp::TurnUpsideDown>(message)) {
      world_.TurnUpsideDown();
      reply(snp::SpecialAck{.acked = type});
    } else if (std::holds_alternative<snp::GetDivergence>(message)) {
      snp::Divergence d{.diverged = world_.Diverged(), .time = Time()};
      if (d.diverged) {
        const physics::DivergenceInfo& info = world_.Divergence();
        if (info.module_id >= 0 && info.module_id <= snp::kMaxModuleId) {
          d.module = static_cast<uint8_t>(info.module_id);
        }
        d.reason = info.reason.substr(0, snp::kMaxDivergenceTextSize);
        for (char& c : d.reason) {
          if (c < 0x20 || c > 0x7e) c = '?';
        }
      }
      reply(d);
    } else if (const auto* m = std::get_if<snp::ReadMorphology>(&message)) {
      if (m->offset == 0) {
        morphology_snapshot_ = world_.CurrentMorphology().ToXml();  // FAILED_PRECONDITION if invalid
        has_morphology_snapshot_ = true;
      } else if (!has_morphology_snapshot_) {
        fail(StatusCode::kFailedPrecondition,
             "ReadMorphology at offset " + std::to_string(m->offset) +
                 " before a read at offset 0 took a snapshot");
        return;
      }
      snp::MorphologyChunk chunk{.total = static_cast<uint32_t>(morphology_snapshot_.size()),
                                 .offset = m->offset};
      if (m->offset < morphology_snapshot_.size()) {
        const std::size_t n =
            std::min<std::size_t>(m->length, morphology_snapshot_.size() - m->offset);
        chunk.data.assign(morphology_snapshot_.begin() + m->offset,
                          morphology_snapshot_.begin() + m->offset + n);
      } else {
        chunk.offset = chunk.total;  // at or past the end: an empty chunk at the end
      }
      reply(chunk);
    } else if (const auto* m = std::get_if<snp::ReadScene>(&message)) {
      if (m->offset == 0) {
        // FAILED_PRECONDITION when diverged: no poses to show.
        scene_snapshot_ = snp::EncodeSceneSnapshot(render::ToSnapshot(SceneOf(world_)));
        has_scene_snapshot_ = true;
      } else if (!has_scene_snapshot_) {
        fail(StatusCode::kFailedPrecondition,
             "ReadScene at offset " + std::to_string(m->offset) +
                 " before a read at offset 0 took a snapshot");
        return;
      }
      snp::SceneChunk chunk{.total = static_cast<uint32_t>(scene_snapshot_.size()),
                            .offset = m->offset};
      if (m->offset < scene_snapshot_.size()) {
        const std::size_t n = std::min<std::size_t>(m->length, scene_snapshot_.size() - m->offset);
        chunk.data.assign(scene_snapshot_.begin() + m->offset,
                          scene_snapshot_.begin() + m->offset + n);
      } else {
        chunk.offset = chunk.total;  // at or past the end: an empty chunk at the end
      }
      reply(chunk);
    } else if (std::holds_alternative<snp::GetSimInfo>(message)) {
      const physics::AccelerometerSpec& spec = world_.options().accelerometer;
      reply(snp::SimInfo{.time_step = world_.options().time_step,
                         .accelerometer_zero = static_cast<double>(spec.zero_count),
                         .accelerometer_count = spec.count_size});
    } else {
      fail(StatusCode::kInvalidArgument, "not a bridge command");
    }
  } catch (const Error& e) {
    fail(e.code(), e.what());
  }
}

void Robot::RebuildNetworkIfDirty() {
  if (!network_dirty_) return;
  cpg::RobotConfig config;
  for (const auto& [id, fw] : firmware_) {
    config.modules.push_back(cpg::ModuleParams{.id = id,
                                               .amplitude = fw.amplitude,
                                               .offset = fw.offset,
                                               .speed = fw.speed,
                                               .min_angle = fw.min_angle,
                                               .max_angle = fw.max_angle});
  }
  for (const auto& [id, fw] : firmware_) {
    for (const auto& [to, coupling] : fw.couplings) {
      // A neighbour that is not in the robot sends no state: no term.
      if (firmware_.count(to) == 0) continue;
      config.couplings.push_back(
          cpg::Coupling{.from = id, .to = to, .phase = coupling.phase, .weight = coupling.weight});
    }
  }
  cpg::Network next = cpg::Network::Compile(config);
  if (network_.size() == 0) {
    network_state_ = next.InitialState(options_.phase_seed);
  } else {
    network_state_ = cpg::RemapState(network_, network_state_, next);
  }
  network_ = std::move(next);
  set_points_.assign(network_.size(), std::nullopt);
  network_dirty_ = false;
}

void Robot::StepOnce(std::vector<snp::Frame>& events) {
  RebuildNetworkIfDirty();
  bool any_enabled = false;
  for (std::size_t i = 0; i < network_.size(); ++i) {
    const ModuleFirmware& fw = firmware_.at(network_.IdAt(i));
    const bool on = fw.cpg && !fw.oscillator_dead;
    network_state_.enabled[i] = on;
    any_enabled = any_enabled || on;
  }
  if (any_enabled) {
    cpg::Step(network_, network_state_, world_.options().time_step);
    cpg::SetPoints(network_, network_state_, set_points_);
    for (std::size_t i = 0; i < network_.size(); ++i) {
      const int id = network_.IdAt(i);
      if (set_points_[i] && firmware_.at(id).motors) world_.SetServoTarget(id, *set_points_[i]);
    }
  }
  world_.Step();

  // The sensor boards sample on their own clock, whatever the host reads.
  const auto period_steps = static_cast<uint64_t>(
      std::max(1.0, std::round(kAccelerometerPeriod / world_.options().time_step)));
  if (world_.StepCount() % period_steps == 0) {
    for (const auto& [id, fw] : firmware_) {
      // A module put away has no sensor in the world to read.
      if (!fw.uart || world_.Presence(id) == physics::ModulePresence::kPutAway) continue;
      auto& history = accelerometer_history_[id];
      history.push_back(world_.Accelerometer(id));
      if (history.size() > kAccelerometerHistory) history.pop_front();
    }
  }
  FireTimers(events);
}

void Robot::Advance(double seconds, std::vector<snp::Frame>& events) {
  if (!(seconds >= 0.0) || !std::isfinite(seconds)) {
    throw Error(StatusCode::kInvalidArgument,
                "advance duration must be finite and >= 0, got " + std::to_string(seconds));
  }
  const auto steps = static_cast<int64_t>(std::llround(seconds / world_.options().time_step));
  for (int64_t i = 0; i < steps; ++i) StepOnce(events);
}

void Robot::FireTimers(std::vector<snp::Frame>& events) {
  // Half a step of slack: a timer due "now" fires on this step, not the next.
  const double now = Time() + 0.5 * world_.options().time_step;
  while (!timers_.empty() && timers_.begin()->first <= now) {
    events.push_back(snp::MakeFrame(Address::Bridge(), Address::Host(),
                                    snp::TimerFired{.timer_id = timers_.begin()->second,
                                                    .time = Time()}));
    timers_.erase(timers_.begin());
  }
}

}  // namespace yamor::bridge
