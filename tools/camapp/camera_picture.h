// The emulated camera's picture (issue 15 §2, `yamor-camapp --frames DIR`):
// a pinhole top-down render of the simulation, wide enough to cover what the
// barrel lens folds into the image, resampled through the camera's own
// Brown–Conrady model so the picture shows exactly what CamApp would look at,
// with the reported LED pixel marked; and a recorder that writes such
// pictures on its own thread so filming never waits for the renderer.
#pragma once

#include <array>
#include <condition_variable>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include <Eigen/Core>

#include "physics/render/image.h"
#include "tools/camapp/camera_emulator.h"
#include "tools/camapp/emulator.h"

namespace yamor::camapp {

/// What to ask the renderer for: a top-down camera `height` metres above
/// `target` with vertical field of view `fov`, `width`×`height_px` pixels.
struct PinholeRequest {
  Eigen::Vector3d target = Eigen::Vector3d::Zero();  ///< Ground point below the lens [m].
  double height = 2.7;                               ///< Lens above the target [m].
  double fov = 0.0;                                  ///< Vertical field of view [rad].
  int width = 0;                                     ///< Render width [px].
  int height_px = 0;                                 ///< Render height [px].
};

/// Turns a pinhole render into the camera's distorted picture.
/// Thread-safety: immutable after construction; Distort is const and may run
/// on any thread.
class CameraPicture {
 public:
  /// Plans the render for `camera`'s lens: the pinhole image is as large as
  /// the undistorted image border needs (plus one pixel), at the camera's
  /// focal length, at most `max_side` pixels a side (INVALID_ARGUMENT
  /// naming the size when the lens needs more).
  explicit CameraPicture(const CameraEmulator& camera, int max_side = 4096);

  /// The render to request.
  const PinholeRequest& request() const noexcept { return request_; }

  /// The camera's picture (its width × height) from `pinhole`, a render of
  /// request(): every camera pixel samples the pinhole image bilinearly at
  /// its undistorted position. INVALID_ARGUMENT when `pinhole` has another size.
  render::Image Distort(const render::Image& pinhole) const;

  /// Draws a cross of `radius` pixels centred on `pixel` (camera pixel
  /// coordinates) in `rgb`, clipped to the image.
  static void MarkPixel(render::Image& picture, const Eigen::Vector2d& pixel, int radius,
                        std::array<uint8_t, 3> rgb);

 private:
  int width_ = 0;
  int height_ = 0;
  PinholeRequest request_;
  // Per camera pixel, the pinhole pixel (column, row; index convention) it samples.
  std::vector<Eigen::Vector2f> source_;
};

/// Renders the pinhole view now: PNG bytes and the simulation time of the
/// scene; throws yamor::Error when it cannot.
using PinholeRenderer = std::function<std::pair<std::vector<uint8_t>, double>(const PinholeRequest&)>;

/// Writes the camera's pictures of captured frames into a folder:
/// `frame-<seq>.png` and an index `frames.csv`
/// (`seq,camera_time_us,picture_time,state,pixel_x,pixel_y,file`). Every
/// `every`-th captured frame is offered; a frame offered while the previous
/// one is still being rendered replaces any frame waiting (the newest wins)
/// and is counted as skipped. A failed render is logged and counted, never
/// thrown to the filming loop.
/// Thread-safety: Offer may be called from one thread while the recorder's
/// own thread renders; the counters are safe to read from any thread.
class PictureRecorder {
 public:
  /// Creates `folder` (INVALID_ARGUMENT naming it when it cannot) and starts
  /// the thread; `camera` must outlive the recorder.
  PictureRecorder(const CameraEmulator& camera, std::filesystem::path folder, int every,
                  PinholeRenderer renderer);
  /// Finishes the picture being rendered and the one waiting, then stops.
  ~PictureRecorder();
  PictureRecorder(const PictureRecorder&) = delete;
  PictureRecorder& operator=(const PictureRecorder&) = delete;

  /// Offers a captured frame (the FrameObserver of an Emulator).
  void Offer(const CapturedFrame& frame);
  /// Waits until no frame is waiting or being rendered.
  void Drain();

  /// Pictures written.
  std::uint64_t written() const;
  /// Frames offered but replaced by a newer one before their turn.
  std::uint64_t skipped() const;
  /// Renders or writes that failed.
  std::uint64_t failed() const;

 private:
  void Loop();
  void Write(const CapturedFrame& frame);

  CameraPicture picture_;
  const CameraEmulator& camera_;
  std::filesystem::path folder_;
  int every_;
  PinholeRenderer renderer_;
  std::ofstream index_;  // touched only by the recorder's thread
  std::uint64_t offered_ = 0;  // touched only by the offering thread

  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::optional<CapturedFrame> waiting_;  // guarded by mutex_
  bool busy_ = false;                     // guarded by mutex_
  bool stop_ = false;                     // guarded by mutex_
  std::uint64_t written_ = 0;             // guarded by mutex_
  std::uint64_t skipped_ = 0;             // guarded by mutex_
  std::uint64_t failed_ = 0;              // guarded by mutex_
  std::thread thread_;
};

}  // namespace yamor::camapp
