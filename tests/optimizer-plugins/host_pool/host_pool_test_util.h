// Helpers for the host pool tests: an in-process fake yamord (scripted
// failures, hangs), its server, candidates, pool options and settings,
// result checks and polling.
#pragma once

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <functional>
#include <future>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "optimizer-plugins/framework/host_pool.h"
#include "yamor/v1/host.grpc.pb.h"

namespace yamor::optimizer::testing {

using Clock = std::chrono::steady_clock;

/// The fake's score of a parameter list: order-sensitive, exact in doubles.
inline double Score(const std::vector<std::pair<std::string, double>>& parameters) {
  double score = 0.0;
  for (std::size_t i = 0; i < parameters.size(); ++i) {
    score += static_cast<double>(i + 1) * parameters[i].second;
  }
  return score;
}

/// Pool options that notice failures and recover within a test's patience:
/// health checks of `health_timeout` s, re-checks from 0.05 s up to
/// `retry_max` s, giving up after 30 s without a healthy host.
inline PoolOptions FastRetry(double health_timeout = 2, double retry_max = 0.2) {
  PoolOptions options;
  options.health_timeout = health_timeout;
  options.retry_initial = 0.05;
  options.retry_max = retry_max;
  options.give_up_after = 30;
  return options;
}

/// Settings of the fake hosts' evaluations: 1 s warm-up, 2 s measured
/// (a fake's distance is 2 x its score), a 20 s deadline.
inline EvaluationSettings FakeSettings() {
  EvaluationSettings settings;
  settings.warmup = 1;
  settings.duration = 2;
  settings.deadline_seconds = 20;
  return settings;
}

/// Every result is the fake's score of its own candidate (FakeSettings).
inline void ExpectScored(const std::vector<Candidate>& batch, const std::vector<Evaluation>& results) {
  ASSERT_EQ(results.size(), batch.size());
  for (std::size_t i = 0; i < batch.size(); ++i) {
    EXPECT_EQ(results[i].velocity, Score(batch[i].parameters)) << "slot " << i;
    EXPECT_EQ(results[i].distance, 2.0 * Score(batch[i].parameters)) << "slot " << i;
    EXPECT_FALSE(results[i].diverged);
    EXPECT_FALSE(results[i].host.empty());
  }
}

/// `count` distinct candidates; `tag` keeps batches of different threads apart.
inline std::vector<Candidate> MakeCandidates(int count, double tag = 0.0) {
  std::vector<Candidate> out;
  for (int i = 0; i < count; ++i) {
    out.push_back(Candidate{{{"amplitude.0", 0.1 * i + tag}, {"phase.0.1", 1.0 + i}}});
  }
  return out;
}

/// Polls `condition` every 5 ms for up to `timeout` (a hang guard only).
inline bool WaitFor(const std::function<bool()>& condition,
                    std::chrono::milliseconds timeout = std::chrono::seconds(20)) {
  const auto deadline = Clock::now() + timeout;
  while (Clock::now() < deadline) {
    if (condition()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return condition();
}

/// pool.EvaluateBatch(batch), failing the test (and stopping the pool)
/// instead of hanging when it does not return within `limit`.
inline std::vector<Evaluation> EvaluateGuarded(
    HostPool& pool, const std::vector<Candidate>& batch,
    std::chrono::seconds limit = std::chrono::seconds(60)) {
  auto result = std::async(std::launch::async, [&] { return pool.EvaluateBatch(batch); });
  if (result.wait_for(limit) != std::future_status::ready) {
    ADD_FAILURE() << "EvaluateBatch did not return within " << limit.count() << " s";
    pool.RequestStop();
  }
  return result.get();
}

/// The status of host `index` in `pool`.
inline HostStatus StatusOf(const HostPool& pool, std::size_t index) {
  return pool.Status().at(index);
}

/// A yamor.v1.Host with GetInfo and a scripted Evaluate: velocity = Score
/// of the parameters after `delay`; call number `fail_call` (1-based) fails
/// UNAVAILABLE, every call fails with `fail_all`, call `hang_call` (or every
/// call with `hang_all`) waits until cancelled (or its deadline passes).
/// Parameters named "foo.*" are refused with INVALID_ARGUMENT.
class FakeHost final : public yamor::v1::Host::Service {
 public:
  std::atomic<int> capacity{2};
  std::atomic<int> fail_call{0};
  std::atomic<bool> fail_all{false};
  std::atomic<int> hang_call{0};
  std::atomic<bool> hang_all{false};
  std::atomic<int> delay_ms{10};

  std::atomic<int> calls{0};      ///< Evaluate calls received.
  std::atomic<int> served{0};     ///< Evaluate calls answered OK.
  std::atomic<int> cancelled{0};  ///< Hanging calls that saw their cancellation.
  std::atomic<int> refused{0};    ///< Calls refused as caller errors.

  grpc::Status GetInfo(grpc::ServerContext*, const google::protobuf::Empty*,
                       yamor::v1::GetInfoResponse* response) override {
    response->set_worker_capacity(static_cast<uint32_t>(capacity.load()));
    response->set_backend("fake");
    return grpc::Status::OK;
  }

  grpc::Status Evaluate(grpc::ServerContext* context, const yamor::v1::EvaluateRequest* request,
                        yamor::v1::EvaluateResponse* response) override {
    const int n = ++calls;
    std::vector<std::pair<std::string, double>> parameters;
    for (const auto& p : request->parameters()) {
      if (p.name().rfind("foo.", 0) == 0) {
        ++refused;
        return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT,
                            "parameter '" + p.name() + "': unknown parameter");
      }
      parameters.emplace_back(p.name(), p.value());
    }
    if (fail_all || n == fail_call) {
      return grpc::Status(grpc::StatusCode::UNAVAILABLE, "injected failure");
    }
    if (hang_all || n == hang_call) {
      const auto limit = Clock::now() + std::chrono::seconds(30);
      while (!context->IsCancelled() && Clock::now() < limit) {
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
      }
      if (context->IsCancelled()) ++cancelled;
      return grpc::Status(grpc::StatusCode::CANCELLED, "hung call cancelled");
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms.load()));
    response->set_velocity(Score(parameters));
    response->set_distance(Score(parameters) * request->duration());
    response->set_wall_seconds(delay_ms.load() / 1000.0);
    ++served;
    return grpc::Status::OK;
  }
};

/// A gRPC server on 127.0.0.1 for one FakeHost, with gRPC's default health
/// service unless `health` is false.
class FakeServer {
 public:
  /// Listens on `port` (0: an ephemeral one).
  explicit FakeServer(FakeHost* service, int port = 0, bool health = true)
      : service_(service), health_(health) {
    Start(port);
  }
  ~FakeServer() { Stop(); }

  /// Stops at once: running calls are cancelled.
  void Stop() {
    if (!server_) return;
    server_->Shutdown(std::chrono::system_clock::now());
    server_->Wait();
    server_.reset();
  }
  /// Listens again on the same port.
  void Restart() {
    Stop();
    Start(port_);
  }
  /// What the health service answers: SERVING or NOT_SERVING.
  void SetServing(bool serving) { server_->GetHealthCheckService()->SetServingStatus(serving); }
  int port() const { return port_; }
  HostAddress address() const { return HostAddress{"127.0.0.1", port_}; }

 private:
  void Start(int port) {
    // A process-wide switch read by BuildAndStart.
    grpc::EnableDefaultHealthCheckService(health_);
    grpc::ServerBuilder builder;
    int bound = 0;
    builder.AddListeningPort("127.0.0.1:" + std::to_string(port), grpc::InsecureServerCredentials(),
                             &bound);
    builder.RegisterService(service_);
    server_ = builder.BuildAndStart();
    if (!server_ || bound == 0) throw std::runtime_error("fake host cannot listen");
    port_ = bound;
    grpc::EnableDefaultHealthCheckService(true);
  }

  FakeHost* service_;
  bool health_ = true;
  std::unique_ptr<grpc::Server> server_;
  int port_ = 0;
};

}  // namespace yamor::optimizer::testing
