// A first-come, first-served mutex (ticket lock on std::mutex +
// std::condition_variable). The RobotDriver needs fairness: a long
// virtual-time Sleep releases the robot between chunks, and with std::mutex
// (not fair) the stepping thread re-took it before any waiting caller got a
// turn (commit 734bcba). With tickets, everyone who queued during a chunk is
// served, in order, before the Sleep's next chunk: a standard hand-off that
// replaces the driver's former waiter counter and yield loop.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <mutex>

namespace yamor::host {

/// A FIFO mutex (BasicLockable; use with std::unique_lock and
/// std::condition_variable_any). Thread-safety: all methods are safe from any
/// thread; unlock only by the holder. Not recursive.
class TicketMutex {
 public:
  /// Takes the next ticket and blocks until it is served.
  void lock() {
    std::unique_lock<std::mutex> lock(mutex_);
    const uint64_t ticket = next_ticket_++;
    turn_.wait(lock, [&] { return serving_ == ticket; });
  }
  /// Serves the next ticket.
  void unlock() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ++serving_;
    }
    turn_.notify_all();
  }
  /// Threads waiting for their turn (excluding the holder), for tests.
  uint64_t waiting() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return next_ticket_ - serving_ - (next_ticket_ > serving_ ? 1 : 0);
  }

 private:
  mutable std::mutex mutex_;
  std::condition_variable turn_;
  uint64_t next_ticket_ = 0;  // guarded by mutex_
  uint64_t serving_ = 0;      // guarded by mutex_
};

}  // namespace yamor::host
