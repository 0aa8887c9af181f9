// Pictures of the robot for RenderFrame and RecordFrames: the scene from the
// driver (a ReadScene bridge special; the robot lock is held only while it
// is read), drawn by a renderer (yamor_render) borrowed from the daemon's
// pool of at most RendererCapacity() for one frame, and encoded as PNG
// outside the lock.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

#include "host/driver.h"
#include "physics/render/camera.h"
#include "physics/render/renderer.h"

namespace yamor::host {

/// How to draw one frame. Thread-safety: plain value.
struct FrameSpec {
  render::Camera camera;          ///< Where the camera is.
  int width = 640;                ///< [px], 1..render::kMaxFrameSize.
  int height = 480;               ///< [px], 1..render::kMaxFrameSize.
  render::RenderOptions options;  ///< Labels, legend, ...
};

/// One encoded frame.
struct EncodedFrame {
  uint32_t index = 0;         ///< 0, 1, ... within a recording.
  double time = 0.0;          ///< Simulated time of the scene [s].
  std::vector<uint8_t> png;   ///< The PNG bytes.
};

/// Throws yamor::Error for a frame size or camera the renderer refuses
/// (OUT_OF_RANGE / INVALID_ARGUMENT naming the value): checked before the
/// robot is asked anything.
void ValidateFrameSpec(const FrameSpec& spec);

/// Most OpenGL contexts the process's frames use at once (each costs tens of
/// MB with llvmpipe): the renderer pool holds min(core count, this), at
/// least 1.
inline constexpr std::size_t kMaxRenderers = 4;

/// Size of the process's renderer pool. Thread-safe.
std::size_t RendererCapacity();

/// Renderers (OpenGL contexts) the pool has created so far; never more than
/// RendererCapacity(), however many threads draw. Thread-safe.
std::size_t RenderersCreated();

/// One frame of the robot as it is now. Errors: ValidateFrameSpec's,
/// UNAVAILABLE when this machine has no renderer, the driver's GetScene
/// errors (FAILED_PRECONDITION no simulation or a diverged world,
/// UNIMPLEMENTED on a real robot), CANCELLED when `cancel` fires while every
/// renderer is busy. Never changes the robot. Thread-safe: frames of many
/// threads are drawn by the shared renderers, RendererCapacity() at a time.
EncodedFrame RenderFrame(RobotDriver& driver, const FrameSpec& spec,
                         const CancelCheck& cancel = {});

/// One frame of `scene` drawn by `renderer` (PNG; `fast` trades size for
/// speed, as video frames want). Errors: the renderer's and EncodePng's.
EncodedFrame EncodeFrame(const render::Scene& scene, const FrameSpec& spec,
                         render::Renderer& renderer, bool fast);

/// A recording: frames every 1/frame_rate simulated seconds.
struct RecordSpec {
  FrameSpec frame;          ///< How each frame is drawn.
  double frame_rate = 25;   ///< Frames per simulated second, (0, kMaxFrameRate].
  double seconds = 1.0;     ///< Simulated duration, (0, kMaxRecordSeconds].
  /// True: the recording steps the world itself (a virtual-time Sleep of
  /// 1/frame_rate after each frame), so the world advances exactly
  /// `seconds`. False: it only watches while others advance the world
  /// (free-run, another client's Sleep), a frame whenever 1/frame_rate more
  /// simulated seconds have passed.
  bool advance = true;
};

/// Highest frame rate of a recording [frames per simulated second].
inline constexpr double kMaxFrameRate = 240.0;
/// Longest recording [simulated s].
inline constexpr double kMaxRecordSeconds = 3600.0;
/// Most frames in one recording.
inline constexpr double kMaxRecordFrames = 100000.0;

/// Frames in a recording: max(1, round(seconds * frame_rate)).
uint32_t RecordFrameCount(const RecordSpec& spec);

/// Throws yamor::Error naming the value: INVALID_ARGUMENT for a frame rate
/// that is NaN or infinite, OUT_OF_RANGE outside (0, kMaxFrameRate].
void ValidateFrameRate(double frame_rate);

/// Throws yamor::Error naming the value: ValidateFrameSpec's, OUT_OF_RANGE
/// for a frame rate or duration outside its range (0 included) or too many
/// frames, INVALID_ARGUMENT for NaN.
void ValidateRecordSpec(const RecordSpec& spec);

/// Records RecordFrameCount(spec) frames, handing each to `sink` as soon as
/// it is encoded (returning false stops the recording early, e.g. the client
/// went away). Rendering and encoding run without the robot lock, so other
/// clients' calls get in between frames. Errors: ValidateRecordSpec's,
/// RenderFrame's, the driver's Sleep errors (CANCELLED when `cancel` fires,
/// FAILED_PRECONDITION when the world diverges).
void RecordFrames(RobotDriver& driver, const RecordSpec& spec,
                  const std::function<bool(EncodedFrame&&)>& sink, const CancelCheck& cancel);

}  // namespace yamor::host
