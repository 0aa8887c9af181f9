// The WatchState event log: noteworthy changes of the robot (opened, reset,
// connected, defects, divergence, ...) and the latest pose sample, with
// watchers that wait for what is new since their cursor. Extracted from the
// RobotDriver (issue 11) so it can be tested on its own.
#pragma once

#include <array>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace yamor::host {

/// A pose of the central module.
struct RobotPose {
  double time = 0.0;                                   ///< Sample time [s].
  std::array<double, 3> position{};                   ///< [m], world frame.
  std::array<double, 4> orientation{1.0, 0.0, 0.0, 0.0};  ///< Quaternion w, x, y, z.
  std::string source;                                  ///< "simulation" or "led-tracker".
};

/// A noteworthy change of the robot, for WatchState.
struct StateEvent {
  std::string kind;    ///< "opened", "closed", "reset", "connected", "defect_set", "diverged", ...
  int module_id = -1;  ///< Module concerned (real id), or -1.
  std::string detail;  ///< Human-readable detail.
};

/// One WatchState update.
struct StateUpdate {
  RobotPose pose;                        ///< Latest pose.
  std::array<double, 3> velocity{};      ///< Estimate from the previous update [m/s].
  std::vector<StateEvent> events;        ///< Events since the previous update.
};

/// A watcher's position in the state log (one per WatchState stream).
struct WatchCursor {
  uint64_t next_event = 0;   ///< First event sequence number not yet delivered.
  uint64_t sample_seq = 0;   ///< Sequence number of the last delivered sample.
  bool has_sample = false;   ///< A sample was delivered.
  RobotPose last;            ///< The last delivered pose.
  std::array<double, 3> velocity{};  ///< The last velocity estimate [m/s].
};

/// The event log and latest sample. Keeps the last kMaxEvents events.
///
/// Thread-safety: every method may be called from any thread; one internal
/// mutex guards the log, and writers wake every waiting watcher. It never
/// calls out while holding it, so callers may hold their own locks.
class StateLog {
 public:
  /// Events kept for late watchers.
  static constexpr std::size_t kMaxEvents = 1024;

  /// Appends an event (and logs it) and wakes the watchers.
  void Push(StateEvent event);
  /// Replaces the latest pose sample and wakes the watchers.
  void RecordSample(const RobotPose& pose);
  /// Counts a new watcher (samples are worth taking while one is counted).
  void AddWatcher() { ++watchers_; }
  /// Uncounts a watcher.
  void RemoveWatcher() { --watchers_; }
  /// True while at least one watcher is counted.
  bool Watched() const { return watchers_.load() > 0; }
  /// A cursor that sees events pushed from now on and the next sample.
  WatchCursor NewCursor() const;
  /// Waits up to `wait` for a sample at least `period` seconds (sample
  /// time) after the cursor's last one, a sample whose time went back (a
  /// reset), or new events; advances the cursor. nullopt when nothing new
  /// arrived or after Shutdown.
  std::optional<StateUpdate> Wait(WatchCursor& cursor, double period,
                                  std::chrono::milliseconds wait);
  /// Wakes every watcher; later waits return nullopt at once. Irreversible.
  void Shutdown();

 private:
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::atomic<int> watchers_{0};
  bool shutdown_ = false;                               // guarded by mutex_
  uint64_t sample_seq_ = 0;                             // guarded by mutex_
  std::optional<RobotPose> latest_sample_;              // guarded by mutex_
  std::deque<std::pair<uint64_t, StateEvent>> events_;  // guarded by mutex_
  uint64_t next_event_seq_ = 0;                         // guarded by mutex_
};

}  // namespace yamor::host
