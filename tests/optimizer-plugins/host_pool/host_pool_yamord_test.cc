// The host pool over real yamord daemons (path compiled in) on ephemeral
// ports: results equal direct Evaluate calls, a daemon killed mid-batch,
// a caller error from the daemon, a host file growing and shrinking while a
// batch runs.
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <future>
#include <map>
#include <set>

#include "common/status.h"
#include "tests/optimizer-plugins/host_pool/host_pool_test_util.h"
#include "tests/support/yamord_process.h"

namespace yamor::optimizer {
namespace {

using namespace testing;  // NOLINT: the test helpers
using std::chrono::seconds;

const char* const kYamord = YAMORD_PATH;

// A yamord on 127.0.0.1:0 with `workers` Evaluate workers, killed at the end.
class Daemon : public ::yamor::testing::YamordProcess {
 public:
  explicit Daemon(int workers)
      : YamordProcess(kYamord, {"--listen", "127.0.0.1:0", "--log-level", "warn", "--workers",
                                std::to_string(workers)}),
        port_(WaitForPort()) {}
  int port() const { return port_; }
  HostAddress address() const { return HostAddress{"127.0.0.1", port_}; }

 private:
  int port_;
};

EvaluationSettings Quadruped() {
  EvaluationSettings settings;
  settings.world = "quadruped";
  settings.warmup = 1;
  settings.duration = 1;
  settings.seed = 11;
  return settings;
}

PoolOptions FastRetry() {
  PoolOptions options;
  options.health_timeout = 5;
  options.retry_initial = 0.05;
  options.retry_max = 0.5;
  options.give_up_after = 30;
  return options;
}

std::vector<Candidate> Gaits(int count) {
  std::vector<Candidate> out;
  for (int i = 0; i < count; ++i) {
    out.push_back(Candidate{{{"phase.0.1", 0.4 * i}, {"amplitude.5", 0.3 + 0.05 * i}}});
  }
  return out;
}

// A direct Evaluate of `candidate` with `settings` on `address`.
yamor::v1::EvaluateResponse DirectEvaluate(const HostAddress& address,
                                          const EvaluationSettings& settings,
                                          const Candidate& candidate) {
  auto stub = yamor::v1::Host::NewStub(
      grpc::CreateChannel(address.ToString(), grpc::InsecureChannelCredentials()));
  yamor::v1::EvaluateRequest request;
  request.set_world(settings.world);
  request.set_warmup(settings.warmup);
  request.set_duration(settings.duration);
  request.set_seed(settings.seed);
  for (const auto& [name, value] : candidate.parameters) {
    auto* p = request.add_parameters();
    p->set_name(name);
    p->set_value(value);
  }
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + seconds(60));
  yamor::v1::EvaluateResponse response;
  const grpc::Status status = stub->Evaluate(&context, request, &response);
  EXPECT_TRUE(status.ok()) << status.error_message();
  return response;
}

TEST(HostPoolYamordTest, TwoDaemonsGiveTheDirectResultsInOrder) {
  Daemon a(1), b(1);
  ASSERT_GT(a.port(), 0);
  ASSERT_GT(b.port(), 0);
  HostPool pool({a.address(), b.address()}, Quadruped(), FastRetry());
  EXPECT_EQ(pool.Capacity(), 2);
  const std::vector<Candidate> batch = Gaits(6);
  const std::vector<Evaluation> results = EvaluateGuarded(pool, batch);
  ASSERT_EQ(results.size(), batch.size());
  std::set<std::string> hosts;
  for (std::size_t i = 0; i < batch.size(); ++i) {
    const yamor::v1::EvaluateResponse direct = DirectEvaluate(a.address(), Quadruped(), batch[i]);
    EXPECT_EQ(results[i].velocity, direct.velocity()) << "slot " << i << " bit-identical";
    EXPECT_EQ(results[i].distance, direct.distance()) << "slot " << i;
    EXPECT_EQ(results[i].diverged, direct.diverged());
    EXPECT_GT(results[i].wall_seconds, 0.0);
    hosts.insert(results[i].host);
  }
  EXPECT_EQ(hosts, (std::set<std::string>{a.address().ToString(), b.address().ToString()}));
  std::set<double> velocities;
  for (const Evaluation& e : results) velocities.insert(e.velocity);
  EXPECT_GT(velocities.size(), 1u) << "the candidates differ";
}

TEST(HostPoolYamordTest, DaemonKilledMidBatch) {
  Daemon a(1), b(1);
  ASSERT_GT(a.port(), 0);
  ASSERT_GT(b.port(), 0);
  HostPool pool({a.address(), b.address()}, Quadruped(), FastRetry());
  // Each gait twice: equal results prove no slot got another's reply.
  std::vector<Candidate> batch;
  for (const Candidate& c : Gaits(4)) {
    batch.push_back(c);
    batch.push_back(c);
  }
  auto result =
      std::async(std::launch::async, [&] { return EvaluateGuarded(pool, batch, seconds(90)); });
  ASSERT_TRUE(WaitFor([&] {
    const HostStatus s = StatusOf(pool, 1);
    return s.completed >= 1 && s.in_flight > 0;
  }, seconds(60)));
  b.Kill();
  const std::vector<Evaluation> results = result.get();
  ASSERT_EQ(results.size(), batch.size());
  for (std::size_t i = 0; i < batch.size(); i += 2) {
    EXPECT_EQ(results[i].velocity, results[i + 1].velocity) << "slots " << i << ", " << i + 1;
    EXPECT_FALSE(results[i].diverged);
  }
  const HostStatus s = StatusOf(pool, 1);
  EXPECT_FALSE(s.up);
  EXPECT_GE(s.failures, 1);
  EXPECT_EQ(StatusOf(pool, 0).completed + s.completed, static_cast<long long>(batch.size()));
  EXPECT_EQ(pool.Capacity(), 1);
}

TEST(HostPoolYamordTest, UnknownParameterIsACallerError) {
  Daemon a(1);
  ASSERT_GT(a.port(), 0);
  HostPool pool({a.address()}, Quadruped(), FastRetry());
  try {
    pool.EvaluateBatch({Candidate{{{"phase.0.1", 1.0}, {"foo.3", 2.0}}}});
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kInvalidArgument) << e.what();
    EXPECT_NE(std::string(e.what()).find("foo.3"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(a.address().ToString()), std::string::npos) << e.what();
  }
  const HostStatus s = StatusOf(pool, 0);
  EXPECT_TRUE(s.up);
  EXPECT_EQ(s.failures, 0) << "a caller error is no host failure";
}

// Issue 13 §2 "model" mode: the robot's condition travels with every request.
TEST(HostPoolYamordTest, TheRobotsConditionReachesEveryEvaluation) {
  Daemon a(1);
  ASSERT_GT(a.port(), 0);
  const std::vector<Candidate> gait = Gaits(1);
  HostPool healthy({a.address()}, Quadruped(), FastRetry());
  const double base = EvaluateGuarded(healthy, gait).at(0).velocity;

  EvaluationSettings broken = Quadruped();
  broken.motor_defects = {{2, MotorDefect::kLimp}, {3, MotorDefect::kOk}};
  broken.module_defects = {6};
  broken.ground_friction = 0.3;
  broken.ground_slope = 0.05;
  broken.ground_slope_direction = 1.0;
  broken.upside_down = true;
  HostPool pool({a.address()}, broken, FastRetry());
  const double changed = EvaluateGuarded(pool, gait).at(0).velocity;
  EXPECT_NE(changed, base);

  // The same condition in a direct request gives the bit-identical result.
  auto stub = yamor::v1::Host::NewStub(
      grpc::CreateChannel(a.address().ToString(), grpc::InsecureChannelCredentials()));
  yamor::v1::EvaluateRequest request;
  request.set_world("quadruped");
  request.set_warmup(1);
  request.set_duration(1);
  request.set_seed(11);
  for (const auto& [name, value] : gait[0].parameters) {
    auto* p = request.add_parameters();
    p->set_name(name);
    p->set_value(value);
  }
  auto* limp = request.add_motor_defects();
  limp->set_module_id(2);
  limp->set_defect(yamor::v1::MOTOR_LIMP);
  request.add_motor_defects()->set_module_id(3);
  auto* dead = request.add_module_defects();
  dead->set_module_id(6);
  dead->set_defective(true);
  request.mutable_ground()->set_friction(0.3);
  request.mutable_ground()->set_slope(0.05);
  request.mutable_ground()->set_slope_direction(1.0);
  request.set_upside_down(true);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + seconds(60));
  yamor::v1::EvaluateResponse direct;
  ASSERT_TRUE(stub->Evaluate(&context, request, &direct).ok());
  EXPECT_EQ(changed, direct.velocity());

  EvaluationSettings unknown = Quadruped();
  unknown.module_defects = {77};
  HostPool refused({a.address()}, unknown, FastRetry());
  std::string message;
  try {
    refused.EvaluateBatch(gait);
    ADD_FAILURE() << "module 77 accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kNotFound) << e.what();
    EXPECT_NE(std::string(e.what()).find("module 77"), std::string::npos) << e.what();
  }
}

// Issue 17 §3: daemons started and stopped mid-batch, joining and leaving
// through the host file; no slot is lost or filled twice, and every result is
// the daemon's own answer for its candidate.
TEST(HostPoolYamordTest, HostFileGrowsAndShrinksWhileABatchRuns) {
  EvaluationSettings settings = Quadruped();
  settings.warmup = 0.3;
  settings.duration = 0.5;
  const std::string path =
      (std::filesystem::path(::testing::TempDir()) / "pool_yamord_hosts.txt").string();
  const auto write = [&](const std::vector<const Daemon*>& daemons) {
    std::string text = "# written by the test\n";
    for (const Daemon* d : daemons) text += d->address().ToString() + "\n";
    std::ofstream(path + ".tmp") << text;
    std::filesystem::rename(path + ".tmp", path);
  };
  const auto completed = [](const HostPool& pool, const Daemon& d) -> long long {
    for (const HostStatus& s : pool.Status()) {
      if (s.address.ToString() == d.address().ToString()) return s.completed;
    }
    return -1;  // not (or no longer) in the pool
  };
  auto a = std::make_unique<Daemon>(1);
  ASSERT_GT(a->port(), 0);
  write({a.get()});
  HostPool pool(ParseHosts("@" + path), settings, FastRetry());
  HostListWatcher watcher(path, pool, 0.05);
  // Each gait twice: equal results prove no slot got another's reply.
  std::vector<Candidate> batch;
  for (const Candidate& c : Gaits(15)) {
    batch.push_back(c);
    batch.push_back(c);
  }
  auto result =
      std::async(std::launch::async, [&] { return EvaluateGuarded(pool, batch, seconds(120)); });
  ASSERT_TRUE(WaitFor([&] { return completed(pool, *a) >= 2; }, seconds(60)));

  Daemon b(1);  // started mid-batch and listed
  ASSERT_GT(b.port(), 0);
  write({a.get(), &b});
  ASSERT_TRUE(WaitFor([&] { return completed(pool, b) >= 1; }, seconds(60)));

  write({&b});  // a is unlisted: it finishes its evaluation, then leaves
  ASSERT_TRUE(WaitFor([&] { return completed(pool, *a) == -1; }, seconds(60)));
  a.reset();    // and is stopped

  Daemon c(1);  // another one joins, then b dies without being unlisted
  ASSERT_GT(c.port(), 0);
  write({&b, &c});
  ASSERT_TRUE(WaitFor([&] { return completed(pool, c) >= 1; }, seconds(60)));
  b.Kill();

  const std::vector<Evaluation> results = result.get();
  ASSERT_EQ(results.size(), batch.size());
  std::map<std::string, int> per_host;
  for (const Evaluation& e : results) ++per_host[e.host];
  EXPECT_EQ(per_host.size(), 3u) << "a, b and c each scored some";
  for (std::size_t i = 0; i < batch.size(); i += 2) {
    EXPECT_EQ(results[i].velocity, results[i + 1].velocity) << "slots " << i << ", " << i + 1;
    EXPECT_FALSE(results[i].diverged);
  }
  for (std::size_t i = 0; i < batch.size(); i += 6) {
    const yamor::v1::EvaluateResponse direct = DirectEvaluate(c.address(), settings, batch[i]);
    EXPECT_EQ(results[i].velocity, direct.velocity()) << "slot " << i << " bit-identical";
  }
  EXPECT_EQ(watcher.Applied(), 3);
}

}  // namespace
}  // namespace yamor::optimizer
