#include "host/frames.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>

#include <fmt/format.h>

#include "common/status.h"
#include "physics/render/image.h"

namespace yamor::host {
namespace {

// The calling thread's renderer; UNAVAILABLE when the machine has none.
render::Renderer& ThisThreadRenderer() { return render::ThreadRenderer(); }

}  // namespace

EncodedFrame EncodeFrame(const render::Scene& scene, const FrameSpec& spec,
                         render::Renderer& renderer, bool fast) {
  const render::Image image =
      renderer.Render(scene, spec.camera, spec.width, spec.height, spec.options);
  return EncodedFrame{.time = scene.time, .png = render::EncodePng(image, fast)};
}

void ValidateFrameSpec(const FrameSpec& spec) {
  render::ValidateFrameSize(spec.width, spec.height);
  render::ValidateCamera(spec.camera);
}

EncodedFrame RenderFrame(RobotDriver& driver, const FrameSpec& spec) {
  ValidateFrameSpec(spec);
  render::Renderer& renderer = ThisThreadRenderer();  // before touching the robot
  const render::Scene scene = driver.GetScene();
  return EncodeFrame(scene, spec, renderer, /*fast=*/false);
}

uint32_t RecordFrameCount(const RecordSpec& spec) {
  return static_cast<uint32_t>(std::max(1.0, std::round(spec.seconds * spec.frame_rate)));
}

void ValidateFrameRate(double frame_rate) {
  if (!std::isfinite(frame_rate)) {
    throw Error(StatusCode::kInvalidArgument,
                fmt::format("frame rate is not finite: {}", frame_rate));
  }
  if (!(frame_rate > 0.0 && frame_rate <= kMaxFrameRate)) {
    throw Error(StatusCode::kOutOfRange, fmt::format("frame rate {} per second is outside (0, {}]",
                                                     frame_rate, kMaxFrameRate));
  }
}

void ValidateRecordSpec(const RecordSpec& spec) {
  ValidateFrameSpec(spec.frame);
  ValidateFrameRate(spec.frame_rate);
  if (!std::isfinite(spec.seconds)) {
    throw Error(StatusCode::kInvalidArgument,
                fmt::format("recording duration is not finite: {}", spec.seconds));
  }
  if (!(spec.seconds > 0.0 && spec.seconds <= kMaxRecordSeconds)) {
    throw Error(StatusCode::kOutOfRange, fmt::format("recording duration {} s is outside (0, {}]",
                                                     spec.seconds, kMaxRecordSeconds));
  }
  if (spec.seconds * spec.frame_rate > kMaxRecordFrames) {
    throw Error(StatusCode::kOutOfRange,
                fmt::format("{} s at {} frames per second is {} frames, more than {}", spec.seconds,
                            spec.frame_rate, spec.seconds * spec.frame_rate, kMaxRecordFrames));
  }
}

void RecordFrames(RobotDriver& driver, const RecordSpec& spec,
                  const std::function<bool(EncodedFrame&&)>& sink, const CancelCheck& cancel) {
  ValidateRecordSpec(spec);
  render::Renderer& renderer = ThisThreadRenderer();
  const uint32_t count = RecordFrameCount(spec);
  const double period = 1.0 / spec.frame_rate;

  if (spec.advance) {
    render::Scene scene = driver.GetScene();
    const double start = scene.time;
    for (uint32_t i = 0; i < count; ++i) {
      if (i > 0) scene = driver.GetScene();
      EncodedFrame frame = EncodeFrame(scene, spec.frame, renderer, /*fast=*/true);
      frame.index = i;
      if (!sink(std::move(frame))) return;
      // Absolute frame times: no drift when the period is not a whole number of steps.
      const double next = start + (i + 1) * period;
      driver.Sleep(std::max(0.0, next - driver.ElapsedTime()), /*real_time=*/false, cancel);
    }
    return;
  }

  // Watch mode: a frame each time the world has advanced by a period.
  struct WatchGuard {
    RobotDriver& driver;
    ~WatchGuard() { driver.EndWatch(); }
  };
  WatchCursor cursor = driver.BeginWatch();
  WatchGuard guard{driver};
  render::Scene scene = driver.GetScene();
  double next = scene.time;
  for (uint32_t i = 0; i < count;) {
    if (scene.time + 1e-9 >= next) {
      EncodedFrame frame = EncodeFrame(scene, spec.frame, renderer, /*fast=*/true);
      frame.index = i++;
      if (!sink(std::move(frame))) return;
      next += period;
      if (i == count) break;
    }
    while (true) {
      if (cancel && cancel()) throw Error(StatusCode::kCancelled, "recording cancelled");
      if (driver.shutting_down()) {
        throw Error(StatusCode::kUnavailable, "yamord is shutting down");
      }
      const std::optional<StateUpdate> update =
          driver.WaitForState(cursor, period, std::chrono::milliseconds(100));
      if (update && update->pose.time + 1e-9 >= next) break;
    }
    scene = driver.GetScene();
  }
}

}  // namespace yamor::host
