// The host pool (thesis 5.7.2, the simulation organizer): an Evaluator that
// runs candidates as stateless Evaluate RPCs on a pool of yamord daemons.
// Work waits in one FIFO queue; each host takes at most its worker capacity
// at once. A host that fails (it died, timed out, is overloaded) is marked
// down, its evaluations go back to the front of the queue for the others,
// and it is health-checked again with exponential backoff until it answers.
// The membership may change while batches run (SetHosts, HostListWatcher).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <thread>
#include <vector>

#include "optimizer-plugins/framework/evaluator.h"

namespace yamor::optimizer {

/// A yamord address.
struct HostAddress {
  std::string host;  ///< Name or IP address (an IPv6 literal without brackets).
  int port = 0;      ///< TCP port, 1..65535.

  /// "host:port" ("[::1]:2224" for IPv6 literals): the gRPC target and the
  /// name in Evaluation::host, logs and errors.
  std::string ToString() const;
};

/// Parses a --hosts value: "H:P,H:P,..." or "@FILE" (one host:port per
/// line; '#' starts a comment; blank lines are skipped). IPv6 literals are
/// written "[::1]:2224". Throws yamor::Error kInvalidArgument naming the bad
/// entry (and FILE:LINE for files), for an empty list and for duplicates;
/// kNotFound when FILE cannot be read.
std::vector<HostAddress> ParseHosts(const std::string& spec);

/// A motor defect of the evaluated robot (EvaluateRequest.motor_defects).
enum class MotorDefect {
  kOk,     ///< No defect (checked, changes nothing).
  kLimp,   ///< No torque.
  kStuck,  ///< Locked at its angle.
};

/// The fixed part of every EvaluateRequest; Candidate::parameters become the
/// request's parameters.
struct EvaluationSettings {
  std::string config_xml;      ///< Robot configuration XML; empty: the world's built-in one.
  std::string world;           ///< Built-in world name; empty: the daemon's world.
  std::string morphology_xml;  ///< Overrides `world` when set.
  double warmup = 8;           ///< [s] before the measured span; 0 = daemon default (8).
  double duration = 12;        ///< [s] measured span; 0 = daemon default (12).
  uint64_t seed = 0;           ///< World and oscillator seed.
  double time_step = 0;        ///< Physics step [s]; 0 = daemon default.
  /// Deadline of one Evaluate RPC [s]; 0: 10 * (warmup + duration) + 60.
  double deadline_seconds = 0;
  // The evaluated robot's condition (a model of a live robot: issue 13
  // "model" mode). Real module ids; the daemon validates them (NOT_FOUND,
  // INVALID_ARGUMENT, OUT_OF_RANGE are caller errors of every evaluation).
  /// Motor defects: (module, defect); the motor is switched off and faulted.
  std::vector<std::pair<int, MotorDefect>> motor_defects;
  /// Modules with a whole-module defect (oscillator dead, motor limp).
  std::vector<int> module_defects;
  std::optional<double> ground_friction;         ///< Coulomb coefficient in (0, 100]; unset: the world's.
  std::optional<double> ground_slope;            ///< [rad] in [0, π/2); unset: the world's (flat).
  std::optional<double> ground_slope_direction;  ///< Downhill azimuth [rad]; unset: the world's.
  bool upside_down = false;                      ///< Start turned upside down.
};

/// How FilmCandidate films an evaluation (EvaluateRequest.frames): a
/// camera following the central module. Thread-safety: plain value.
struct FilmOptions {
  int width = 320;          ///< Frame width [px], 1..4096.
  int height = 240;         ///< Frame height [px], 1..4096.
  double frame_rate = 25;   ///< Frames per simulated second, (0, 240].
  std::optional<double> camera_distance;   ///< Eye to module [m]; unset: the daemon's default.
  std::optional<double> camera_elevation;  ///< Above the horizon [rad]; unset: default.
  std::optional<double> camera_azimuth;    ///< Module-to-eye direction [rad]; unset: default.
  bool hide_labels = false;  ///< No module ids next to the modules.
  bool hide_legend = false;  ///< No legend strip.
  /// Deadline of the filmed Evaluate [s]; 0: 3 x the evaluations' deadline.
  double deadline_seconds = 0;
  /// True: the host makes the MP4 itself (EvaluationFrames.mp4) and sends
  /// only `png_frames` as PNG; a host without ffmpeg sends every frame.
  bool mp4 = false;
  /// With mp4: indices of the frames also wanted as PNG (at most 64).
  std::vector<uint32_t> png_frames;
};

/// One frame of a filmed evaluation.
struct FilmFrame {
  double time = 0.0;  ///< Simulated time [s] since the start of the evaluation.
  std::string png;    ///< 8-bit RGB PNG bytes.
  uint32_t index = 0; ///< 0, 1, ... in the film.
};

/// A filmed evaluation: its result and its frames in order.
struct FilmResult {
  Evaluation evaluation;         ///< As EvaluateBatch would report it.
  /// t = 0, 1/frame_rate, ...: every frame, or with FilmOptions::mp4 and an
  /// MP4 made only the png_frames.
  std::vector<FilmFrame> frames;
  std::string mp4;               ///< With FilmOptions::mp4: the host's MP4; empty when not made.
  int mp4_frames = 0;            ///< Frames in `mp4`.
  std::string video_note;        ///< Why `mp4` is empty although asked for.
};

/// How the pool treats failing hosts.
struct PoolOptions {
  double health_timeout = 5;  ///< Deadline of one health check (Health/Check + GetInfo) [s].
  double retry_initial = 0.5; ///< First delay before re-checking a failed host [s].
  double retry_max = 30;      ///< Cap of the doubling re-check delay [s].
  /// No healthy host for this long while a batch waits: EvaluateBatch throws
  /// kUnavailable [s].
  double give_up_after = 120;
  /// Host failures one evaluation may meet before EvaluateBatch throws
  /// kUnavailable naming the candidate.
  int max_attempts = 5;
};

/// What the pool knows about one host (a snapshot).
struct HostStatus {
  HostAddress address;     ///< The host.
  bool up = false;         ///< Passed its last health check and has not failed since.
  int capacity = 0;        ///< Evaluations it runs at once (its GetInfo worker_capacity).
  int in_flight = 0;       ///< Evaluate RPCs not yet returned (cancelled ones included).
  long long completed = 0; ///< Evaluations it scored for a batch.
  /// Times it was marked down after an Evaluate failure, plus failed health checks.
  long long failures = 0;
  std::string last_error;  ///< Text of the last failure ("" if none).
  /// Removed from the list (SetHosts): takes no new work, finishes what it
  /// runs, then leaves Status().
  bool draining = false;
};

/// Runs evaluations on yamord hosts over gRPC.
///
/// A host is used once it passes a health check: grpc.health.v1.Health/Check
/// must answer SERVING (a server without the health service, UNIMPLEMENTED,
/// is accepted) and GetInfo must succeed; its worker_capacity bounds the
/// evaluations sent to it at once. Evaluate replies UNAVAILABLE,
/// DEADLINE_EXCEEDED, INTERNAL, RESOURCE_EXHAUSTED (or any other code except
/// the caller errors below, including a CANCELLED the pool did not ask for)
/// count as a host failure: the host is marked down, every evaluation it
/// was running is re-queued at the front (each costs an attempt), its
/// late replies are ignored and its RPCs cancelled, and it is re-checked
/// after retry_initial * 2^k (capped at retry_max; k resets after its next
/// successful evaluation). INVALID_ARGUMENT, OUT_OF_RANGE, NOT_FOUND and
/// FAILED_PRECONDITION are caller errors: EvaluateBatch throws that code with
/// the host's message, naming the candidate, without retrying. Every slot of
/// a batch is filled exactly once.
///
/// The membership can change while batches run: SetHosts adds hosts (used
/// once they pass a health check) and drains removed ones (no new work; the
/// evaluations they run finish there, or are re-queued if the host fails;
/// then the host is dropped), so a membership change loses and repeats no
/// evaluation.
///
/// Thread safety: every public method may be called from any thread at any
/// time; concurrent EvaluateBatch calls share the hosts in FIFO order. The
/// destructor must not run concurrently with other calls; it cancels and
/// waits for every RPC still running, then releases every client context,
/// stub and channel on its own thread (a gRPC callback thread never drops
/// the last reference to one: issue 17's double free).
class HostPool final : public Evaluator {
 public:
  /// Connects to `hosts` and health-checks each once (waiting at most about
  /// options.health_timeout) before returning; hosts that fail are retried in
  /// the background. Throws kInvalidArgument for an empty or duplicated host
  /// list or invalid options, kNotFound for a negative module id in the
  /// settings' defects.
  HostPool(std::vector<HostAddress> hosts, EvaluationSettings settings, PoolOptions options = {});
  /// Cancels every RPC and waits for them to return.
  ~HostPool() override;
  HostPool(const HostPool&) = delete;
  HostPool& operator=(const HostPool&) = delete;

  /// Queues the batch behind earlier ones and waits for every slot; see
  /// Evaluator::EvaluateBatch for the errors.
  std::vector<Evaluation> EvaluateBatch(const std::vector<Candidate>& batch) override;
  /// Ends every running and future batch with kCancelled and cancels their RPCs.
  void RequestStop() override;
  /// Sum of the capacities of the hosts that are up (at least 1).
  int Capacity() const override;

  /// Evaluates `candidate` once more, with the settings of every evaluation,
  /// on one host of the pool, and returns its frames or its MP4 (issue 14: the video of
  /// the best gait). Hosts that are up are tried in turn (then the others)
  /// until one films it; a host's failure here does not mark it down and the
  /// evaluation counts in no host's `completed`. Independent of RequestStop:
  /// `cancelled` (polled every 0.1 s) ends it instead. Throws yamor::Error:
  /// kCancelled when `cancelled` fired; the host's code and message, naming
  /// the host, for a caller error (INVALID_ARGUMENT, OUT_OF_RANGE, NOT_FOUND,
  /// FAILED_PRECONDITION); kUnavailable naming every host's failure when no
  /// host could film it (e.g. none has a renderer).
  FilmResult FilmCandidate(const Candidate& candidate, const FilmOptions& options,
                           const std::function<bool()>& cancelled = {});

  /// One snapshot per host (draining ones included), in the order they
  /// joined.
  std::vector<HostStatus> Status() const;

  /// Makes `hosts` the membership: hosts not in the pool join after a
  /// health check (checked in the background; this does not wait), hosts
  /// not in `hosts` drain, draining hosts listed again are kept. Throws
  /// kInvalidArgument for an empty or duplicated list (nothing changes).
  void SetHosts(std::vector<HostAddress> hosts);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Follows a host file (`--hosts @FILE`): polls its modification time, size
/// and inode every `poll_seconds`, and once a change has held still for one
/// poll (a file being written is not read half-way) re-reads it with
/// ParseHosts and applies it with HostPool::SetHosts. A file that cannot be
/// read or parsed is logged and the membership kept.
///
/// Thread safety: one background thread; the destructor stops it. The pool
/// must outlive the watcher.
class HostListWatcher {
 public:
  /// Starts following `path` (without '@') for `pool`; the file as read now
  /// is taken as already applied.
  HostListWatcher(std::string path, HostPool& pool, double poll_seconds = 0.5);
  /// Stops the thread.
  ~HostListWatcher();
  HostListWatcher(const HostListWatcher&) = delete;
  HostListWatcher& operator=(const HostListWatcher&) = delete;

  /// Host lists applied since the start.
  long long Applied() const;

 private:
  struct State;
  std::shared_ptr<State> state_;
  std::thread thread_;
};

}  // namespace yamor::optimizer
