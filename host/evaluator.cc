#include "host/evaluator.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <set>
#include <sstream>

#include "common/format.h"
#include "common/log.h"
#include "common/status.h"
#include "cpg/parameters.h"
#include "host/sim_factory.h"
#include "host/snp_link.h"
#include "physics/render/renderer.h"
#include "physics/render/snapshot.h"
#include "physics/render/video.h"

namespace yamor::host {

using cpg::ApplyParameters;
namespace {

constexpr double kMaxEvaluatedTime = 3600.0;  // simulated seconds per evaluation
constexpr std::size_t kMaxTrajectorySamples = 100000;
constexpr double kChunk = 0.1;  // simulated seconds between cancellation checks
constexpr double kMinTimeStep = 1e-5;
constexpr double kMaxTimeStep = 0.02;
constexpr int64_t kMaxSteps = 20'000'000;  // bounds the work one request can ask for

void CheckTiming(double value, std::string_view what, bool allow_zero) {
  if (!std::isfinite(value)) {
    throw Error(StatusCode::kInvalidArgument, std::string(what) + " is not finite: " + FormatRounded(value));
  }
  if (value < 0.0 || (!allow_zero && value == 0.0) || value > kMaxEvaluatedTime) {
    throw Error(StatusCode::kOutOfRange, std::string(what) + " " + FormatRounded(value) + " s is outside " +
                                             (allow_zero ? "[0, " : "(0, ") +
                                             FormatRounded(kMaxEvaluatedTime) + "]");
  }
}

// Runs a simulated robot of its own through SNP, exactly as the driver
// would: the worker builds the backend and then knows it only by bytes.
class EvaluationRobot {
 public:
  EvaluationRobot(physics::Morphology morphology, const SimulationOptions& options,
                  const IdMap& id_map)
      : backend_(MakeSimBackend(std::move(morphology), options)), link_(*backend_, id_map) {}

  // Sends the configuration (real ids) and checks every answer.
  void Configure(const cpg::RobotConfig& config) { link_.Configure(config); }

  // Advances by `steps` physics steps; false when the world diverged, with
  // the reason in `divergence`.
  bool Step(int64_t steps, double time_step, std::string& divergence) {
    try {
      link_.BridgeRequest(snp::Step{.duration = static_cast<double>(steps) * time_step},
                          snp::MessageType::kStepDone);
      return true;
    } catch (const Error& e) {
      // The bridge refuses a Step into a diverged world (docs/snp.md).
      if (e.code() != StatusCode::kFailedPrecondition) throw;
      const snp::Message m =
          link_.BridgeRequest(snp::GetDivergence{}, snp::MessageType::kDivergence);
      const auto& d = std::get<snp::Divergence>(m);
      if (!d.diverged) throw;
      divergence = d.reason + " at t = " + FormatRounded(d.time) + " s";
      return false;
    }
  }

  // The robot's condition, through the bridge specials the driver uses.
  void SetGround(const GroundChange& ground) {
    link_.BridgeRequest(snp::SetGround{.friction = ground.friction,
                                       .slope = ground.slope,
                                       .slope_direction = ground.slope_direction},
                        snp::MessageType::kGround);
  }
  void SetMotorDefect(int id, MotorDefect defect) {
    // As RobotDriver::SetMotorDefect on a connected robot: motor off, then the fault.
    link_.ModuleCall(id, snp::Control{.motors = snp::Tristate::kOff}, snp::MessageType::kAck);
    link_.BridgeRequest(snp::SetMotorFault{.module = static_cast<uint8_t>(id), .fault = ToFault(defect)},
                        snp::MessageType::kSpecialAck);
  }
  void SetModuleDefect(int id) {
    link_.BridgeRequest(snp::SetModuleDefect{.module = static_cast<uint8_t>(id), .defective = true},
                        snp::MessageType::kSpecialAck);
  }
  void TurnUpsideDown() {
    link_.BridgeRequest(snp::TurnUpsideDown{}, snp::MessageType::kSpecialAck);
  }

  // The world as it is now, with real module ids (ReadScene special).
  render::Scene Scene() {
    const snp::SceneSnapshot snapshot = link_.ReadScene();
    return render::FromSnapshot(snapshot, [this](int wire) { return link_.Real(wire); });
  }

  RobotPose Position() {
    const snp::Message m =
        link_.BridgeRequest(snp::GetRobotPosition{}, snp::MessageType::kRobotPosition);
    const auto& p = std::get<snp::RobotPosition>(m);
    return RobotPose{.time = p.time, .position = p.position, .orientation = p.orientation,
                     .source = "simulation"};
  }

 private:
  std::unique_ptr<Backend> backend_;
  SnpLink link_;
};

// Checks a film before any world exists: frame size, camera, rate, count.
void CheckFilm(const EvaluationFilm& film, double seconds) {
  ValidateFrameSpec(film.frame);
  ValidateFrameRate(film.frame_rate);
  if (seconds * film.frame_rate > kMaxRecordFrames) {
    throw Error(StatusCode::kOutOfRange,
                FormatRounded(seconds) + " s at " + FormatRounded(film.frame_rate) +
                    " frames per second is " + FormatRounded(seconds * film.frame_rate) +
                    " frames, more than " + FormatRounded(kMaxRecordFrames));
  }
  if (film.png_frames.size() > kMaxPngFrames) {
    throw Error(StatusCode::kOutOfRange,
                std::to_string(film.png_frames.size()) + " PNG frames asked for; at most " +
                    std::to_string(kMaxPngFrames));
  }
  const uint32_t count = EvaluationFrameCount(seconds, film.frame_rate);
  for (const uint32_t index : film.png_frames) {
    if (index >= count) {
      throw Error(StatusCode::kOutOfRange, "PNG frame " + std::to_string(index) +
                                               " is past the film's " + std::to_string(count) +
                                               " frames");
    }
  }
}

// An empty temporary file for the film's MP4, removed when it goes out of scope.
class TempVideoFile {
 public:
  TempVideoFile() {
    std::string pattern = (std::filesystem::temp_directory_path() / "yamor-film-XXXXXX.mp4").string();
    const int fd = mkstemps(pattern.data(), 4);
    if (fd < 0) {
      throw Error(StatusCode::kInternal, "cannot create a temporary file for the film's MP4 in " +
                                             std::filesystem::temp_directory_path().string());
    }
    close(fd);
    path_ = pattern;
  }
  ~TempVideoFile() {
    std::error_code ec;
    std::filesystem::remove(path_, ec);
  }
  TempVideoFile(const TempVideoFile&) = delete;
  TempVideoFile& operator=(const TempVideoFile&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

}  // namespace

uint32_t EvaluationFrameCount(double seconds, double frame_rate) {
  return static_cast<uint32_t>(std::max(1.0, std::round(seconds * frame_rate)));
}

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
                "trajectory period " + FormatRounded(spec.trajectory_period) + " s is negative");
  }
  const double time_step =
      spec.time_step == 0.0 ? DefaultSimulationTimeStep() : spec.time_step;
  if (!std::isfinite(time_step)) {
    throw Error(StatusCode::kInvalidArgument, "time step is not finite: " + FormatRounded(time_step));
  }
  if (time_step < kMinTimeStep || time_step > kMaxTimeStep) {
    throw Error(StatusCode::kOutOfRange, "time step " + FormatRounded(time_step) + " s is outside [" +
                                             FormatRounded(kMinTimeStep) + ", " + FormatRounded(kMaxTimeStep) + "]");
  }
  auto steps_of = [&](double seconds) { return std::llround(seconds / time_step); };
  const int64_t warm_steps = steps_of(spec.warmup);
  const int64_t end_steps = steps_of(spec.warmup + spec.duration);
  if (end_steps > kMaxSteps) {
    throw Error(StatusCode::kOutOfRange,
                "warm-up + duration of " + FormatRounded(spec.warmup + spec.duration) + " s at a step of " +
                    FormatRounded(time_step) + " s is more than " + std::to_string(kMaxSteps) + " steps");
  }
  const int64_t sample_every =
      spec.trajectory_period > 0.0 ? std::max<int64_t>(1, steps_of(spec.trajectory_period)) : 0;
  if (sample_every > 0 && static_cast<std::size_t>(end_steps / sample_every) > kMaxTrajectorySamples) {
    throw Error(StatusCode::kOutOfRange,
                "trajectory period " + FormatRounded(spec.trajectory_period) + " s gives more than " +
                    std::to_string(kMaxTrajectorySamples) + " samples");
  }

  cpg::RobotConfig config = spec.config;
  ApplyParameters(config, spec.parameters);
  cpg::Validate(config);
  std::vector<int> ids;
  for (const cpg::ModuleParams& m : config.modules) ids.push_back(m.id);
  spec.id_map.CheckInjective(ids);
  for (const cpg::ModuleParams& m : config.modules) {
    const int sim = spec.id_map.ToSim(m.id);
    if (!spec.morphology.Contains(sim) || spec.morphology.Module(sim).free) {
      throw Error(StatusCode::kInvalidArgument,
                  "module " + std::to_string(m.id) +
                      " of the configuration is not part of world " + spec.morphology.source());
    }
  }

  // The condition is checked whole before any world exists.
  std::set<int> motor_defect_ids;
  for (const auto& [id, defect] : spec.motor_defects) {
    if (config.FindModule(id) == nullptr) {
      throw Error(StatusCode::kNotFound,
                  "motor defect: module " + std::to_string(id) + " is not in the configuration");
    }
    if (!motor_defect_ids.insert(id).second) {
      throw Error(StatusCode::kInvalidArgument,
                  "motor defect: module " + std::to_string(id) + " is listed twice");
    }
  }
  std::set<int> module_defect_ids;
  for (const auto& [id, defective] : spec.module_defects) {
    if (id < 0 || id > cpg::kMaxModuleId || !spec.morphology.Contains(spec.id_map.ToSim(id))) {
      throw Error(StatusCode::kNotFound, "module defect: module " + std::to_string(id) +
                                             " is not in world " + spec.morphology.source());
    }
    if (!module_defect_ids.insert(id).second) {
      throw Error(StatusCode::kInvalidArgument,
                  "module defect: module " + std::to_string(id) + " is listed twice");
    }
  }
  CheckGroundValues(spec.ground);
  // The film: checked, and this thread's renderer made (UNAVAILABLE on a
  // machine without one), before the world is built.
  render::Renderer* renderer = nullptr;
  uint32_t frame_count = 0;
  if (spec.film) {
    CheckFilm(*spec.film, spec.warmup + spec.duration);
    renderer = &render::ThreadRenderer();
    frame_count = EvaluationFrameCount(spec.warmup + spec.duration, spec.film->frame_rate);
  }

  const SimulationOptions options{.time_step = time_step,
                                  .seed = spec.seed,
                                  .master = spec.id_map.ToSim(config.master_id)};
  EvaluationRobot robot(spec.morphology, options, spec.id_map);
  robot.Configure(config);
  if (spec.ground.friction || spec.ground.slope || spec.ground.slope_direction) {
    robot.SetGround(spec.ground);
  }
  for (const auto& [id, defect] : spec.motor_defects) {
    if (defect != MotorDefect::kNone) robot.SetMotorDefect(id, defect);
  }
  for (const auto& [id, defective] : spec.module_defects) {
    if (defective) robot.SetModuleDefect(id);
  }
  if (spec.upside_down) robot.TurnUpsideDown();

  EvaluationResult result;
  const int64_t chunk = std::max<int64_t>(1, steps_of(kChunk));
  // Frame i is taken at step round(i / frame_rate / time_step): absolute
  // times, so a period that is no whole number of steps does not drift.
  std::size_t frame_bytes = 0;
  uint32_t frames_taken = 0;
  // With film->mp4: the film goes raw to ffmpeg here (about half the CPU of
  // PNG frames a client makes into a video); without ffmpeg, PNG frames.
  std::unique_ptr<TempVideoFile> video_file;
  std::unique_ptr<render::VideoWriter> video;
  render::Image image;  // the MP4's frames, one buffer for all
  const std::set<uint32_t> png_wanted =
      spec.film ? std::set<uint32_t>(spec.film->png_frames.begin(), spec.film->png_frames.end())
                : std::set<uint32_t>{};
  if (spec.film && spec.film->mp4) {
    video_file = std::make_unique<TempVideoFile>();
    video = std::make_unique<render::VideoWriter>(
        video_file->path(), render::VideoOptions{.frame_rate = spec.film->frame_rate,
                                                 .raw_width = spec.film->frame.width,
                                                 .raw_height = spec.film->frame.height});
    if (!video->ToFfmpeg()) {
      video->Finish();
      video.reset();
      result.video_note =
          "the daemon's machine cannot run ffmpeg ($YAMOR_FFMPEG, else ffmpeg in PATH): every "
          "frame comes as PNG instead";
      Log().warn("evaluate: no MP4 of the film, PNG frames instead: {}", result.video_note);
    }
  }
  const auto frame_step = [&](uint32_t i) -> int64_t {
    return steps_of(static_cast<double>(i) / spec.film->frame_rate);
  };
  const auto take_frame = [&] {
    const uint32_t index = frames_taken++;
    EncodedFrame frame;
    if (video) {
      // Raw to ffmpeg; PNG only for the frames asked for.
      const FrameSpec& f = spec.film->frame;
      const render::Scene scene = robot.Scene();
      renderer->RenderInto(scene, f.camera, f.width, f.height, f.options, image);
      video->AddImage(image);
      if (!png_wanted.contains(index)) return;
      frame = EncodedFrame{.time = scene.time, .png = render::EncodePng(image, /*fast=*/true)};
    } else {
      frame = EncodeFrame(robot.Scene(), spec.film->frame, *renderer, /*fast=*/true);
    }
    frame.index = index;
    frame_bytes += frame.png.size();
    if (frame_bytes > kMaxEvaluationFrameBytes) {
      throw Error(StatusCode::kOutOfRange,
                  "the frames of this evaluation pass " +
                      std::to_string(kMaxEvaluationFrameBytes >> 20) + " MiB at frame " +
                      std::to_string(index) + " of " + std::to_string(frame_count) +
                      "; ask for smaller frames or a lower frame rate");
    }
    result.frames.push_back(std::move(frame));
  };
  // Frames due at the current step (several when the rate is above 1/step).
  int64_t step = 0;
  const auto take_due_frames = [&] {
    while (frames_taken < frame_count && frame_step(frames_taken) <= step) {
      take_frame();
    }
  };
  if (spec.film) take_due_frames();
  RobotPose start_pose = robot.Position();
  result.final_pose = start_pose;
  if (sample_every > 0) result.trajectory.push_back({start_pose.time, start_pose.position});
  while (step < end_steps) {
    if (cancel && cancel()) {
      throw Error(StatusCode::kCancelled,
                  "evaluation cancelled at t = " + FormatRounded(static_cast<double>(step) * time_step) + " s");
    }
    int64_t next = std::min(end_steps, step + chunk);
    if (step < warm_steps) next = std::min(next, warm_steps);
    if (sample_every > 0) next = std::min(next, (step / sample_every + 1) * sample_every);
    if (spec.film && frames_taken < frame_count) {
      next = std::min(next, frame_step(frames_taken));
    }
    std::string divergence;
    if (!robot.Step(next - step, time_step, divergence)) {
      result.diverged = true;
      result.divergence = divergence;
      result.velocity = 0.0;
      result.distance = 0.0;
      Log().info("evaluate: world diverged: {}", result.divergence);
      break;
    }
    step = next;
    if (spec.film) take_due_frames();
    const bool at_warmup = step == warm_steps;
    const bool at_sample = sample_every > 0 && step % sample_every == 0;
    if (at_warmup || at_sample || step == end_steps) {
      const RobotPose pose = robot.Position();
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
  if (video) {
    const render::VideoResult made = video->Finish();  // UNAVAILABLE with ffmpeg's messages
    video.reset();
    std::error_code size_error;
    const auto size = std::filesystem::file_size(video_file->path(), size_error);
    std::ifstream in(video_file->path(), std::ios::binary);
    if (size_error || !in) {
      throw Error(StatusCode::kInternal, "cannot read the film's MP4 " + video_file->path());
    }
    result.mp4.resize(static_cast<std::size_t>(size));
    if (!in.read(reinterpret_cast<char*>(result.mp4.data()), static_cast<std::streamsize>(size))) {
      throw Error(StatusCode::kInternal, "cannot read the film's MP4 " + video_file->path());
    }
    result.mp4_frames = static_cast<uint32_t>(made.frames);
    if (frame_bytes + result.mp4.size() > kMaxEvaluationFrameBytes) {
      throw Error(StatusCode::kOutOfRange,
                  "the film of this evaluation passes " +
                      std::to_string(kMaxEvaluationFrameBytes >> 20) +
                      " MiB; ask for smaller frames or a lower frame rate");
    }
  }
  result.wall_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return result;
}

}  // namespace yamor::host
