// The LED tracker (issue 15 §1): a TCP client of the camera application
// (docs/camapp.md) that keeps the latest sample with its arrival time,
// reconnects after any failure, and turns pixels into metres through an
// immutable CameraModel. It never passes a stale position off as fresh.
#pragma once

#include <Eigen/Core>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "host/camera_model.h"
#include "host/position_tracker.h"

namespace yamor::host {

/// Default TCP port of the camera application (docs/camapp.md).
inline constexpr int kCamAppDefaultPort = 2225;

/// One decoded sample line of the CamApp protocol.
struct CamAppSample {
  std::uint32_t seq = 0;             ///< Frame counter.
  std::uint64_t camera_time_us = 0;  ///< Camera capture time [µs, camera epoch].
  bool seen = false;                 ///< False for a "- -" (LED not seen) frame.
  Eigen::Vector2d pixel{0, 0};       ///< Raw pixel (only when seen).
};

/// Decodes one sample line (without '\n') for a width x height image;
/// INVALID_ARGUMENT naming the bad field. Comment lines are the caller's.
CamAppSample ParseCamAppSample(std::string_view line, int width, int height);

/// Where and how the tracker connects.
struct LedTrackerOptions {
  std::string host = "127.0.0.1";           ///< CamApp's host name or address.
  int port = kCamAppDefaultPort;            ///< CamApp's TCP port.
  double connect_timeout = 2.0;             ///< Longest TCP connect [s].
  double reconnect_delay = 0.5;             ///< Pause before reconnecting [s].
};

/// A sample as the tracker received it.
struct LedSample {
  CamAppSample sample;                                 ///< The decoded line.
  std::chrono::steady_clock::time_point arrival;       ///< Host arrival time.
  std::uint64_t connection = 0;                        ///< Connection it came on (1, 2, ...).
};

/// A tracked position on the ground.
struct TrackedPosition {
  Eigen::Vector2d ground{0, 0};                        ///< Position [m], calibration frame.
  Eigen::Vector2d pixel{0, 0};                         ///< Raw pixel it came from.
  std::uint32_t seq = 0;                               ///< Camera frame counter.
  std::uint64_t camera_time_us = 0;                    ///< Camera capture time [µs].
  std::chrono::steady_clock::time_point arrival;       ///< Host arrival time.
};

/// The TCP client of CamApp: one background I/O thread reads the stream and
/// reconnects; queries read the latest sample.
/// Thread-safety: every public method is safe from any thread concurrently;
/// the model is immutable, the connection state is guarded by one mutex.
class LedTracker {
 public:
  /// Starts connecting to `options.host:options.port` in the background.
  LedTracker(CameraModel model, LedTrackerOptions options);
  /// A tracker without a camera model (raw pixels only, e.g. to record
  /// reference points before a calibration exists) for a width x height image.
  LedTracker(int width, int height, LedTrackerOptions options);
  /// Stops the I/O thread and closes the connection.
  ~LedTracker();
  LedTracker(const LedTracker&) = delete;
  LedTracker& operator=(const LedTracker&) = delete;

  /// "led-tracker HOST:PORT", the name errors carry.
  const std::string& name() const noexcept;
  /// True when the tracker has a camera model (pixels -> metres).
  bool has_model() const noexcept;
  /// The camera model; FAILED_PRECONDITION for a raw-only tracker.
  const CameraModel& model() const;

  /// The latest sample received (seen or not), if any.
  std::optional<LedSample> LatestSample() const;

  /// The latest position, if its sample arrived at most `max_age` ago and the
  /// LED was seen in it; UNAVAILABLE naming the tracker and how stale otherwise.
  TrackedPosition LatestPosition(std::chrono::duration<double> max_age) const;

  /// Waits up to `timeout` for the latest sample to satisfy `accept` (tested
  /// on the latest sample now and on each new one); the sample, or nullopt.
  std::optional<LedSample> WaitForSample(const std::function<bool(const LedSample&)>& accept,
                                         std::chrono::duration<double> timeout) const;

  /// The position of `sample`: UNAVAILABLE naming the tracker when the LED
  /// was not seen in it or its pixel cannot be corrected; FAILED_PRECONDITION
  /// for a raw-only tracker.
  TrackedPosition Locate(const LedSample& sample) const;

  /// Calls `handler` on the tracker's I/O thread with every sample received
  /// from now on, before it becomes the latest sample (it must return quickly,
  /// and not set a handler or wait for a sample: Locate is fine);
  /// an empty handler removes it. Returns once no call of the previous
  /// handler is in flight.
  void SetSampleHandler(std::function<void(const LedSample&)> handler);

  /// True while a connection (past the hello) is up.
  bool connected() const;
  /// Number of connections that got past the hello so far.
  std::uint64_t connections() const;

 private:
  LedTracker(std::optional<CameraModel> model, int width, int height, LedTrackerOptions options);

  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// yamord's position source: `tracker`'s positions (metres at the
/// calibration's LED height), fresh within `max_age`.
/// Thread-safety: as LedTracker.
std::shared_ptr<PositionTracker> MakeLedPositionTracker(std::shared_ptr<LedTracker> tracker,
                                                        std::chrono::duration<double> max_age);

}  // namespace yamor::host
