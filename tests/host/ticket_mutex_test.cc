// TicketMutex: first come, first served, so a thread that releases and
// re-locks at once goes behind everyone already waiting (the driver's Sleep
// hand-off between chunks).
#include "host/ticket_mutex.h"

#include <gtest/gtest.h>

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>
#include <vector>

namespace yamor::host {
namespace {

void WaitUntilWaiting(const TicketMutex& mutex, uint64_t n) {
  while (mutex.waiting() < n) std::this_thread::sleep_for(std::chrono::milliseconds(1));
}

TEST(TicketMutexTest, ServesWaitersInArrivalOrderBeforeARelock) {
  TicketMutex mutex;
  std::vector<int> order;  // guarded by mutex
  mutex.lock();
  std::vector<std::thread> threads;
  for (int i = 1; i <= 4; ++i) {
    threads.emplace_back([&, i] {
      std::lock_guard<TicketMutex> lock(mutex);
      order.push_back(i);
    });
    WaitUntilWaiting(mutex, static_cast<uint64_t>(i));  // i queues before i + 1
  }
  // The holder releases and immediately wants the mutex again, as a Sleep
  // between two chunks does: it must come after all four waiters.
  mutex.unlock();
  mutex.lock();
  order.push_back(0);
  mutex.unlock();
  for (std::thread& t : threads) t.join();
  EXPECT_EQ(order, (std::vector<int>{1, 2, 3, 4, 0}));
  EXPECT_EQ(mutex.waiting(), 0u);
}

TEST(TicketMutexTest, ExcludesMutuallyUnderContention) {
  TicketMutex mutex;
  int inside = 0;
  int64_t counter = 0;
  bool overlap = false;
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&] {
      for (int i = 0; i < 2000; ++i) {
        std::lock_guard<TicketMutex> lock(mutex);
        if (++inside != 1) overlap = true;
        ++counter;
        --inside;
      }
    });
  }
  for (std::thread& t : threads) t.join();
  EXPECT_FALSE(overlap);
  EXPECT_EQ(counter, 8000);
}

TEST(TicketMutexTest, WorksWithConditionVariableAny) {
  TicketMutex mutex;
  std::condition_variable_any cv;
  bool ready = false;
  std::thread waiter([&] {
    std::unique_lock<TicketMutex> lock(mutex);
    cv.wait(lock, [&] { return ready; });
    EXPECT_TRUE(ready);
  });
  {
    std::lock_guard<TicketMutex> lock(mutex);
    ready = true;
  }
  cv.notify_all();
  waiter.join();
}

}  // namespace
}  // namespace yamor::host
