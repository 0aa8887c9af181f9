// The Evaluate workers: a fixed pool of threads that run queued jobs (one
// evaluation each) in FIFO order, apart from the stateful robot calls.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <thread>
#include <utility>
#include <vector>

namespace yamor::host {

/// A fixed pool of worker threads running queued jobs in FIFO order.
/// Thread-safety: Submit and Shutdown may be called from any thread.
class WorkerPool {
 public:
  /// Starts `workers` threads (0 = std::thread::hardware_concurrency, at least 1).
  explicit WorkerPool(unsigned workers);
  /// Shuts down and joins.
  ~WorkerPool();
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  /// Queues `job`; the future carries its result or exception. Throws
  /// UNAVAILABLE after Shutdown.
  template <typename F>
  auto Submit(F job) -> std::future<decltype(job())> {
    using Result = decltype(job());
    auto task = std::make_shared<std::packaged_task<Result()>>(std::move(job));
    std::future<Result> future = task->get_future();
    Enqueue([task] { (*task)(); });
    return future;
  }

  /// Number of worker threads.
  unsigned size() const { return static_cast<unsigned>(threads_.size()); }
  /// Jobs waiting for a worker.
  std::size_t queued() const;
  /// Stops accepting jobs; queued jobs still run; running jobs should watch
  /// stopping() (via their cancel check) to end early. Joins the workers.
  void Shutdown();
  /// True once Shutdown was called.
  bool stopping() const;

 private:
  void Enqueue(std::function<void()> job);
  void WorkerLoop();

  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<std::function<void()>> jobs_;  // guarded by mutex_
  bool stopping_ = false;                   // guarded by mutex_
  std::vector<std::thread> threads_;        // written only in the constructor/Shutdown
};

}  // namespace yamor::host
