// Where the robot driver reads a tracked position of the central module
// (issue 15): yamord's LED tracker in production (MakeLedPositionTracker in
// host/led_tracker.h), fakes in tests. No network here.
#pragma once

#include <array>
#include <chrono>
#include <functional>
#include <string>

namespace yamor::host {

/// One tracked position of the LED on the central module.
struct TrackedPose {
  std::array<double, 3> position{};  ///< x, y on the ground [m]; z the calibration's LED height.
  double camera_time = 0.0;          ///< The camera's capture time [s, camera epoch].
  std::chrono::steady_clock::time_point arrival;  ///< Host arrival time.
};

/// A source of tracked positions.
/// Thread-safety: implementations must allow every method from any thread.
class PositionTracker {
 public:
  virtual ~PositionTracker() = default;

  /// The name errors carry ("led-tracker HOST:PORT").
  virtual const std::string& name() const = 0;

  /// The latest position, when its sample arrived at most the tracker's
  /// maximum age ago and saw the LED; UNAVAILABLE naming the tracker otherwise.
  virtual TrackedPose Latest() const = 0;

  /// The latest position seen at a camera time in [earliest, latest()] [s]
  /// (`latest` is read while waiting, from the waiting thread, and must be
  /// cheap), waiting up to the tracker's maximum age for one; UNAVAILABLE
  /// naming the tracker, the time and what it saw instead otherwise.
  virtual TrackedPose CapturedBetween(double earliest, const std::function<double()>& latest) const = 0;

  /// Calls `handler` (on the tracker's thread; it must return quickly) with
  /// every position seen from now on; an empty handler removes it. Returns
  /// once no call of the previous handler is in flight.
  virtual void SetHandler(std::function<void(const TrackedPose&)> handler) = 0;
};

}  // namespace yamor::host
