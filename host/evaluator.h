// Evaluate: the stateless gait evaluation optimizers use (DESIGN.md). Each
// evaluation builds its own emulated robot from a morphology and a
// configuration with named parameter values applied, configures it over SNP,
// runs a warm-up and a measured span, and reports the velocity of thesis
// 6.2.1. Evaluations run on the Evaluate workers (host/worker_pool.h).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "cpg/robot_config.h"
#include "host/driver.h"
#include "host/frames.h"
#include "host/id_map.h"
#include "physics/morphology.h"

namespace yamor::host {

/// Default warm-up [s] before the measured span (thesis chapter 6).
inline constexpr double kDefaultWarmup = 8.0;
/// Default measured span [s].
inline constexpr double kDefaultDuration = 12.0;

/// How an evaluation is filmed (EvaluateRequest.frames): frames at
/// t = 0, 1/frame_rate, ... over the whole evaluation, warm-up included.
/// Thread-safety: plain value.
struct EvaluationFilm {
  FrameSpec frame;          ///< How each frame is drawn (size, camera, options).
  double frame_rate = 25;   ///< Frames per simulated second, (0, kMaxFrameRate].
  /// True: the frames go raw to ffmpeg on this machine and come back as one
  /// MP4 (EvaluationResult::mp4); only `png_frames` are PNG-encoded.
  bool mp4 = false;
  /// With mp4: indices of frames also returned as PNG (at most kMaxPngFrames).
  std::vector<uint32_t> png_frames;
};

/// Most frames a film made into an MP4 may also return as PNG.
inline constexpr std::size_t kMaxPngFrames = 64;

/// Most PNG bytes the frames of one evaluation may hold (512 MiB).
inline constexpr std::size_t kMaxEvaluationFrameBytes = std::size_t{512} << 20;

/// Frames of a filmed evaluation of `seconds` (warm-up + duration):
/// max(1, round(seconds * frame_rate)).
uint32_t EvaluationFrameCount(double seconds, double frame_rate);

/// One evaluation's inputs.
struct EvaluationSpec {
  physics::Morphology morphology;  ///< World (simulation ids).
  cpg::RobotConfig config;         ///< Configuration (real ids).
  IdMap id_map;                    ///< Real -> simulation ids.
  /// Named parameters (amplitude.3, phase.2.5, ...) applied over `config`.
  std::vector<std::pair<std::string, double>> parameters;
  double warmup = kDefaultWarmup;      ///< [s], >= 0.
  double duration = kDefaultDuration;  ///< [s], > 0.
  uint64_t seed = 0;                   ///< World and oscillator seed.
  double trajectory_period = 0.0;      ///< > 0: sample the trajectory every period [s].
  double time_step = 0.0;              ///< Physics step [s]; 0 = default.
  // The robot's condition at t = 0 (issue 13 "model" mode), real ids.
  /// Motor defects: each module's motor is switched off and faulted, as
  /// RobotDriver::SetMotorDefect on a connected robot; kNone entries are skipped.
  std::vector<std::pair<int, MotorDefect>> motor_defects;
  /// Module defects (oscillator dead, motor limp; SetModuleDefect) as
  /// (module, defective); `false` entries are checked and change nothing.
  std::vector<std::pair<int, bool>> module_defects;
  GroundChange ground;       ///< Ground friction and slope; absent: the world's.
  bool upside_down = false;  ///< Turned upside down at t = 0 (TurnUpsideDown).
  /// Set: frames of the evaluation, rendered on the evaluating thread from
  /// its own world (render::ThreadRenderer: one GL context per thread).
  std::optional<EvaluationFilm> film;
};

/// A trajectory sample.
struct TrajectoryPoint {
  double time = 0.0;                 ///< Simulated time [s].
  std::array<double, 3> position{};  ///< Central module position [m].
};

/// One evaluation's outputs.
struct EvaluationResult {
  double velocity = 0.0;  ///< distance / duration [m/s]; 0 when diverged.
  double distance = 0.0;  ///< Ground-plane (x, y) distance warm-up -> end [m].
  RobotPose final_pose;   ///< Central module at the end (or when it diverged).
  std::vector<TrajectoryPoint> trajectory;  ///< When trajectory_period > 0.
  bool diverged = false;    ///< The world diverged.
  std::string divergence;   ///< Why, when diverged.
  double wall_seconds = 0.0;  ///< Wall-clock time taken.
  /// With EvaluationSpec::film: the frames in order (index 0, 1, ...); a
  /// diverged world ends them early. With film->mp4 and a video made: only
  /// the frames of film->png_frames.
  std::vector<EncodedFrame> frames;
  std::vector<uint8_t> mp4;  ///< With film->mp4: the film (H.264 MP4); empty when not made.
  uint32_t mp4_frames = 0;   ///< Frames in `mp4`.
  std::string video_note;    ///< With film->mp4: why `mp4` is empty (no ffmpeg here).
};

/// Runs one evaluation on the calling thread. Deterministic: the same spec
/// gives bit-identical results on the same build. Errors: the parameter
/// errors of ApplyParameters, INVALID_ARGUMENT for configuration modules
/// missing from the world, OUT_OF_RANGE for bad timings; for the condition
/// fields NOT_FOUND naming a motor-defect module not in the configuration or
/// a module-defect module not in the world, INVALID_ARGUMENT for a module
/// listed twice, CheckGroundValues' errors, for the film
/// ValidateFrameSpec's and ValidateFrameRate's errors and OUT_OF_RANGE for
/// more than kMaxRecordFrames frames, for a png_frames index at or past the
/// frame count or more than kMaxPngFrames of them (all checked before the world is
/// built); UNAVAILABLE when a film is asked for on a machine without a
/// renderer; OUT_OF_RANGE when the frames pass kMaxEvaluationFrameBytes;
/// UNAVAILABLE when ffmpeg fails while making the MP4 (with its messages);
/// CANCELLED when
/// `cancel` fires (checked between 0.1 s chunks of simulated time).
/// Thread-safe: evaluations share nothing.
EvaluationResult RunEvaluation(const EvaluationSpec& spec, const CancelCheck& cancel);

}  // namespace yamor::host
