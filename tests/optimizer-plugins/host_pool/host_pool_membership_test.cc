// The host pool's membership changing mid-batch (issue 17 §3), over
// in-process fake hosts: SetHosts adds hosts after their health check and
// drains removed ones (their evaluations finish there, or are re-queued when
// the host fails while draining), and HostListWatcher applies a host file's
// changes. Every slot is filled once, by the candidate's own score.
#include <unistd.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <future>

#include "common/status.h"
#include "tests/optimizer-plugins/host_pool/host_pool_test_util.h"
#include "tests/support/code_of.h"

namespace yamor::optimizer {
namespace {

using namespace testing;  // NOLINT: the test helpers
using ::yamor::testing::CodeOf;
using std::chrono::seconds;

std::optional<HostStatus> StatusNamed(const HostPool& pool, const HostAddress& address) {
  for (const HostStatus& s : pool.Status()) {
    if (s.address.ToString() == address.ToString()) return s;
  }
  return std::nullopt;
}

int Count(const std::vector<Evaluation>& results, const HostAddress& address) {
  int n = 0;
  for (const Evaluation& e : results) n += e.host == address.ToString();
  return n;
}

TEST(HostPoolMembershipTest, AnAddedHostJoinsAfterItsHealthCheck) {
  FakeHost a, b;
  a.capacity = 1;
  b.capacity = 2;
  a.delay_ms = 30;
  b.delay_ms = 30;
  FakeServer server_a(&a), server_b(&b);
  server_b.SetServing(false);
  HostPool pool({server_a.address()}, FakeSettings(), FastRetry());
  pool.SetHosts({server_a.address(), server_b.address()});
  ASSERT_TRUE(WaitFor([&] { return StatusNamed(pool, server_b.address()).has_value(); }));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  EXPECT_FALSE(StatusNamed(pool, server_b.address())->up) << "not serving: not used";
  EXPECT_EQ(pool.Capacity(), 1);
  server_b.SetServing(true);
  ASSERT_TRUE(WaitFor([&] { return StatusNamed(pool, server_b.address())->up; }));
  EXPECT_EQ(pool.Capacity(), 3);
  const std::vector<Candidate> batch = MakeCandidates(12);
  const std::vector<Evaluation> results = EvaluateGuarded(pool, batch);
  ExpectScored(batch, results);
  EXPECT_GT(Count(results, server_b.address()), 0);
  EXPECT_EQ(a.served + b.served, 12) << "no evaluation twice";
}

TEST(HostPoolMembershipTest, ARemovedHostFinishesItsEvaluationsAndTakesNoMore) {
  FakeHost a, b;
  a.capacity = 2;
  b.capacity = 2;
  a.delay_ms = 300;
  b.delay_ms = 20;
  FakeServer server_a(&a), server_b(&b);
  HostPool pool({server_a.address(), server_b.address()}, FakeSettings(), FastRetry());
  const std::vector<Candidate> batch = MakeCandidates(16);
  auto running = std::async(std::launch::async, [&] { return EvaluateGuarded(pool, batch); });
  ASSERT_TRUE(WaitFor([&] { return a.calls.load() == 2; }));
  pool.SetHosts({server_b.address()});
  const int calls_at_removal = a.calls.load();
  const std::optional<HostStatus> draining = StatusNamed(pool, server_a.address());
  ASSERT_TRUE(draining.has_value()) << "still finishing its two evaluations";
  EXPECT_TRUE(draining->draining);
  EXPECT_EQ(pool.Capacity(), 2);
  const std::vector<Evaluation> results = running.get();
  ExpectScored(batch, results);
  EXPECT_EQ(a.calls.load(), calls_at_removal) << "no new work after the removal";
  EXPECT_EQ(a.served.load(), calls_at_removal) << "its evaluations finished there";
  EXPECT_EQ(Count(results, server_a.address()), calls_at_removal);
  EXPECT_EQ(a.served + b.served, 16) << "none lost, none twice";
  ASSERT_TRUE(WaitFor([&] { return !StatusNamed(pool, server_a.address()).has_value(); }))
      << "a drained host leaves the pool";
  EXPECT_EQ(pool.Status().size(), 1u);
}

TEST(HostPoolMembershipTest, AHostFailingWhileDrainingHasItsWorkRequeued) {
  FakeHost a, b;
  a.capacity = 2;
  b.capacity = 1;
  a.hang_all = true;  // its evaluations never finish by themselves
  b.delay_ms = 10;
  FakeServer server_a(&a), server_b(&b);
  HostPool pool({server_a.address(), server_b.address()}, FakeSettings(), FastRetry());
  const std::vector<Candidate> batch = MakeCandidates(8);
  auto running = std::async(std::launch::async, [&] { return EvaluateGuarded(pool, batch); });
  ASSERT_TRUE(WaitFor([&] { return a.calls.load() == 2; }));
  pool.SetHosts({server_b.address()});
  server_a.Stop();  // the draining host dies: its two evaluations go to b
  const std::vector<Evaluation> results = running.get();
  ExpectScored(batch, results);
  EXPECT_EQ(b.served.load(), 8);
  EXPECT_EQ(Count(results, server_b.address()), 8);
  ASSERT_TRUE(WaitFor([&] { return !StatusNamed(pool, server_a.address()).has_value(); }));
}

TEST(HostPoolMembershipTest, ADrainingHostListedAgainStays) {
  FakeHost a, b;
  a.delay_ms = 200;
  FakeServer server_a(&a), server_b(&b);
  HostPool pool({server_a.address(), server_b.address()}, FakeSettings(), FastRetry());
  const std::vector<Candidate> batch = MakeCandidates(10);
  auto running = std::async(std::launch::async, [&] { return EvaluateGuarded(pool, batch); });
  ASSERT_TRUE(WaitFor([&] { return a.calls.load() >= 1; }));
  pool.SetHosts({server_b.address()});
  pool.SetHosts({server_b.address(), server_a.address()});
  const std::optional<HostStatus> back = StatusNamed(pool, server_a.address());
  ASSERT_TRUE(back.has_value());
  EXPECT_FALSE(back->draining);
  EXPECT_TRUE(back->up) << "kept its health and its place";
  ExpectScored(batch, running.get());
  EXPECT_EQ(a.served + b.served, 10);
  EXPECT_EQ(pool.Status().size(), 2u);
}

TEST(HostPoolMembershipTest, BadListsChangeNothing) {
  FakeHost a;
  FakeServer server_a(&a);
  HostPool pool({server_a.address()}, FakeSettings(), FastRetry());
  EXPECT_EQ(CodeOf([&] { pool.SetHosts({}); }), StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf([&] { pool.SetHosts({server_a.address(), server_a.address()}); }),
            StatusCode::kInvalidArgument);
  ASSERT_EQ(pool.Status().size(), 1u);
  EXPECT_FALSE(pool.Status()[0].draining);
}

TEST(HostPoolMembershipTest, TheWatcherAppliesTheHostFileWhenItChanges) {
  FakeHost a, b;
  FakeServer server_a(&a), server_b(&b);
  const std::string path =
      (std::filesystem::path(::testing::TempDir()) /
       ("pool_watcher_hosts_" + std::to_string(::getpid()) + ".txt"))
          .string();
  const auto write = [&](const std::string& text) {
    const std::string temporary = path + ".tmp";
    std::ofstream(temporary) << text;
    std::filesystem::rename(temporary, path);
  };
  write(server_a.address().ToString() + "\n");
  HostPool pool(ParseHosts("@" + path), FakeSettings(), FastRetry());
  HostListWatcher watcher(path, pool, 0.02);
  write("# two now\n" + server_a.address().ToString() + "\n" + server_b.address().ToString() +
        "\n");
  // The watcher counts a list once SetHosts returned, which may be after the
  // pool shows the change: wait for both.
  ASSERT_TRUE(WaitFor([&] {
    const auto s = StatusNamed(pool, server_b.address());
    return s && s->up && watcher.Applied() == 1;
  }));
  write("not a host\n");  // refused: the membership stays
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  EXPECT_EQ(watcher.Applied(), 1);
  EXPECT_EQ(pool.Status().size(), 2u);
  write(server_b.address().ToString() + "\n");
  ASSERT_TRUE(WaitFor([&] { return pool.Status().size() == 1u && watcher.Applied() == 2; }));
  EXPECT_EQ(pool.Status()[0].address.ToString(), server_b.address().ToString());
  const std::vector<Candidate> batch = MakeCandidates(4);
  ExpectScored(batch, EvaluateGuarded(pool, batch));
  EXPECT_EQ(b.served.load(), 4);
}

}  // namespace
}  // namespace yamor::optimizer
