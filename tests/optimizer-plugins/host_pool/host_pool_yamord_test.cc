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

#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <thread>
#include <future>
#include <map>
#include <set>

#include "common/status.h"
#include "tests/optimizer-plugins/host_pool/host_pool_test_util.h"
#include "tests/support/code_of.h"
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

// Real daemons start slower than fakes: a longer health check and backoff.
PoolOptions DaemonRetry() { return FastRetry(5, 0.5); }

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
  HostPool pool({a.address(), b.address()}, Quadruped(), DaemonRetry());
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
  HostPool pool({a.address(), b.address()}, Quadruped(), DaemonRetry());
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
  HostPool pool({a.address()}, Quadruped(), DaemonRetry());
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

// Issue 14: FilmCandidate evaluates once more with frames on a host of the
// pool: the same result as the batch's, any host that can film, errors.
TEST(HostPoolYamordTest, FilmCandidateReturnsTheFramesOfTheSameEvaluation) {
  // A daemon that acts as a machine without a renderer.
  setenv("YAMOR_RENDER_BACKEND", "none", 1);
  Daemon blind(1);
  unsetenv("YAMOR_RENDER_BACKEND");
  ASSERT_GT(blind.port(), 0);
  const Candidate candidate = Gaits(3)[2];
  FilmOptions options;
  options.width = 32;
  options.height = 24;
  options.frame_rate = 10;
  {
    HostPool only_blind({blind.address()}, Quadruped(), DaemonRetry());
    try {
      only_blind.FilmCandidate(candidate, options);
      ADD_FAILURE() << "a daemon without a renderer filmed";
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), StatusCode::kUnavailable) << e.what();
      EXPECT_NE(std::string(e.what()).find("no host could film"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(blind.address().ToString()), std::string::npos);
    }
    EXPECT_EQ(StatusOf(only_blind, 0).failures, 0) << "a failed film marks no host down";
  }

  Daemon a(1);
  ASSERT_GT(a.port(), 0);
  HostPool pool({blind.address(), a.address()}, Quadruped(), DaemonRetry());
  const std::vector<Evaluation> batch = EvaluateGuarded(pool, {candidate});
  FilmResult film;
  try {
    film = pool.FilmCandidate(candidate, options);
  } catch (const Error& e) {
    if (e.code() == StatusCode::kUnavailable) GTEST_SKIP() << "no renderer: " << e.what();
    throw;
  }
  EXPECT_EQ(film.evaluation.host, a.address().ToString()) << "the host that can film";
  EXPECT_EQ(film.evaluation.velocity, batch[0].velocity) << "the same evaluation";
  ASSERT_EQ(film.frames.size(), 20u) << "2 s at 10 frames per second";
  for (std::size_t i = 0; i < film.frames.size(); ++i) {
    EXPECT_NEAR(film.frames[i].time, 0.1 * static_cast<double>(i), 1e-9);
    EXPECT_EQ(film.frames[i].png.substr(1, 3), "PNG");
  }
  EXPECT_TRUE(film.mp4.empty()) << "PNG frames unless an MP4 is asked for";

  // The host makes the MP4 and sends only the frames asked for as PNG.
  if (std::system("ffmpeg -version > /dev/null 2>&1") == 0) {
    FilmOptions mp4 = options;
    mp4.mp4 = true;
    mp4.png_frames = {0, 19};
    const FilmResult made = pool.FilmCandidate(candidate, mp4);
    EXPECT_EQ(made.evaluation.velocity, batch[0].velocity);
    EXPECT_TRUE(made.video_note.empty()) << made.video_note;
    EXPECT_EQ(made.mp4_frames, 20);
    ASSERT_GT(made.mp4.size(), 8u);
    EXPECT_EQ(made.mp4.substr(4, 4), "ftyp");
    ASSERT_EQ(made.frames.size(), 2u);
    EXPECT_EQ(made.frames[0].index, 0u);
    EXPECT_EQ(made.frames[1].index, 19u);
    EXPECT_EQ(made.frames[1].png, film.frames[19].png) << "the same picture as the PNG film's";
  }

  // A caller error names the value and the host; no other host is tried.
  FilmOptions bad = options;
  bad.width = 0;
  try {
    pool.FilmCandidate(candidate, bad);
    ADD_FAILURE() << "width 0 filmed";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kOutOfRange) << e.what();
    EXPECT_NE(std::string(e.what()).find("frame width 0"), std::string::npos) << e.what();
  }
  // Cancelled, even after RequestStop (which ends batches, not films).
  pool.RequestStop();
  FilmOptions slow = options;
  slow.width = 640;
  slow.height = 480;
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(::yamor::testing::CodeOf([&] { pool.FilmCandidate(candidate, slow, [] { return true; }); }),
            StatusCode::kCancelled);
  EXPECT_LT(std::chrono::steady_clock::now() - start, seconds(30));
}

// Issue 13 §2 "model" mode: the robot's condition travels with every request.
TEST(HostPoolYamordTest, TheRobotsConditionReachesEveryEvaluation) {
  Daemon a(1);
  ASSERT_GT(a.port(), 0);
  const std::vector<Candidate> gait = Gaits(1);
  HostPool healthy({a.address()}, Quadruped(), DaemonRetry());
  const double base = EvaluateGuarded(healthy, gait).at(0).velocity;

  EvaluationSettings broken = Quadruped();
  broken.motor_defects = {{2, MotorDefect::kLimp}, {3, MotorDefect::kOk}};
  broken.module_defects = {6};
  broken.ground_friction = 0.3;
  broken.ground_slope = 0.05;
  broken.ground_slope_direction = 1.0;
  broken.upside_down = true;
  HostPool pool({a.address()}, broken, DaemonRetry());
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
  HostPool refused({a.address()}, unknown, DaemonRetry());
  std::string message;
  try {
    refused.EvaluateBatch(gait);
    ADD_FAILURE() << "module 77 accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kNotFound) << e.what();
    EXPECT_NE(std::string(e.what()).find("module 77"), std::string::npos) << e.what();
  }
}

// Issue 17 §3: daemons started and stopped while batches run, joining and
// leaving through the host file; no slot is lost or filled twice, and every
// result is the daemon's own answer for its candidate. Batches go on (as a
// plugin's would) until the last daemon has worked alone, so no step races
// the machine's speed.
TEST(HostPoolYamordTest, HostFileGrowsAndShrinksWhileBatchesRun) {
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
  HostPool pool(ParseHosts("@" + path), settings, DaemonRetry());
  HostListWatcher watcher(path, pool, 0.05);

  // Batches of 4 gaits, each twice: equal results prove no slot got
  // another's reply.
  std::atomic<bool> enough{false};
  std::vector<std::pair<std::vector<Candidate>, std::vector<Evaluation>>> done;
  std::thread producer([&] {
    for (int k = 0; !enough.load() && k < 200; ++k) {
      std::vector<Candidate> batch;
      for (int i = 0; i < 4; ++i) {
        const Candidate c{{{"phase.0.1", 0.1 * (4 * k + i)}, {"amplitude.5", 0.3 + 0.01 * i}}};
        batch.push_back(c);
        batch.push_back(c);
      }
      std::vector<Evaluation> results = EvaluateGuarded(pool, batch, seconds(90));
      done.emplace_back(std::move(batch), std::move(results));
    }
  });
  const auto finish = [&] {
    enough = true;
    producer.join();
  };
  if (!WaitFor([&] { return completed(pool, *a) >= 2; }, seconds(60))) {
    finish();
    FAIL() << "a did no work";
  }
  Daemon b(1);  // started mid-run and listed
  write({a.get(), &b});
  if (!WaitFor([&] { return completed(pool, b) >= 1; }, seconds(60))) {
    finish();
    FAIL() << "b never joined";
  }
  write({&b});  // a is unlisted: it finishes its evaluation, then leaves
  if (!WaitFor([&] { return completed(pool, *a) == -1; }, seconds(60))) {
    finish();
    FAIL() << "a never drained";
  }
  a.reset();  // and is stopped
  Daemon c(1);  // another one joins, then b dies without being unlisted
  write({&b, &c});
  if (!WaitFor([&] { return completed(pool, c) >= 1; }, seconds(60))) {
    finish();
    FAIL() << "c never joined";
  }
  b.Kill();
  const long long on_c = completed(pool, c);
  const bool alone = WaitFor([&] { return completed(pool, c) >= on_c + 4; }, seconds(60));
  finish();
  ASSERT_TRUE(alone) << "c did not go on alone";

  std::map<std::string, int> per_host;
  for (const auto& [batch, results] : done) {
    ASSERT_EQ(results.size(), batch.size());
    for (const Evaluation& e : results) ++per_host[e.host];
    for (std::size_t i = 0; i < batch.size(); i += 2) {
      EXPECT_EQ(results[i].velocity, results[i + 1].velocity) << "slots " << i << ", " << i + 1;
      EXPECT_FALSE(results[i].diverged);
    }
  }
  EXPECT_EQ(per_host.size(), 3u) << "a, b and c each scored some";
  for (std::size_t k = 0; k < done.size(); k += 3) {
    const yamor::v1::EvaluateResponse direct =
        DirectEvaluate(c.address(), settings, done[k].first[0]);
    EXPECT_EQ(done[k].second[0].velocity, direct.velocity()) << "batch " << k << " bit-identical";
  }
  EXPECT_EQ(watcher.Applied(), 3);
}

}  // namespace
}  // namespace yamor::optimizer
