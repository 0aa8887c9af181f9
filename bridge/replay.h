// Replay of a recorded SNP session (docs/snp.md "Recorded sessions") into a
// fresh emulated robot: the reality gap of thesis 6.3 made measurable. The
// host→robot frames of each recorded session drive a new bridge::Robot; the
// central module's simulated position is compared with the position samples
// the recording holds.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "physics/morphology.h"
#include "proto/snp/recording.h"

namespace yamor::bridge {

/// How a session's frames are placed in simulated time.
enum class ReplayTiming {
  /// The recording holds Step specials (a simulation was recorded): feeding
  /// them advances time exactly as recorded.
  kStepped,
  /// No Step specials (a real robot was recorded): before each frame the
  /// simulation is advanced to the frame's recorded time since the session
  /// opened.
  kClocked,
};

/// "stepped" or "clocked".
std::string_view ReplayTimingName(ReplayTiming timing);

/// What to replay into; unset fields come from each session's `open` line.
struct ReplayOptions {
  /// Resolves a world name or file (the `world` attribute or `world` below)
  /// to a morphology; required unless every session carries `morphology`.
  std::function<physics::Morphology(const std::string& world)> load_world;
  /// World for every session; overrides the recorded world and morphology.
  std::optional<std::string> world;
  /// Seed of the world and the oscillators' phases (default: recorded, else 0).
  std::optional<uint64_t> seed;
  /// Physics step [s] (default: recorded, else physics::WorldOptions's).
  std::optional<double> time_step;
  /// Master node, simulation id (default: recorded, else the central module).
  std::optional<int> master;
  /// Simulated seconds between table rows (> 0).
  double row_period = 1.0;
};

/// A position of the central module at a time.
struct PositionSample {
  double time = 0.0;                 ///< Simulated (or tracker) time [s].
  std::array<double, 3> position{};  ///< x, y, z [m].
};

/// One recorded position sample next to the replay's answer to the same
/// request (the simulated position at that point of the replay).
struct SampleComparison {
  int session = 0;            ///< Session index (0-based).
  PositionSample recorded;    ///< From a recorded RobotPosition reply.
  PositionSample replayed;    ///< The replayed robot's RobotPosition reply.
  double difference = 0.0;    ///< |recorded − replayed| position [m].
};

/// One row of the per-second table.
struct ReplayRow {
  int session = 0;                  ///< Session index (0-based).
  PositionSample simulated;         ///< Replayed central module at the row's time.
  /// The recorded sample nearest in time (with the replay's difference at
  /// the sample's time); absent when the session recorded none.
  std::optional<SampleComparison> nearest;
};

/// What happened in one session.
struct ReplaySessionSummary {
  int index = 0;                 ///< Session index (0-based).
  double opened_at = 0.0;        ///< Recording time of its `open` line [s].
  std::string world;             ///< World replayed into (name, file or source).
  uint64_t seed = 0;             ///< Seed used.
  double time_step = 0.0;        ///< Physics step used [s].
  ReplayTiming timing = ReplayTiming::kStepped;  ///< How time was advanced.
  uint64_t frames_fed = 0;       ///< Host→robot frames fed to the robot.
  uint64_t replies_recorded = 0; ///< Robot→host frames in the recording.
  uint64_t replies_replayed = 0; ///< Frames the replayed robot produced.
  /// Replayed frames differing from the recorded one at the same position
  /// of the reply sequence (plus the length difference).
  uint64_t replies_differing = 0;
  std::string first_difference;  ///< Description of the first differing reply.
  double end_time = 0.0;         ///< Simulated time at the end [s].
  std::string diverged;          ///< Why the world diverged, "" if it did not.
};

/// The outcome of a replay.
struct ReplayResult {
  std::vector<ReplaySessionSummary> sessions;  ///< One per session.
  std::vector<ReplayRow> rows;                 ///< The per-period table.
  std::vector<SampleComparison> samples;       ///< Every recorded sample compared.
  /// Recorded samples without a replayed counterpart (or the reverse).
  uint64_t unmatched_samples = 0;
  double mean_difference = 0.0;  ///< Mean of samples[].difference [m] (0 if none).
  double max_difference = 0.0;   ///< Max of samples[].difference [m] (0 if none).
};

/// Replays every session of `recording` (frames before the first `open`
/// line form a session of their own, described by the header). Throws
/// yamor::Error: INVALID_ARGUMENT for a session without a world (give
/// ReplayOptions::world) or a malformed recorded attribute, NOT_FOUND /
/// INVALID_ARGUMENT from load_world, OUT_OF_RANGE for row_period <= 0.
/// Thread-safety: a pure function of its arguments; builds its own robots.
ReplayResult Replay(const snp::Recording& recording, const ReplayOptions& options);

/// The table as CSV: a header line, then one line per row
/// (session,time,sim_x,sim_y,sim_z,sample_time,sample_x,sample_y,sample_z,
/// difference; sample columns empty without a sample).
std::string FormatReplayCsv(const ReplayResult& result);

/// A human-readable report: per session a summary and the table, then the
/// mean and max position difference over every recorded sample.
std::string FormatReplayReport(const ReplayResult& result);

}  // namespace yamor::bridge
