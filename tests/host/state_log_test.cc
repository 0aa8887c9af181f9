// StateLog (the WatchState event log, extracted from the driver): events
// since the cursor, sample pacing by period, time going back, shutdown.
#include "host/state_log.h"

#include <gtest/gtest.h>

#include <chrono>
#include <thread>

namespace yamor::host {
namespace {

using std::chrono::milliseconds;

RobotPose PoseAt(double t, double x) {
  return RobotPose{.time = t, .position = {x, 0.0, 0.0}, .source = "simulation"};
}

TEST(StateLogTest, DeliversEventsPushedAfterTheCursorOnce) {
  StateLog log;
  log.Push(StateEvent{.kind = "opened"});
  WatchCursor cursor = log.NewCursor();
  log.Push(StateEvent{.kind = "connected", .detail = "3 links"});
  log.Push(StateEvent{.kind = "defect_set", .module_id = 2});
  const auto update = log.Wait(cursor, 0.1, milliseconds(0));
  ASSERT_TRUE(update);
  ASSERT_EQ(update->events.size(), 2u);
  EXPECT_EQ(update->events[0].kind, "connected");
  EXPECT_EQ(update->events[1].module_id, 2);
  EXPECT_FALSE(log.Wait(cursor, 0.1, milliseconds(0)));  // nothing new
}

TEST(StateLogTest, SamplesArePacedByPeriodAndGiveAVelocity) {
  StateLog log;
  WatchCursor cursor = log.NewCursor();
  log.RecordSample(PoseAt(1.0, 0.0));
  auto first = log.Wait(cursor, 0.5, milliseconds(0));
  ASSERT_TRUE(first);
  EXPECT_EQ(first->velocity[0], 0.0);
  log.RecordSample(PoseAt(1.2, 0.1));  // before the period is over
  EXPECT_FALSE(log.Wait(cursor, 0.5, milliseconds(0)));
  log.RecordSample(PoseAt(1.5, 0.25));
  auto second = log.Wait(cursor, 0.5, milliseconds(0));
  ASSERT_TRUE(second);
  EXPECT_DOUBLE_EQ(second->pose.time, 1.5);
  EXPECT_DOUBLE_EQ(second->velocity[0], 0.5);
  log.RecordSample(PoseAt(0.0, 0.0));  // a reset: time went back
  auto reset = log.Wait(cursor, 0.5, milliseconds(0));
  ASSERT_TRUE(reset);
  EXPECT_EQ(reset->pose.time, 0.0);
  EXPECT_EQ(reset->velocity[0], 0.0);
}

TEST(StateLogTest, ALateWatcherGetsBackOnThePeriodGrid) {
  StateLog log;
  WatchCursor cursor = log.NewCursor();
  log.RecordSample(PoseAt(0.0, 0.0));
  ASSERT_TRUE(log.Wait(cursor, 0.25, milliseconds(0)));
  // The watcher woke late: the first sample it sees is off the grid.
  log.RecordSample(PoseAt(0.8, 0.0));
  auto late = log.Wait(cursor, 0.25, milliseconds(0));
  ASSERT_TRUE(late);
  EXPECT_DOUBLE_EQ(late->pose.time, 0.8);
  // A Sleep ending at 1.0 is due on the grid (0.8 + 0.25 would skip it and
  // the stream would wait for time that may never come).
  log.RecordSample(PoseAt(0.9, 0.0));
  EXPECT_FALSE(log.Wait(cursor, 0.25, milliseconds(0)));
  log.RecordSample(PoseAt(1.0, 0.0));
  auto on_grid = log.Wait(cursor, 0.25, milliseconds(0));
  ASSERT_TRUE(on_grid);
  EXPECT_DOUBLE_EQ(on_grid->pose.time, 1.0);
}

TEST(StateLogTest, KeepsTheLastEventsOnly) {
  StateLog log;
  WatchCursor cursor = log.NewCursor();
  for (std::size_t i = 0; i < StateLog::kMaxEvents + 10; ++i) {
    log.Push(StateEvent{.kind = "e", .module_id = static_cast<int>(i)});
  }
  const auto update = log.Wait(cursor, 0.1, milliseconds(0));
  ASSERT_TRUE(update);
  ASSERT_EQ(update->events.size(), StateLog::kMaxEvents);
  EXPECT_EQ(update->events.front().module_id, 10);
}

TEST(StateLogTest, WakesAWaiterAndShutsDown) {
  StateLog log;
  WatchCursor cursor = log.NewCursor();
  std::thread pusher([&] {
    std::this_thread::sleep_for(milliseconds(20));
    log.Push(StateEvent{.kind = "reset"});
  });
  const auto update = log.Wait(cursor, 0.1, milliseconds(5000));
  pusher.join();
  ASSERT_TRUE(update);
  EXPECT_EQ(update->events.at(0).kind, "reset");
  log.AddWatcher();
  EXPECT_TRUE(log.Watched());
  log.RemoveWatcher();
  EXPECT_FALSE(log.Watched());
  log.Shutdown();
  log.Push(StateEvent{.kind = "late"});
  EXPECT_FALSE(log.Wait(cursor, 0.1, milliseconds(1000)));
}

}  // namespace
}  // namespace yamor::host
