// The emulated YaMoR robot: one firmware state per module, driven by SNP
// frames exactly as a module would be, feeding CPG set-points into servos of
// an ODE world. This is the simulation backend the daemon embeds in-process.
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "cpg/network.h"
#include "physics/morphology.h"
#include "physics/world.h"
#include "proto/snp/decoder.h"
#include "proto/snp/frame.h"
#include "proto/snp/messages.h"

namespace yamor::bridge {

/// One CPG coupling as a module's firmware stores it (keyed by `to`).
struct FirmwareCoupling {
  float phase = 0.0f;   ///< Phase bias [rad].
  float weight = 0.0f;  ///< Weight.
  friend bool operator==(const FirmwareCoupling&, const FirmwareCoupling&) = default;
};

/// The state a module's firmware keeps, as the SNP messages set it. Starts at
/// power-on values: everything off, zero oscillator, limits at the servo's
/// ±90°, no couplings, no links.
struct ModuleFirmware {
  int id = 0;                 ///< Module id.
  bool uart = false;          ///< Sensor-board serial line on.
  bool cpg = false;           ///< Oscillator integrating.
  bool motors = false;        ///< Servo powered.
  float amplitude = 0.0f;     ///< Target amplitude [rad].
  float offset = 0.0f;        ///< Target offset [rad].
  float speed = 0.0f;         ///< Frequency [Hz].
  float min_angle = -1.5707964f;  ///< Lower set-point limit [rad].
  float max_angle = 1.5707964f;   ///< Upper set-point limit [rad].
  std::map<int, FirmwareCoupling> couplings;  ///< to -> coupling.
  std::vector<int> links;     ///< Children this module opened bluetooth links to.
  bool oscillator_dead = false;  ///< Module defect: the oscillator no longer runs.
};

/// Construction options of the emulated robot.
struct RobotOptions {
  physics::WorldOptions world;  ///< The ODE world's options (step, seed, ...).
  /// Master node (the module linked to the host); default: the morphology's
  /// central module.
  std::optional<int> master;
  /// Seed of the oscillators' initial phases (a real robot's modules never
  /// start in perfect sync; a seeded spread breaks symmetric equilibria).
  uint64_t phase_seed = 1;
  /// Longest simulated time one Step command may ask for [s].
  double max_step_duration = 3600.0;
};

/// Counters of what the emulated robot did with incoming traffic.
struct RobotStats {
  uint64_t frames_in = 0;           ///< Frames handled.
  uint64_t frames_out = 0;          ///< Frames produced.
  uint64_t dropped_unreachable = 0; ///< Module frames for unlinked modules.
  uint64_t decode_errors = 0;       ///< Rejected byte-stream candidates.
  uint64_t rejected = 0;            ///< Frames answered with an error.
};

/// The emulated robot. Module messages are applied by the addressed module's
/// firmware when it is reachable over the bluetooth tree (the master always
/// is; others once their parent opened a link); frames for unreachable
/// modules are dropped, as on the real robot, and the host times out.
/// Broadcast module messages are applied by every reachable module and not
/// acknowledged. Bridge commands (simulated time, step, timers, position,
/// master node, connect/disconnect, reset, ground, motor and module defects,
/// upside down, divergence, morphology and scene readback, simulation facts;
/// docs/snp.md)
/// are answered by the bridge.
///
/// Thread-safety: not thread-safe. One owner thread drives a Robot; distinct
/// Robot instances share nothing and may run on different threads.
class Robot {
 public:
  /// Builds the world for `morphology` with every module at power-on.
  explicit Robot(physics::Morphology morphology, RobotOptions options = {});

  /// Handles one frame from the host, appending replies and events (acks,
  /// readbacks, TimerFired) to `out`. Never throws for bad frame contents:
  /// they are answered with an Ack/SpecialError carrying the code.
  void HandleFrame(const snp::Frame& frame, std::vector<snp::Frame>& out);

  /// Feeds raw bytes (as from a serial line); decodes frames, handles them
  /// and appends the encoded replies to `out`. Garbage and corrupted frames
  /// are skipped and counted.
  void HandleBytes(std::span<const uint8_t> bytes, std::vector<uint8_t>& out);

  /// Advances one physics step: integrates the oscillators of modules whose
  /// CPG is on, sends set-points to servos whose motors are on, steps the
  /// world, fires due timers into `events`. Throws yamor::Error
  /// (FAILED_PRECONDITION) once the world diverged.
  void StepOnce(std::vector<snp::Frame>& events);

  /// Advances by `seconds` of simulated time (rounded to whole steps).
  void Advance(double seconds, std::vector<snp::Frame>& events);

  /// Power-on firmware for every module and the world at its initial state.
  void Reset();

  /// Simulated time [s].
  double Time() const { return world_.Time(); }
  /// The master node.
  int master() const { return master_; }
  /// True when frames addressed to `id` reach it.
  bool Reachable(int id) const;
  /// Firmware of module `id`; throws yamor::Error(NOT_FOUND).
  const ModuleFirmware& Firmware(int id) const;
  /// Module defect: the oscillator stops and the motor goes limp (or back).
  void SetModuleDefect(int id, bool defective);
  /// The ODE world (faults, ground, sensors).
  physics::World& world() { return world_; }
  /// The ODE world, read-only.
  const physics::World& world() const { return world_; }
  /// Traffic counters.
  const RobotStats& stats() const { return stats_; }

 private:
  void PowerOn();
  void HandleModuleFrame(const snp::Frame& frame, const snp::Message& message,
                         std::vector<snp::Frame>& out);
  void HandleBridgeCommand(const snp::Message& message, std::vector<snp::Frame>& out);
  // Applies a module message to one module's firmware; returns the reply or
  // nullopt when the message has none.
  std::optional<snp::Message> Apply(ModuleFirmware& module, const snp::Message& message);
  void RebuildNetworkIfDirty();
  void FireTimers(std::vector<snp::Frame>& events);
  ModuleFirmware& MutableFirmware(int id);

  RobotOptions options_;
  physics::World world_;
  int master_ = 0;
  std::map<int, ModuleFirmware> firmware_;
  std::map<int, int> link_parent_;  // child -> parent over bluetooth

  // The oscillators of every module, compiled from the firmware parameters;
  // recompiled (state remapped) when a parameter changes.
  bool network_dirty_ = true;
  cpg::Network network_;
  cpg::NetworkState network_state_;
  std::vector<std::optional<double>> set_points_;

  double slope_ = 0.0;            // ground tilt set by SetGround [rad]
  double slope_direction_ = 0.0;  // its downhill azimuth [rad]
  std::string morphology_snapshot_;  // ReadMorphology's text (taken at offset 0)
  bool has_morphology_snapshot_ = false;
  std::vector<uint8_t> scene_snapshot_;  // ReadScene's bytes (taken at offset 0)
  bool has_scene_snapshot_ = false;
  std::multimap<double, uint8_t> timers_;  // due time -> timer id
  // Recent accelerometer samples per module whose UART is on, oldest first.
  std::map<int, std::deque<physics::AccelerometerReading>> accelerometer_history_;
  snp::FrameDecoder decoder_;
  std::vector<snp::DecodeEvent> decode_events_;
  std::vector<snp::Frame> reply_scratch_;
  RobotStats stats_;
};

}  // namespace yamor::bridge
