#include "host/frames.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include <fmt/format.h>

#include "common/status.h"
#include "physics/render/image.h"

namespace yamor::host {
namespace {

// The daemon's renderers, shared by every call (issue 17, found by the soak).
// A renderer per gRPC thread (render::ThreadRenderer) cost an OpenGL context
// (tens of MB with llvmpipe, and its rasterizer threads) for every thread
// that ever drew a frame; gRPC's sync server starts and ends threads with
// the load, so 64 concurrent RenderFrame clients took yamord from 20 MB to
// over 800 MB, kept after they left. Here at most `capacity` contexts exist
// for the daemon's life; a call borrows one for one frame and waits while
// all are in use. Renderer::Render unbinds its context when done, so a
// renderer may move between threads (a context left current on one thread
// crashed OSMesa when that thread next bound another one; EGL refuses it).
class RendererPool {
 public:
  explicit RendererPool(std::size_t capacity) : capacity_(capacity) {}

  // A borrowed renderer, given back when destroyed.
  class Lease {
   public:
    Lease(RendererPool& pool, std::unique_ptr<render::Renderer> renderer)
        : pool_(&pool), renderer_(std::move(renderer)) {}
    Lease(Lease&& other) noexcept = default;
    Lease& operator=(Lease&&) = delete;
    ~Lease() {
      if (renderer_) pool_->GiveBack(std::move(renderer_));
    }
    render::Renderer& operator*() const { return *renderer_; }

   private:
    RendererPool* pool_;
    std::unique_ptr<render::Renderer> renderer_;
  };

  // A free renderer, a new one while fewer than the capacity exist, or,
  // when all are in use, the next one given back. UNAVAILABLE when the
  // machine has no renderer; CANCELLED when `cancel` fires while waiting.
  Lease Borrow(const CancelCheck& cancel) {
    std::unique_lock lock(mutex_);
    while (idle_.empty() && created_ >= capacity_) {
      if (cancel && cancel()) throw Error(StatusCode::kCancelled, "frame cancelled");
      given_back_.wait_for(lock, std::chrono::milliseconds(50));
    }
    if (!idle_.empty()) {
      std::unique_ptr<render::Renderer> renderer = std::move(idle_.back());
      idle_.pop_back();
      return Lease(*this, std::move(renderer));
    }
    ++created_;  // reserved; creating a context takes a while, so outside the lock
    lock.unlock();
    try {
      return Lease(*this, std::make_unique<render::Renderer>());
    } catch (...) {
      lock.lock();
      --created_;
      given_back_.notify_one();
      throw;
    }
  }

  std::size_t capacity() const { return capacity_; }

  std::size_t created() const {
    std::lock_guard lock(mutex_);
    return created_;
  }

 private:
  void GiveBack(std::unique_ptr<render::Renderer> renderer) {
    {
      std::lock_guard lock(mutex_);
      idle_.push_back(std::move(renderer));
    }
    given_back_.notify_one();
  }

  const std::size_t capacity_;
  mutable std::mutex mutex_;
  std::condition_variable given_back_;
  std::vector<std::unique_ptr<render::Renderer>> idle_;  // guarded by mutex_
  std::size_t created_ = 0;                              // guarded by mutex_
};

RendererPool& Renderers() {
  // Never destroyed: contexts outlive every call, and static destruction
  // order against the GL libraries is not ours to choose.
  static RendererPool* pool = new RendererPool(
      std::clamp<std::size_t>(std::thread::hardware_concurrency(), 1, kMaxRenderers));
  return *pool;
}

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

std::size_t RendererCapacity() { return Renderers().capacity(); }

std::size_t RenderersCreated() { return Renderers().created(); }

EncodedFrame RenderFrame(RobotDriver& driver, const FrameSpec& spec, const CancelCheck& cancel) {
  ValidateFrameSpec(spec);
  RendererPool::Lease renderer = Renderers().Borrow(cancel);  // before touching the robot
  const render::Scene scene = driver.GetScene();
  return EncodeFrame(scene, spec, *renderer, /*fast=*/false);
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
  // A renderer per frame, not for the whole recording (which may wait on
  // the world for minutes); borrowed once first so a machine without one
  // fails before the world moves.
  { RendererPool::Lease check = Renderers().Borrow(cancel); }
  auto draw = [&](const render::Scene& scene) {
    RendererPool::Lease renderer = Renderers().Borrow(cancel);
    return EncodeFrame(scene, spec.frame, *renderer, /*fast=*/true);
  };
  const uint32_t count = RecordFrameCount(spec);
  const double period = 1.0 / spec.frame_rate;

  if (spec.advance) {
    render::Scene scene = driver.GetScene();
    const double start = scene.time;
    for (uint32_t i = 0; i < count; ++i) {
      if (i > 0) scene = driver.GetScene();
      EncodedFrame frame = draw(scene);
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
      EncodedFrame frame = draw(scene);
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
