// The host pool over in-process fake hosts: injected failures, calls past
// their deadline, a server shut down mid-batch, caller errors, all hosts
// down, attempts exhausted, RequestStop and concurrent batches.
#include <gtest/gtest.h>

#include <future>
#include <numeric>

#include "common/status.h"
#include "tests/optimizer-plugins/host_pool/host_pool_test_util.h"
#include "tests/support/unused_port.h"

namespace yamor::optimizer {
namespace {

using namespace testing;  // NOLINT: the test helpers
using ::yamor::testing::UnusedPort;
using std::chrono::seconds;

long long TotalCompleted(const HostPool& pool) {
  long long total = 0;
  for (const HostStatus& s : pool.Status()) total += s.completed;
  return total;
}

// The error EvaluateBatch throws (fails the test if none).
Error BatchError(HostPool& pool, const std::vector<Candidate>& batch) {
  try {
    EvaluateGuarded(pool, batch);
  } catch (const Error& e) {
    return e;
  }
  ADD_FAILURE() << "EvaluateBatch did not throw";
  return Error(StatusCode::kOk, "");
}

TEST(HostPoolFakeTest, SpreadsWorkAndReportsStatus) {
  FakeHost a, b;
  a.capacity = 2;
  b.capacity = 3;
  FakeServer server_a(&a), server_b(&b);
  HostPool pool({server_a.address(), server_b.address()}, FakeSettings(), FastRetry());
  EXPECT_EQ(pool.Capacity(), 5);
  const std::vector<Candidate> batch = MakeCandidates(20);
  const std::vector<Evaluation> results = EvaluateGuarded(pool, batch);
  ExpectScored(batch, results);
  const std::vector<HostStatus> status = pool.Status();
  ASSERT_EQ(status.size(), 2u);
  EXPECT_TRUE(status[0].up && status[1].up);
  EXPECT_EQ(status[0].capacity, 2);
  EXPECT_EQ(status[1].capacity, 3);
  EXPECT_GT(status[0].completed, 0);
  EXPECT_GT(status[1].completed, 0);
  EXPECT_EQ(status[0].completed + status[1].completed, 20);
  EXPECT_EQ(a.served + b.served, 20);
  EXPECT_EQ(status[0].in_flight + status[1].in_flight, 0);
  int on_a = 0;
  for (const Evaluation& e : results) on_a += e.host == server_a.address().ToString();
  EXPECT_EQ(on_a, status[0].completed);
  EXPECT_TRUE(pool.EvaluateBatch({}).empty());
}

TEST(HostPoolFakeTest, FailedCallIsRetriedElsewhereAndTheHostRecovers) {
  FakeHost bad, good;
  bad.capacity = 1;
  good.capacity = 1;
  bad.fail_call = 2;
  FakeServer server_bad(&bad), server_good(&good);
  HostPool pool({server_bad.address(), server_good.address()}, FakeSettings(), FastRetry());
  const std::vector<Candidate> batch = MakeCandidates(12);
  ExpectScored(batch, EvaluateGuarded(pool, batch));
  EXPECT_EQ(TotalCompleted(pool), 12) << "every slot scored once";
  EXPECT_EQ(bad.served + good.served, 12);
  HostStatus s = StatusOf(pool, 0);
  EXPECT_EQ(s.failures, 1);
  EXPECT_NE(s.last_error.find("injected failure"), std::string::npos) << s.last_error;
  // Re-checked after the backoff, the host is used again.
  ASSERT_TRUE(WaitFor([&] { return StatusOf(pool, 0).up; })) << "the failed host came back";
  const int served_before = bad.served;
  const std::vector<Candidate> more = MakeCandidates(8, 5.0);
  ExpectScored(more, EvaluateGuarded(pool, more));
  EXPECT_GT(bad.served, served_before) << "the recovered host takes work";
  EXPECT_EQ(TotalCompleted(pool), 20);
}

TEST(HostPoolFakeTest, CallPastItsDeadlineIsRetriedElsewhere) {
  FakeHost slow, good;
  slow.capacity = 1;
  good.capacity = 1;
  slow.hang_call = 1;
  FakeServer server_slow(&slow), server_good(&good);
  EvaluationSettings settings = FakeSettings();
  settings.deadline_seconds = 0.5;
  HostPool pool({server_slow.address(), server_good.address()}, settings, FastRetry());
  const std::vector<Candidate> batch = MakeCandidates(6);
  ExpectScored(batch, EvaluateGuarded(pool, batch));
  EXPECT_EQ(TotalCompleted(pool), 6);
  const HostStatus s = StatusOf(pool, 0);
  EXPECT_GE(s.failures, 1);
  EXPECT_NE(s.last_error.find("DEADLINE_EXCEEDED"), std::string::npos) << s.last_error;
  EXPECT_TRUE(WaitFor([&] { return slow.cancelled.load() == 1; })) << "the host saw the deadline";
}

TEST(HostPoolFakeTest, ServerShutDownMidBatchThenRestarted) {
  FakeHost a, b;
  a.capacity = 2;
  b.capacity = 2;
  a.delay_ms = 40;
  b.delay_ms = 40;
  FakeServer server_a(&a), server_b(&b);
  HostPool pool({server_a.address(), server_b.address()}, FakeSettings(), FastRetry());
  const std::vector<Candidate> batch = MakeCandidates(24);
  auto result =
      std::async(std::launch::async, [&] { return EvaluateGuarded(pool, batch, seconds(30)); });
  ASSERT_TRUE(WaitFor([&] {
    const HostStatus s = StatusOf(pool, 0);
    return s.completed >= 2 && s.in_flight > 0;
  }));
  server_a.Stop();
  ExpectScored(batch, result.get());
  EXPECT_EQ(TotalCompleted(pool), 24);
  HostStatus s = StatusOf(pool, 0);
  EXPECT_FALSE(s.up);
  EXPECT_GE(s.failures, 1);

  server_a.Restart();
  ASSERT_TRUE(WaitFor([&] { return StatusOf(pool, 0).up; })) << "restarted host found again";
  const long long before = StatusOf(pool, 0).completed;
  const std::vector<Candidate> more = MakeCandidates(8, 3.0);
  ExpectScored(more, EvaluateGuarded(pool, more));
  EXPECT_GT(StatusOf(pool, 0).completed, before);
}

TEST(HostPoolFakeTest, CallerErrorIsNotRetried) {
  FakeHost a, b;
  FakeServer server_a(&a), server_b(&b);
  HostPool pool({server_a.address(), server_b.address()}, FakeSettings(), FastRetry());
  std::vector<Candidate> batch = MakeCandidates(5);
  batch[3].parameters.emplace_back("foo.3", 0.25);
  const Error e = BatchError(pool, batch);
  EXPECT_EQ(e.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(std::string(e.what()).find("foo.3=0.25"), std::string::npos) << e.what();
  EXPECT_NE(std::string(e.what()).find("unknown parameter"), std::string::npos) << e.what();
  EXPECT_EQ(a.refused + b.refused, 1) << "refused once, not retried";
  for (const HostStatus& s : pool.Status()) {
    EXPECT_TRUE(s.up);
    EXPECT_EQ(s.failures, 0);
  }
  // The pool still works.
  const std::vector<Candidate> ok = MakeCandidates(4);
  ExpectScored(ok, EvaluateGuarded(pool, ok));
}

// A caller error while the batch's other calls are in flight, the pool
// destroyed right after (issue 17: a double free in a gRPC thread at exit
// under ASan). The in-flight calls are cancelled, so the destructor returns
// at once instead of waiting for the hung calls' 30 s limit.
TEST(HostPoolFakeTest, CallerErrorWithCallsInFlightThenDestroyed) {
  FakeHost a;
  a.capacity = 4;
  a.hang_all = true;  // every call but the refused one waits until cancelled
  FakeServer server(&a);
  for (int round = 0; round < 10; ++round) {
    std::vector<Candidate> batch = MakeCandidates(4, round);
    batch[3].parameters.emplace_back("foo.1", 1.0);
    auto pool = std::make_unique<HostPool>(std::vector<HostAddress>{server.address()}, FakeSettings(),
                                           FastRetry());
    const Error e = BatchError(*pool, batch);
    EXPECT_EQ(e.code(), StatusCode::kInvalidArgument) << e.what();
    const auto start = Clock::now();
    pool.reset();
    EXPECT_LT(Clock::now() - start, seconds(10)) << "round " << round << ": the destructor waited";
  }
  EXPECT_EQ(a.refused, 10);
}

TEST(HostPoolFakeTest, AllHostsDownGivesUp) {
  PoolOptions options = FastRetry();
  options.health_timeout = 1;
  options.give_up_after = 1;
  const auto start = Clock::now();
  HostPool pool({{"127.0.0.1", UnusedPort()}, {"127.0.0.1", UnusedPort()}}, FakeSettings(), options);
  EXPECT_EQ(pool.Capacity(), 1);
  const Error e = BatchError(pool, MakeCandidates(3));
  EXPECT_EQ(e.code(), StatusCode::kUnavailable);
  EXPECT_NE(std::string(e.what()).find("no healthy host"), std::string::npos) << e.what();
  EXPECT_LT(Clock::now() - start, seconds(30)) << "gave up (hang guard)";
  for (const HostStatus& s : pool.Status()) {
    EXPECT_FALSE(s.up);
    EXPECT_GE(s.failures, 1);
    EXPECT_FALSE(s.last_error.empty());
  }
}

TEST(HostPoolFakeTest, AttemptsExhaustedNameTheCandidate) {
  FakeHost broken;
  broken.fail_all = true;
  FakeServer server(&broken);
  PoolOptions options = FastRetry();
  options.max_attempts = 3;
  HostPool pool({server.address()}, FakeSettings(), options);
  const Error e = BatchError(pool, {Candidate{{{"amplitude.2", 0.75}}}});
  EXPECT_EQ(e.code(), StatusCode::kUnavailable);
  EXPECT_NE(std::string(e.what()).find("amplitude.2=0.75"), std::string::npos) << e.what();
  EXPECT_NE(std::string(e.what()).find("injected failure"), std::string::npos) << e.what();
  EXPECT_EQ(broken.calls, 3);
}

TEST(HostPoolFakeTest, RequestStopCancelsPromptly) {
  FakeHost hung;
  hung.hang_all = true;
  FakeServer server(&hung);
  EvaluationSettings settings = FakeSettings();
  settings.deadline_seconds = 300;  // only the cancellation can end the hung calls in time
  HostPool pool({server.address()}, settings, FastRetry());
  const std::vector<Candidate> batch = MakeCandidates(4);
  auto result = std::async(std::launch::async, [&] { return pool.EvaluateBatch(batch); });
  if (!WaitFor([&] { return hung.calls.load() == 2; })) {
    pool.RequestStop();
    FAIL() << "capacity 2 in flight";
  }
  pool.RequestStop();
  EXPECT_EQ(result.wait_for(seconds(20)), std::future_status::ready) << "stopped (hang guard)";
  try {
    result.get();
    ADD_FAILURE() << "no error after RequestStop";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kCancelled);
  }
  EXPECT_TRUE(WaitFor([&] { return hung.cancelled.load() == 2; })) << "in-flight RPCs cancelled";
  EXPECT_EQ(BatchError(pool, MakeCandidates(1)).code(), StatusCode::kCancelled);
  EXPECT_EQ(BatchError(pool, {}).code(), StatusCode::kCancelled);
  EXPECT_TRUE(StatusOf(pool, 0).up) << "a cancelled call is no host failure";
  EXPECT_EQ(StatusOf(pool, 0).failures, 0);
}

TEST(HostPoolFakeTest, ConcurrentBatchesShareTheHosts) {
  FakeHost a, b;
  a.delay_ms = 5;
  b.delay_ms = 5;
  b.fail_call = 7;  // one failure among the concurrent traffic
  FakeServer server_a(&a), server_b(&b);
  HostPool pool({server_a.address(), server_b.address()}, FakeSettings(), FastRetry());
  std::vector<std::vector<Candidate>> batches;
  for (int t = 0; t < 3; ++t) batches.push_back(MakeCandidates(10, 100.0 * (t + 1)));
  std::vector<std::future<std::vector<Evaluation>>> results;
  for (int t = 0; t < 3; ++t) {
    results.push_back(std::async(std::launch::async, [&, t] {
      return EvaluateGuarded(pool, batches[t], seconds(30));
    }));
  }
  for (int t = 0; t < 3; ++t) ExpectScored(batches[t], results[t].get());
  EXPECT_EQ(TotalCompleted(pool), 30) << "every slot scored once";
  // A call cancelled after b's failure may still have finished on b.
  EXPECT_GE(a.served + b.served, 30);
}

TEST(HostPoolFakeTest, HealthCheckDecidesWhenAHostIsUsed) {
  FakeHost a, b;
  FakeServer server_a(&a), server_b(&b, 0, /*health=*/false);
  server_a.SetServing(false);
  HostPool pool({server_a.address(), server_b.address()}, FakeSettings(), FastRetry());
  HostStatus s = StatusOf(pool, 0);
  EXPECT_FALSE(s.up) << "NOT_SERVING";
  EXPECT_NE(s.last_error.find("not serving"), std::string::npos) << s.last_error;
  EXPECT_TRUE(StatusOf(pool, 1).up) << "a server without the health service is judged by GetInfo";
  EXPECT_EQ(pool.Capacity(), 2);
  const std::vector<Candidate> batch = MakeCandidates(6);
  ExpectScored(batch, EvaluateGuarded(pool, batch));
  EXPECT_EQ(a.calls, 0);
  server_a.SetServing(true);
  EXPECT_TRUE(WaitFor([&] { return StatusOf(pool, 0).up; }));
  EXPECT_EQ(pool.Capacity(), 4);
}

TEST(HostPoolFakeTest, RejectsBadConstruction) {
  EXPECT_THROW(HostPool({}, FakeSettings()), Error);
  PoolOptions options;
  options.max_attempts = 0;
  EXPECT_THROW(HostPool({{"127.0.0.1", 1}}, FakeSettings(), options), Error);
  EXPECT_THROW(HostPool({{"127.0.0.1", 1}, {"127.0.0.1", 1}}, FakeSettings()), Error);
}

}  // namespace
}  // namespace yamor::optimizer
