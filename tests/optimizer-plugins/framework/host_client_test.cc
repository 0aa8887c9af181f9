// The one C++ client of yamord (framework/host_rpc.h) against an in-process
// fake yamor.v1.Host: the rule code by code, a daemon that answers past the
// deadline, one that is not there, cancellation, and the stream helpers.
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "common/status.h"
#include "optimizer-plugins/framework/host_rpc.h"
#include "tests/support/code_of.h"
#include "tests/support/unused_port.h"
#include "yamor/v1/host.grpc.pb.h"

namespace yamor::client {
namespace {

using ::yamor::testing::CodeOf;
using ::yamor::testing::UnusedPort;
using google::protobuf::Empty;
using Stub = v1::Host::Stub;

// GetInfo fails with `code`; Sleep sleeps `sleep_ms` (until cancelled);
// WatchState sends `updates` updates, then ends with `stream_end`, or
// keeps the stream open until cancelled when `stream_open`.
class FakeHost final : public v1::Host::Service {
 public:
  std::atomic<int> code{0};
  std::atomic<int> sleep_ms{0};
  std::atomic<int> updates{3};
  std::atomic<int> stream_end{0};
  std::atomic<bool> stream_open{false};
  std::atomic<int> cancelled{0};  ///< Calls that saw their cancellation.

  grpc::Status GetInfo(grpc::ServerContext*, const Empty*, v1::GetInfoResponse* response) override {
    response->set_backend("fake");
    return grpc::Status(static_cast<grpc::StatusCode>(code.load()), "the fake says no");
  }

  grpc::Status Sleep(grpc::ServerContext* context, const v1::SleepRequest*,
                     v1::SleepResponse* response) override {
    const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(sleep_ms.load());
    while (std::chrono::steady_clock::now() < until) {
      if (context->IsCancelled()) {
        ++cancelled;
        return grpc::Status(grpc::StatusCode::CANCELLED, "sleep cancelled");
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    response->set_time(1.5);
    return grpc::Status::OK;
  }

  grpc::Status WatchState(grpc::ServerContext* context, const v1::WatchStateRequest*,
                          grpc::ServerWriter<v1::StateUpdate>* writer) override {
    for (int i = 0; i < updates.load(); ++i) {
      v1::StateUpdate update;
      update.set_time(i);
      if (!writer->Write(update)) return grpc::Status(grpc::StatusCode::CANCELLED, "reader gone");
    }
    while (stream_open.load() && !context->IsCancelled()) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    if (context->IsCancelled()) ++cancelled;
    return grpc::Status(static_cast<grpc::StatusCode>(stream_end.load()), "the stream ends");
  }
};

// The fake on 127.0.0.1:0.
class FakeServer {
 public:
  FakeServer() {
    grpc::ServerBuilder builder;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port_);
    builder.RegisterService(&service);
    server_ = builder.BuildAndStart();
  }
  ~FakeServer() { server_->Shutdown(std::chrono::system_clock::now()); }
  std::string address() const { return "127.0.0.1:" + std::to_string(port_); }

  FakeHost service;

 private:
  int port_ = 0;
  std::unique_ptr<grpc::Server> server_;
};

bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

TEST(HostClientTest, EveryCodeFollowsTheOneRule) {
  // The rule of host_rpc.h, written out: the caller's codes keep their code,
  // every other one is the daemon's or the link's failure.
  const std::map<grpc::StatusCode, StatusCode> expected = {
      {grpc::StatusCode::CANCELLED, StatusCode::kUnavailable},
      {grpc::StatusCode::UNKNOWN, StatusCode::kUnavailable},
      {grpc::StatusCode::INVALID_ARGUMENT, StatusCode::kInvalidArgument},
      {grpc::StatusCode::DEADLINE_EXCEEDED, StatusCode::kUnavailable},
      {grpc::StatusCode::NOT_FOUND, StatusCode::kNotFound},
      {grpc::StatusCode::ALREADY_EXISTS, StatusCode::kAlreadyExists},
      {grpc::StatusCode::PERMISSION_DENIED, StatusCode::kPermissionDenied},
      {grpc::StatusCode::RESOURCE_EXHAUSTED, StatusCode::kUnavailable},
      {grpc::StatusCode::FAILED_PRECONDITION, StatusCode::kFailedPrecondition},
      {grpc::StatusCode::ABORTED, StatusCode::kUnavailable},
      {grpc::StatusCode::OUT_OF_RANGE, StatusCode::kOutOfRange},
      {grpc::StatusCode::UNIMPLEMENTED, StatusCode::kUnimplemented},
      {grpc::StatusCode::INTERNAL, StatusCode::kUnavailable},
      {grpc::StatusCode::UNAVAILABLE, StatusCode::kUnavailable},
      {grpc::StatusCode::DATA_LOSS, StatusCode::kUnavailable},
      {grpc::StatusCode::UNAUTHENTICATED, StatusCode::kUnauthenticated},
  };
  FakeServer server;
  HostClient host(server.address(), 10);
  for (const auto& [code, want] : expected) {
    const std::string name(StatusCodeName(static_cast<StatusCode>(code)));
    server.service.code = static_cast<int>(code);
    std::string message;
    EXPECT_EQ(CodeOf([&] { host.Call(&Stub::GetInfo, Empty(), "GetInfo"); }, &message), want) << name;
    if (code != grpc::StatusCode::UNAVAILABLE) {
      EXPECT_EQ(KeepsCode(code), static_cast<int>(want) == static_cast<int>(code)) << name;
    }
    // The message names the daemon, the RPC and the code it came with.
    EXPECT_TRUE(Contains(message, "yamord " + server.address() + " GetInfo: " + name + ": the fake says no"))
        << message;
    // The raw call keeps the daemon's code for callers that need it.
    v1::GetInfoResponse info;
    EXPECT_EQ(host.TryCall(&Stub::GetInfo, Empty(), &info).error_code(), code) << name;
  }
  server.service.code = 0;
  EXPECT_EQ(host.Call(&Stub::GetInfo, Empty(), "GetInfo").backend(), "fake");
}

TEST(HostClientTest, ToErrorAndIsCallerErrorAgreeOnTheCallerCodes) {
  for (int n = 1; n <= 16; ++n) {
    const auto code = static_cast<grpc::StatusCode>(n);
    const Error e = ToError(grpc::Status(code, "m"), "h:1", "Rpc");
    // What a pool does not retry keeps its code; the rule keeps a few more.
    if (IsCallerError(static_cast<StatusCode>(n))) {
      EXPECT_EQ(static_cast<int>(e.code()), n);
    }
  }
  EXPECT_TRUE(IsCallerError(StatusCode::kInvalidArgument));
  EXPECT_FALSE(IsCallerError(StatusCode::kUnimplemented));
  EXPECT_FALSE(IsCallerError(StatusCode::kUnavailable));
}

TEST(HostClientTest, ADaemonAnsweringPastTheDeadlineIsUnavailable) {
  FakeServer server;
  server.service.sleep_ms = 3000;
  HostClient host(server.address(), 0.2);
  std::string message;
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(CodeOf([&] { host.Call(&Stub::Sleep, v1::SleepRequest(), "Sleep"); }, &message),
            StatusCode::kUnavailable);
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(2)) << "the deadline held";
  EXPECT_TRUE(Contains(message, "DEADLINE_EXCEEDED")) << message;
  EXPECT_TRUE(Contains(message, server.address() + " Sleep")) << message;
  // A call's own deadline overrides the client's.
  server.service.sleep_ms = 300;
  EXPECT_EQ(host.Call(&Stub::Sleep, v1::SleepRequest(), "Sleep", {.deadline = 10}).time(), 1.5);
}

TEST(HostClientTest, NoDaemonIsUnavailableNamingTheAddress) {
  const std::string address = "127.0.0.1:" + std::to_string(UnusedPort());
  HostClient host(address, 5);
  std::string message;
  EXPECT_EQ(CodeOf([&] { host.Call(&Stub::GetInfo, Empty(), "GetInfo"); }, &message),
            StatusCode::kUnavailable);
  EXPECT_TRUE(Contains(message, "yamord " + address + " GetInfo: UNAVAILABLE")) << message;
}

TEST(HostClientTest, CancelEndsTheCallInFlightAndEveryLaterOne) {
  FakeServer server;
  server.service.sleep_ms = 20000;
  HostClient host(server.address(), 30);
  std::thread canceller([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    host.Cancel();
  });
  std::string message;
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(CodeOf([&] { host.Call(&Stub::Sleep, v1::SleepRequest(), "Sleep"); }, &message),
            StatusCode::kCancelled);
  canceller.join();
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(10));
  EXPECT_TRUE(Contains(message, "Sleep")) << message;
  EXPECT_TRUE(host.cancelled());
  server.service.code = 0;
  EXPECT_EQ(CodeOf([&] { host.Call(&Stub::GetInfo, Empty(), "GetInfo"); }), StatusCode::kCancelled);
  v1::GetInfoResponse info;
  EXPECT_EQ(host.TryCall(&Stub::GetInfo, Empty(), &info).error_code(), grpc::StatusCode::CANCELLED);
}

TEST(HostClientTest, APolledCancellationEndsOneCall) {
  FakeServer server;
  server.service.sleep_ms = 20000;
  HostClient host(server.address(), 30);
  const auto start = std::chrono::steady_clock::now();
  auto after = [start](int ms) {
    return [start, ms] { return std::chrono::steady_clock::now() - start > std::chrono::milliseconds(ms); };
  };
  EXPECT_EQ(CodeOf([&] { host.Call(&Stub::Sleep, v1::SleepRequest(), "Sleep", {.cancelled = after(200)}); }),
            StatusCode::kCancelled);
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(10));
  EXPECT_FALSE(host.cancelled()) << "only that call";
  server.service.sleep_ms = 0;
  EXPECT_EQ(host.Call(&Stub::Sleep, v1::SleepRequest(), "Sleep", {.cancelled = [] { return false; }}).time(),
            1.5);
}

TEST(HostClientTest, AStreamIsReadToItsEndOrUntilTheReaderStops) {
  FakeServer server;
  HostClient host(server.address(), 10);
  std::vector<double> times;
  host.Stream(&Stub::WatchState, v1::WatchStateRequest(), "WatchState", [&](const v1::StateUpdate& u) {
    times.push_back(u.time());
    return true;
  });
  EXPECT_EQ(times, (std::vector<double>{0, 1, 2}));

  // The reader stops after two: success, and the daemon sees the cancellation.
  server.service.stream_open = true;
  times.clear();
  const grpc::Status stopped =
      host.TryStream(&Stub::WatchState, v1::WatchStateRequest(), [&](const v1::StateUpdate& u) {
        times.push_back(u.time());
        return times.size() < 2;
      });
  EXPECT_TRUE(stopped.ok()) << stopped.error_message();
  EXPECT_EQ(times.size(), 2u);

  // A stream that fails follows the rule; its raw status keeps the code.
  server.service.stream_open = false;
  server.service.stream_end = static_cast<int>(grpc::StatusCode::FAILED_PRECONDITION);
  std::string message;
  EXPECT_EQ(CodeOf([&] {
              host.Stream(&Stub::WatchState, v1::WatchStateRequest(), "WatchState",
                          [](const v1::StateUpdate&) { return true; });
            }, &message),
            StatusCode::kFailedPrecondition);
  EXPECT_TRUE(Contains(message, "WatchState: FAILED_PRECONDITION")) << message;
  server.service.stream_end = static_cast<int>(grpc::StatusCode::INTERNAL);
  EXPECT_EQ(CodeOf([&] {
              host.Stream(&Stub::WatchState, v1::WatchStateRequest(), "WatchState",
                          [](const v1::StateUpdate&) { return true; });
            }),
            StatusCode::kUnavailable);
  EXPECT_EQ(host.TryStream(&Stub::WatchState, v1::WatchStateRequest(),
                           [](const v1::StateUpdate&) { return true; })
                .error_code(),
            grpc::StatusCode::INTERNAL);
}

TEST(HostClientTest, AStreamEndsAtItsDeadlineOrWhenCancelled) {
  FakeServer server;
  server.service.stream_open = true;
  HostClient host(server.address(), 10);
  int received = 0;
  auto count = [&](const v1::StateUpdate&) { return ++received > 0; };
  std::string message;
  EXPECT_EQ(CodeOf([&] {
              host.Stream(&Stub::WatchState, v1::WatchStateRequest(), "WatchState", count,
                          {.deadline = 0.3});
            }, &message),
            StatusCode::kUnavailable);
  EXPECT_TRUE(Contains(message, "DEADLINE_EXCEEDED")) << message;
  EXPECT_EQ(received, 3);

  // Without a deadline the stream lasts until the client is cancelled.
  std::thread canceller([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    host.Cancel();
  });
  EXPECT_EQ(CodeOf([&] { host.Stream(&Stub::WatchState, v1::WatchStateRequest(), "WatchState", count); }),
            StatusCode::kCancelled);
  canceller.join();
  EXPECT_EQ(received, 6);
}

TEST(HostClientTest, AnExceptionOfTheReaderCancelsTheStream) {
  FakeServer server;
  server.service.stream_open = true;
  HostClient host(server.address(), 10);
  EXPECT_EQ(CodeOf([&] {
              host.TryStream(&Stub::WatchState, v1::WatchStateRequest(),
                             [](const v1::StateUpdate&) -> bool {
                               throw Error(StatusCode::kInvalidArgument, "cannot write the frame");
                             });
            }),
            StatusCode::kInvalidArgument);
  for (int i = 0; i < 200 && server.service.cancelled.load() == 0; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_EQ(server.service.cancelled.load(), 1) << "the daemon saw the stream end";
}

TEST(HostClientTest, ChannelsAndDeadlinesAreChecked) {
  EXPECT_EQ(CodeOf([] { HostClient host("127.0.0.1:1", 0); }), StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf([] { HostClient host(nullptr, "x", 1); }), StatusCode::kInvalidArgument);
  // Clients over one channel share it.
  FakeServer server;
  HostClient first(server.address(), 5, {.max_receive_bytes = 1 << 20});
  HostClient second(first.channel(), server.address(), 5);
  EXPECT_EQ(second.Call(&Stub::GetInfo, Empty(), "GetInfo").backend(), "fake");
  EXPECT_EQ(first.channel(), second.channel());
}

}  // namespace
}  // namespace yamor::client
