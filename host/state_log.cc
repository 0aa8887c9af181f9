#include "host/state_log.h"

#include <cmath>

#include "common/log.h"

namespace yamor::host {

void StateLog::Push(StateEvent event) {
  Log().info("event {}{}{}", event.kind,
             event.module_id >= 0 ? " module " + std::to_string(event.module_id) : std::string(),
             event.detail.empty() ? std::string() : ": " + event.detail);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    events_.emplace_back(next_event_seq_++, std::move(event));
    while (events_.size() > kMaxEvents) events_.pop_front();
  }
  cv_.notify_all();
}

void StateLog::RecordSample(const RobotPose& pose) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    latest_sample_ = pose;
    ++sample_seq_;
  }
  cv_.notify_all();
}

WatchCursor StateLog::NewCursor() const {
  WatchCursor cursor;
  std::lock_guard<std::mutex> lock(mutex_);
  cursor.next_event = next_event_seq_;
  return cursor;
}

std::optional<StateUpdate> StateLog::Wait(WatchCursor& cursor, double period,
                                          std::chrono::milliseconds wait) {
  std::unique_lock<std::mutex> lock(mutex_);
  auto new_sample = [&] {
    if (!latest_sample_ || (cursor.has_sample && sample_seq_ == cursor.sample_seq)) return false;
    if (!cursor.has_sample) return true;
    const double t = latest_sample_->time;
    // Time going back means a reset or a new world: report it at once.
    if (t < cursor.last.time) return true;
    // Due at the next multiple of the period after the last report, not a
    // period after it: a watcher that woke late (its last report off the grid)
    // would otherwise skip the sample that ends a Sleep on the grid and wait
    // for time that may never come.
    const double next_due = (std::floor(cursor.last.time / period + 1e-9) + 1.0) * period;
    return t >= next_due - 1e-9;
  };
  auto new_events = [&] { return !events_.empty() && events_.back().first >= cursor.next_event; };
  cv_.wait_for(lock, wait, [&] { return shutdown_ || new_sample() || new_events(); });
  if (shutdown_ || (!new_sample() && !new_events())) return std::nullopt;
  StateUpdate update;
  for (const auto& entry : events_) {
    if (entry.first >= cursor.next_event) update.events.push_back(entry.second);
  }
  cursor.next_event = next_event_seq_;
  if (new_sample()) {
    const RobotPose& pose = *latest_sample_;
    const double dt = pose.time - cursor.last.time;
    if (cursor.has_sample && dt > 0.0) {
      for (int i = 0; i < 3; ++i) {
        cursor.velocity[i] = (pose.position[i] - cursor.last.position[i]) / dt;
      }
    } else {
      cursor.velocity = {0.0, 0.0, 0.0};
    }
    cursor.last = pose;
    cursor.has_sample = true;
    cursor.sample_seq = sample_seq_;
  }
  update.pose = cursor.last;
  update.velocity = cursor.velocity;
  return update;
}

void StateLog::Shutdown() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    shutdown_ = true;
  }
  cv_.notify_all();
}

}  // namespace yamor::host
