#include "tools/camapp/emulator.h"

#include <cmath>
#include <thread>

#include <fmt/format.h>

#include "common/format.h"
#include "common/log.h"
#include "common/status.h"
#include "physics/morphology.h"

namespace yamor::camapp {
using Clock = std::chrono::steady_clock;

namespace {

const EmulatorOptions& Validated(const EmulatorOptions& o) {
  if (!(o.latency >= 0.0 && o.latency <= 10.0)) {
    throw Error(StatusCode::kInvalidArgument,
                "camapp: latency must be in [0, 10] s, got " + FormatDouble(o.latency));
  }
  if (!(o.poll_interval > 0.0 && o.poll_interval <= 1.0)) {
    throw Error(StatusCode::kInvalidArgument,
                "camapp: poll interval must be in (0, 1] s, got " + FormatDouble(o.poll_interval));
  }
  return o;
}

}  // namespace

Emulator::Emulator(EmulatorOptions options, CamAppServer& server, PoseSource source, std::ostream* truth)
    : options_(Validated(options)),
      camera_(options_.camera),
      clock_(options_.fps),
      server_(server),
      source_(std::move(source)),
      truth_(truth),
      next_seq_(options_.first_seq) {
  if (truth_ != nullptr) *truth_ << kTruthHeader << "\n" << std::flush;
}

bool Emulator::PollOnce(Clock::time_point now) {
  SimulatedPose pose;
  try {
    pose = source_();
    if (!std::isfinite(pose.time) || !pose.position.allFinite() || !pose.orientation.coeffs().allFinite() ||
        pose.orientation.norm() < 1e-9) {
      throw Error(StatusCode::kInvalidArgument, "camapp: the pose is not finite");
    }
  } catch (const Error& e) {
    if (e.what() != last_error_) Log().warn("camapp: no pose: {}", e.what());
    last_error_ = e.what();
    return false;
  }
  if (!last_error_.empty()) Log().info("camapp: the pose is back");
  last_error_.clear();
  if (!first_pose_) {
    first_pose_ = pose;
    if (options_.led_axis_from_first_pose) {
      const Eigen::Vector3d up =
          physics::NearestFrameAxis(pose.orientation.normalized().conjugate() * Eigen::Vector3d::UnitZ());
      camera_.SetLedAxis(up);
      Log().info("camapp: the LED faces the central module's ({}, {}, {}) axis", up.x(), up.y(), up.z());
    }
  }
  const FrameClock::Decision decision = clock_.Poll(pose.time, now);
  if (!decision.capture) return false;
  if (decision.restarted) Log().info("camapp: the simulation clock went back to {} s", FormatRounded(pose.time));
  next_seq_ += decision.skipped;  // frames the camera could not film: a gap in seq
  const std::uint32_t seq = next_seq_++;
  const auto time_us = static_cast<std::uint64_t>(std::llround(std::max(0.0, pose.time) * 1e6));
  const CameraFrame frame = camera_.Capture(pose.position, pose.orientation);
  const bool seen = frame.state == FrameState::kSeen;
  const std::string x = seen ? camera_.PixelText(frame.pixel.x()) : "-";
  const std::string y = seen ? camera_.PixelText(frame.pixel.y()) : "-";
  server_.Publish(fmt::format("{} {} {} {}", seq, time_us, x, y),
                  now + std::chrono::duration_cast<Clock::duration>(
                            std::chrono::duration<double>(options_.latency)));
  ++frames_;
  if (truth_ != nullptr) {
    *truth_ << fmt::format("{},{},{},{},{},{},{},{},{}\n", seq, time_us, FormatDouble(pose.time),
                           FormatDouble(pose.position.x()), FormatDouble(pose.position.y()),
                           FormatDouble(pose.position.z()), FrameStateName(frame.state),
                           seen ? x : "", seen ? y : "")
            << std::flush;  // a killed emulator leaves every frame it sent
  }
  if (observer_) observer_(CapturedFrame{.seq = seq, .time_us = time_us, .pose = pose, .frame = frame});
  return true;
}

void Emulator::Run(const std::function<bool()>& stop) {
  const auto interval =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(options_.poll_interval));
  auto next = Clock::now();
  while (!stop()) {
    PollOnce(Clock::now());
    next += interval;
    const auto now = Clock::now();
    if (next < now) next = now;  // a slow poll does not make a burst of polls
    std::this_thread::sleep_until(next);
  }
}

}  // namespace yamor::camapp
