// The robot driver (the thesis's RobotCom, 5.5.2): holds the robot
// configuration, translates every API call into SNP frames for a Backend,
// queues parameter changes until Flush, maps real <-> simulation ids, builds
// the bluetooth network, and advances virtual time in simulation.
#pragma once

#include <array>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <thread>
#include <utility>
#include <vector>

#include "cpg/robot_config.h"
#include "host/backend.h"
#include "host/id_map.h"
#include "host/position_tracker.h"
#include "host/snp_link.h"
#include "host/state_log.h"
#include "host/ticket_mutex.h"
#include "cpg/parameters.h"
#include "physics/morphology.h"
#include "physics/render/scene.h"
#include "proto/snp/messages.h"
#include "proto/snp/recording.h"

namespace yamor::host {

// The driver's setters speak the configuration model's field names.
using cpg::CouplingField;
using cpg::ModuleField;

/// Returns true once the caller gave up (client cancelled, deadline passed).
/// Long operations poll it between chunks and then throw CANCELLED.
using CancelCheck = std::function<bool()>;

/// Fixed settings of a driver (from yamord's settings).
struct DriverOptions {
  /// Real -> simulation ids, applied to every frame sent to a simulation.
  IdMap id_map;
  /// The master node the settings expect (thesis C.1); when set, ConnectRobot
  /// refuses a configuration whose bluetooth tree has another root.
  std::optional<int> master;
  /// Default wait for each link's ConnectAck [s].
  double link_timeout = 2.0;
  /// Further ConnectRequests for a link that timed out or failed before
  /// ConnectRobot gives up on it (a radio link can miss once).
  int link_retries = 2;
  /// Wait for a module's or the bridge's reply on a real link [s] (a
  /// simulation answers synchronously and never waits).
  double reply_timeout = 1.0;
  /// Virtual seconds stepped per Step frame in a Sleep; cancellation and
  /// other calls get in between chunks.
  double sleep_chunk = 0.05;
  /// Longest Sleep [s].
  double max_sleep = 24.0 * 3600.0;
  /// Where RobotPosition and WatchState read a tracked position (yamord's LED
  /// tracker): always on a real robot (unset: UNIMPLEMENTED there), and on a
  /// simulation when `position_from_tracker`.
  std::shared_ptr<PositionTracker> tracker;
  /// On a simulation, RobotPosition and WatchState report what `tracker`
  /// sees instead of the simulation's own position (yamord --position-source
  /// tracker). The camera's clock must be the simulation's (yamor-camapp's
  /// is): a position is the one captured at the simulation's present time.
  bool position_from_tracker = false;
  /// Wraps every backend the driver installs (OpenSimulation, AttachBackend),
  /// e.g. in a RecordingBackend for `yamord --record`; `attributes` describe
  /// it (backend, world, and for a simulation seed, time_step, master,
  /// morphology). Unset: backends are used as built.
  std::function<std::unique_ptr<Backend>(std::unique_ptr<Backend> backend,
                                         const snp::RecordAttributes& attributes)>
      backend_wrapper;
};

/// A resolved simulation to open: a morphology plus, optionally, a new
/// configuration (otherwise the driver keeps its current one).
struct SimulationSpec {
  physics::Morphology morphology;         ///< World (simulation ids).
  std::string world_name;                 ///< Name shown by GetInfo.
  std::optional<cpg::RobotConfig> config; ///< Replaces the configuration when set.
  uint64_t seed = 0;                      ///< World and oscillator seed.
  double time_step = 0.0;                 ///< Physics step [s]; 0 = default.
};

/// What OpenSimulation reports.
struct OpenedSimulation {
  std::vector<int> module_ids;  ///< Real ids of the world's modules, ascending sim order.
  int central_module = 0;       ///< Real id of the tracked module.
};

/// Result of ConnectRobot.
struct ConnectResult {
  int links = 0;         ///< Links established.
  double elapsed = 0.0;  ///< Wall-clock seconds taken.
  int frames_sent = 0;   ///< SNP frames sent (links and configuration).
};

/// A tristate control message (thesis C.2.4) and its targets.
struct ControlMessage {
  snp::Tristate uart = snp::Tristate::kUnchanged;    ///< Sensor-board serial line.
  snp::Tristate cpg = snp::Tristate::kUnchanged;     ///< Oscillator.
  snp::Tristate motors = snp::Tristate::kUnchanged;  ///< Servo power.
  std::vector<int> module_ids;  ///< Targets (real ids), used when `all` is false.
  /// Every module of the configuration; motor-on then skips inactive modules
  /// (all-zero oscillator, host::IsInactive), which stay unpowered unless named.
  bool all = false;
};

/// A motor defect (C.2.6).
enum class MotorDefect {
  kNone,   ///< Repaired.
  kLimp,   ///< No torque.
  kStuck,  ///< Locked at its angle.
};

/// The SNP SetMotorFault value of `defect`.
snp::MotorFault ToFault(MotorDefect defect);

/// A ground change; absent fields keep their value.
struct GroundChange {
  std::optional<double> friction;         ///< Coulomb coefficient (> 0).
  std::optional<double> slope;            ///< [rad] in [0, π/2).
  std::optional<double> slope_direction;  ///< Downhill azimuth [rad].
};

/// Checks a ground change's values before they reach the world:
/// INVALID_ARGUMENT for NaN/inf, OUT_OF_RANGE for friction outside (0, 100]
/// or slope outside [0, π/2). Absent fields pass. Pure.
void CheckGroundValues(const GroundChange& change);

/// One accelerometer sample.
struct AccelerometerSample {
  std::array<int, 3> counts{};             ///< Raw 10-bit counts.
  std::array<double, 3> acceleration{};    ///< (count - zero)·δ [m/s²], module frame.
};

/// A module's orientation from its accelerometer (GetOrientation).
struct ModuleOrientation {
  bool valid = false;                 ///< The mean looks like gravity alone.
  std::array<double, 3> up{0, 0, 1};  ///< World up in the module frame (unit).
  double tilt = 0;                    ///< Angle of `up` to the reference [rad].
  bool upside_down = false;           ///< valid and tilt > kUpsideDownTilt.
  double magnitude = 0;               ///< |mean| [m/s²].
  double max_deviation = 0;           ///< Largest ||sample| − g| [m/s²].
  int samples = 0;                    ///< Samples used.
};

/// Tilt beyond which GetOrientation calls a module upside down [rad] (120°):
/// far from what walking reaches, close enough to a flip (thesis 7.5.2).
inline constexpr double kUpsideDownTilt = 2.0943951023931957;

/// What GetInfo shows about the driver.
struct DriverInfo {
  std::string backend;        ///< "simulation", "serial", "fake" or "none".
  std::string world;          ///< Name of the open world ("" when none).
  int master_node = 0;        ///< Master node (real id).
  bool connected = false;     ///< ConnectRobot succeeded since open/reset.
  double free_run_factor = 0; ///< Free-run real-time factor, 0 = off.
};

/// The stateful robot driver.
///
/// It knows the robot only through SNP bytes on one SnpLink: everything a
/// simulation alone can do (time, step, position, ground, defects,
/// divergence, morphology readback) is a bridge special (docs/snp.md).
///
/// Thread-safety: every public method may be called from any thread. One
/// first-come-first-served mutex (`mutex_`, a TicketMutex) serialises
/// everything that touches the robot or the configuration: the robot is one
/// stateful device. A virtual-time Sleep releases it between chunks, and the
/// ticket order hands the robot to every caller that queued meanwhile (other
/// calls, the free-run thread, WatchState) before the next chunk; a real-time
/// Sleep does not hold it while waiting. The WatchState log (StateLog) has
/// its own mutex.
class RobotDriver {
 public:
  /// A driver without a backend (no simulation open) holding `config`.
  RobotDriver(DriverOptions options, cpg::RobotConfig config);
  /// Stops the free-run thread.
  ~RobotDriver();
  RobotDriver(const RobotDriver&) = delete;
  RobotDriver& operator=(const RobotDriver&) = delete;

  // ---- Backend ----------------------------------------------------------

  /// Opens (or replaces) the simulation: INVALID_ARGUMENT when a module of
  /// the configuration is missing from the world, OUT_OF_RANGE for a bad
  /// time step. The robot starts at power-on, not connected.
  OpenedSimulation OpenSimulation(SimulationSpec spec);
  /// Uses `backend` (a fake in tests, later the serial link); the robot is
  /// not connected.
  void AttachBackend(std::unique_ptr<Backend> backend, std::string world_name);
  /// Drops the backend; later robot calls get FAILED_PRECONDITION. No-op
  /// when none is open.
  void CloseSimulation();
  /// True when the backend is a simulation.
  bool SimulationModeEnabled() const;
  /// Restores the simulation to its state when opened (time 0, power-on,
  /// not connected; defects and ground changes cleared).
  void ResetSimulation();
  /// The open world's morphology as the robot is now, after ConnectModules,
  /// DisconnectModule and scripts (physics::World::CurrentMorphology;
  /// simulation ids). FAILED_PRECONDITION without an open simulation or when
  /// the current body has no valid morphology; UNIMPLEMENTED on a backend
  /// without a simulated robot.
  physics::Morphology GetMorphology() const;
  /// The world as it is now, for the renderer: every module's body and handle
  /// pose with real ids, the shape, the slope (chunked ReadScene specials,
  /// docs/snp.md; the robot lock is held only while reading).
  /// FAILED_PRECONDITION without an open simulation or when the world is
  /// diverged; UNIMPLEMENTED on a real robot.
  render::Scene GetScene();

  // ---- Configuration (works with or without a backend) ------------------

  /// Replaces the configuration (XML, thesis schema). INVALID_ARGUMENT with
  /// file:line when malformed or when a module is missing from the open
  /// world. Every parameter is queued for the next Flush; the robot must be
  /// connected again when the bluetooth tree changed.
  void LoadConfig(std::string_view xml, std::string_view source_name);
  /// The configuration as canonical XML.
  std::string SaveConfig() const;
  /// A copy of the configuration.
  cpg::RobotConfig Config() const;
  /// Module ids in configuration order.
  std::vector<int> GetAllModulesId() const;
  /// A module parameter; NOT_FOUND for an unknown module.
  double GetModuleValue(int id, ModuleField field) const;
  /// Sets a module parameter (see SetModuleField) and queues it.
  void SetModuleValue(int id, ModuleField field, double value);
  /// A coupling parameter; NOT_FOUND when the coupling is absent.
  double GetCouplingValue(int from, int to, CouplingField field) const;
  /// Sets a coupling parameter (see SetCouplingField) and queues it.
  void SetCouplingValue(int from, int to, CouplingField field, double value);
  /// Adds or replaces a coupling (see host::AddCoupling) and queues it.
  void AddCoupling(int from, int to, double phase, double weight);
  /// Removes every coupling; queues a ClearCouplings per module.
  void RemoveAllCouplings();
  /// Number of queued changes (one per module parameter group or coupling).
  int PendingChanges() const;

  // ---- Robot ------------------------------------------------------------

  /// Builds the bluetooth network in tree order (parent before child), one
  /// ConnectRequest at a time, each waiting for its ConnectAck up to
  /// `link_timeout` seconds (<= 0: the default) and retried up to
  /// `link_retries` times. UNAVAILABLE names the link and the attempts:
  /// "link 4 -> 7 timed out after 2 s (3 attempts)". Unless `links_only`,
  /// then sends the whole configuration (as Refresh).
  ConnectResult ConnectRobot(double link_timeout, bool links_only, const CancelCheck& cancel);
  /// Sends the queued changes; returns the number of frames. On an error the
  /// changes not yet sent stay queued and the message says how many.
  int Flush();
  /// Resends every parameter and coupling; returns the number of frames.
  /// After the link was lost and reopened (the peer may have restarted at
  /// power-on), first links the robot again (as ConnectRobot) and afterwards
  /// restores the control switches and defects it had: the configuration
  /// survives the loss.
  int Refresh();
  /// Sends a tristate control message to each target (unicast, acknowledged).
  /// Motor-on is never forwarded to a module with a motor defect.
  void SendControlMessage(const ControlMessage& message);
  /// Waits `seconds`: in simulation (unless `real_time`) steps the world as
  /// fast as possible in chunks; otherwise waits on the clock. Simulated
  /// time others step meanwhile counts; when another caller resets or
  /// reopens the world, the time still owed counts from its new clock.
  /// Returns the elapsed time afterwards. CANCELLED when `cancel` fires, UNAVAILABLE
  /// when the driver shuts down, FAILED_PRECONDITION when the world diverges.
  double Sleep(double seconds, bool real_time, const CancelCheck& cancel);
  /// Virtual time in simulation; wall-clock seconds since the backend was
  /// attached otherwise.
  double ElapsedTime();
  /// Pose of the central module: the simulation's, or the LED tracker's
  /// (DriverOptions::tracker) on a real robot and, with
  /// `position_from_tracker`, on a simulation. On a real robot the latest
  /// fresh position, time in seconds since the robot was attached or
  /// connected; UNIMPLEMENTED without a tracker. On a simulation the first
  /// position the camera captured at or after the present simulation time
  /// (waiting for it), time the capture time. UNAVAILABLE naming the tracker
  /// when it is stale, lost or does not see the LED: never a stale value.
  RobotPose RobotPosition();
  /// The simulation's own pose of the central module, whatever the position
  /// source (what yamor-camapp films); UNIMPLEMENTED on a real robot.
  RobotPose SimulatedPosition();
  /// Servo angles of `ids` (all modules when empty), read over SNP.
  std::vector<std::pair<int, double>> GetServoAngles(const std::vector<int>& ids);
  /// The last `samples` (1..16; 0 = 1) accelerometer samples of a module.
  std::vector<AccelerometerSample> GetAccelerometer(int id, int samples);
  /// Orientation of module `id` from the mean of its latest `samples`
  /// (1..16; 0 = 16) accelerometer samples, tilt against `reference_up`
  /// (module frame; zero = +z). Same errors as GetAccelerometer, plus
  /// kInvalidArgument for a non-finite reference.
  ModuleOrientation GetOrientation(int id, int samples, std::array<double, 3> reference_up);
  /// Marks a motor defect (C.2.6): sends motor-off when connected, blocks
  /// later motor-on, and in simulation makes the servo limp or stuck.
  void SetMotorDefect(int id, MotorDefect defect);
  /// Marks a whole module defect (simulation only; UNIMPLEMENTED otherwise).
  void SetModuleDefect(int id, bool defective);
  /// Changes friction and slope (simulation only).
  void SetGround(const GroundChange& change);
  /// Turns the robot upside down about its centre (simulation only; a
  /// bridge special, thesis 7.5.2).
  void TurnUpsideDown();
  /// Physically attaches free module `from` (a bridge command; backends
  /// without reconfiguration answer UNIMPLEMENTED). angle_degrees: multiple
  /// of 15 in [0, 360).
  void ConnectModules(int from, snp::Connector from_connector, int to,
                      snp::Connector to_connector, double angle_degrees);
  /// Detaches a module from all its neighbours (a bridge command).
  void DisconnectModule(int id);
  /// Runs a transformation script (thesis C.2.7: <script> with connect,
  /// disconnect and pause delay="ms"), parsed by physics::TransformationScript
  /// and validated whole before anything runs; each command is sent as SNP
  /// (ConnectModules / DisconnectModule / a virtual-time Sleep). Errors name
  /// the script line.
  void RunTransformationScript(std::string_view xml, const CancelCheck& cancel);
  /// Free-run mode: a background thread steps the simulation at
  /// `real_time_factor` simulated seconds per wall second (0 = off,
  /// OUT_OF_RANGE outside [0, 100]). A diverged world idles until reset; any
  /// other failure stops free-run with a "free_run_stopped" WatchState event.
  void SetFreeRun(double real_time_factor);

  // ---- State stream -----------------------------------------------------

  /// Starts a watcher: records the current pose so the first update is
  /// immediate. Call EndWatch when the stream ends.
  WatchCursor BeginWatch();
  /// Ends a watcher started with BeginWatch.
  void EndWatch();
  /// Waits up to `wait` for the next update at least `period` (virtual)
  /// seconds after the cursor's last one, or for new events. nullopt when
  /// nothing new arrived (or the driver shuts down).
  std::optional<StateUpdate> WaitForState(WatchCursor& cursor, double period,
                                          std::chrono::milliseconds wait);

  // ---- Daemon -----------------------------------------------------------

  /// Backend, world, master, connection, free-run factor.
  DriverInfo Info() const;
  /// The id mapping of this driver.
  const IdMap& id_map() const { return options_.id_map; }
  /// Cancels long calls (they fail with UNAVAILABLE "shutting down"),
  /// stops free-run and wakes watchers. Irreversible.
  void Shutdown();
  /// True after Shutdown.
  bool shutting_down() const { return shutdown_.load(); }

 private:
  struct PendingModule {
    bool amplitude = false;
    bool offset = false;
    bool speed = false;
    bool limits = false;
    bool clear_couplings = false;
    std::set<int> couplings;  // `to` ids of couplings to (re)send
    int Count() const;
  };

  using Lock = std::unique_lock<TicketMutex>;

  // All *Locked methods require mutex_ held.
  Backend& RequireBackendLocked(std::string_view what) const;
  SnpLink& RequireSimulationLocked(std::string_view what) const;
  void RequireConnectedLocked(std::string_view what) const;
  void InstallBackendLocked(std::unique_ptr<Backend> backend);
  // Builds the bluetooth tree (SetMasterNode on a simulation, then each link
  // with its retries); counts into `result`.
  void LinkTreeLocked(double timeout, const CancelCheck& cancel, ConnectResult& result);
  // Asks the simulation's time step and accelerometer scale (GetSimInfo).
  void ReadSimInfoLocked();
  // SnpLink's reopened handler: the robot is no longer linked.
  void OnLinkReopenedLocked();
  // Refresh after a reopened link: link, configure, restore switches and defects.
  int RestoreAfterReopenLocked();
  // Shorthands for link_ (mutex_ held, a backend attached).
  snp::Message ModuleCallLocked(int id, const snp::Message& message, snp::MessageType reply);
  snp::Message BridgeRequestLocked(const snp::Message& message, snp::MessageType reply);
  // Throws FAILED_PRECONDITION when the world is known to be diverged.
  void CheckDivergedLocked();
  // Asks the bridge (GetDivergence); when diverged, records it, pushes the
  // event and throws FAILED_PRECONDITION.
  void QueryDivergenceLocked();
  void StepLocked(double seconds);
  void RecordSampleLocked();
  // The simulation's pose (bridge special); records the time in sim_clock_.
  RobotPose SimulatedPoseLocked();
  // Sets sim_time_ and sim_clock_.
  void SetSimTimeLocked(double seconds);
  // Publishes where tracked samples go for WatchState (tracker_feed_, tracker_epoch_).
  void UpdateTrackerFeedLocked();
  // The tracker's handler (tracker thread): a WatchState sample.
  void OnTrackedPose(const TrackedPose& pose);
  int SendModuleConfigLocked(const cpg::ModuleParams& module, const PendingModule* only);
  int RefreshLocked();
  void MarkAllPendingLocked();
  // Every configured module is a (non-free) module of `morphology`, or of
  // `now` (the body as it is now; may be null).
  void CheckConfigAgainstWorldLocked(const cpg::RobotConfig& config, const physics::Morphology& morphology,
                                     const physics::Morphology* now = nullptr) const;
  void ResetRobotStateLocked();
  void PushEvent(StateEvent event) { state_.Push(std::move(event)); }
  void FreeRunLoop();
  double SleepRealTime(double seconds, const CancelCheck& cancel);

  const DriverOptions options_;
  std::atomic<bool> shutdown_{false};

  mutable TicketMutex mutex_;
  cpg::RobotConfig config_;                      // guarded by mutex_
  std::map<int, PendingModule> pending_;         // guarded by mutex_
  std::unique_ptr<Backend> backend_;             // guarded by mutex_
  std::unique_ptr<SnpLink> link_;                // guarded by mutex_ (over backend_)
  std::optional<physics::Morphology> world_morphology_;  // guarded by mutex_ (as opened)
  double accelerometer_zero_ = 512.0;            // guarded by mutex_ (SimInfo on a simulation)
  double accelerometer_count_ = 0.0395;          // guarded by mutex_ (MMA7260Q, 1.5 g range)
  std::string world_name_;                       // guarded by mutex_
  bool connected_ = false;                       // guarded by mutex_
  bool relink_needed_ = false;                   // guarded by mutex_ (link reopened while connected)
  std::map<int, snp::Control> control_state_;    // guarded by mutex_ (last switches per real id)
  bool diverged_ = false;                        // guarded by mutex_
  std::string divergence_;                       // guarded by mutex_
  double sim_time_ = 0.0;                        // guarded by mutex_
  double time_step_ = 0.001;                     // guarded by mutex_
  std::chrono::steady_clock::time_point attached_at_;  // guarded by mutex_
  std::map<int, MotorDefect> motor_defects_;     // guarded by mutex_ (real ids)
  std::set<int> module_defects_;                 // guarded by mutex_ (real ids)
  double slope_ = 0.0;                           // guarded by mutex_
  double slope_direction_ = 0.0;                 // guarded by mutex_
  double free_run_factor_ = 0.0;                 // guarded by mutex_

  // Wakes real-time sleeps and the free-run thread on shutdown or change.
  std::condition_variable_any wake_;             // used with mutex_
  std::thread free_run_thread_;                  // guarded by mutex_ (started once)

  // Read by the tracker's thread without mutex_: what WatchState samples come
  // from the tracker (kTrackerFeed*), the real robot's time epoch, and the
  // latest simulation time the driver knows (an upper bound on the capture
  // time of any frame of the present simulation clock).
  static constexpr int kTrackerFeedNone = 0;   // samples from the simulation, or none
  static constexpr int kTrackerFeedReal = 1;   // real robot: time since tracker_epoch_
  static constexpr int kTrackerFeedSim = 2;    // simulation: the camera's (= simulation) time
  std::atomic<int> tracker_feed_{kTrackerFeedNone};
  std::atomic<std::chrono::steady_clock::rep> tracker_epoch_{0};
  std::atomic<double> sim_clock_{0.0};

  StateLog state_;  // WatchState's events and samples (own mutex)
};

}  // namespace yamor::host
