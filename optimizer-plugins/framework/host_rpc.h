// The one C++ client of yamord: how a channel to a daemon is made (the one
// place: credentials join ChannelOptions), a deadline on every call, and the
// one rule that turns a failed call into a yamor::Error. Every C++ program
// that talks to yamord (the host pool, the live evaluator, yamor-lifelong,
// yamorctl, yamor-cpg-build, yamor-camapp, yamor-characterize, the
// benchmarks) goes through here; the library (yamor::host_client) needs only proto, gRPC and common.
//
// THE RULE: what a daemon's failure means to a caller.
//   Codes about the request or the caller keep their code:
//     INVALID_ARGUMENT, OUT_OF_RANGE, NOT_FOUND, FAILED_PRECONDITION,
//     ALREADY_EXISTS (the request is wrong: retrying anywhere won't help),
//     UNIMPLEMENTED (this daemon's backend cannot do it, e.g. a real robot),
//     PERMISSION_DENIED, UNAUTHENTICATED (the caller's credentials).
//   Every other code is a failure of the daemon or of the link to it, and
//   becomes UNAVAILABLE (retryable: reattach, try later or elsewhere):
//     UNAVAILABLE, DEADLINE_EXCEEDED (the daemon did not answer in time),
//     CANCELLED (not by this caller), RESOURCE_EXHAUSTED (the daemon's call
//     cap, or a reply larger than the channel accepts), ABORTED, INTERNAL,
//     UNKNOWN, DATA_LOSS.
//   A call this caller cancelled (HostClient::Cancel, CallOptions::cancelled)
//   ends with CANCELLED.
//   The message is "yamord ADDRESS RPC: ORIGINAL_CODE: daemon's message".
// A pool that can retry on another daemon (HostPool) retries everything but
// IsCallerError's codes; that is its retry policy, not a second mapping. Its
// many concurrent Evaluate calls and health checks use gRPC's callback API
// on channels made here; what it throws comes from ToError.
// yamorctl shows the daemon's own code as its exit status: it takes the raw
// status (TryCall, TryStream) on purpose.
//
// Why the reverse direction is not here: host/service.h's ToGrpcStatus turns
// a handler's exception into a status on the server side (anything not a
// yamor::Error becomes INTERNAL); it lives in the daemon library, which a
// client must not link, and this file must not sit in host/ (tools and the
// optimizer would link the daemon). The code numbers both rely on are
// checked once, beside ToError (host_rpc.cc).
#pragma once

#include <grpcpp/grpcpp.h>

#include <chrono>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <string_view>
#include <thread>
#include <type_traits>

#include "common/status.h"
#include "yamor/v1/host.grpc.pb.h"

namespace yamor::client {

/// How a channel to a daemon is made. Zero values keep gRPC's defaults.
struct ChannelOptions {
  /// First reconnect backoff [s]; 0: gRPC's (1 s). A caller with its own
  /// retry policy keeps it short, so a restarted daemon is found at once.
  double reconnect_initial = 0;
  /// Cap of the reconnect backoff [s]; 0: gRPC's (120 s).
  double reconnect_max = 0;
  /// A connection of its own, not shared with other channels to the address.
  bool own_connection = false;
  /// > 0 raises gRPC's 4 MB limit on a reply (frames, filmed evaluations).
  int max_receive_bytes = 0;
};

/// A channel to the yamord at `target` ("host:port"); the only place a
/// channel to a daemon is created. Thread-safe.
std::shared_ptr<grpc::Channel> MakeChannel(const std::string& target,
                                           const ChannelOptions& options = {});

/// The wall-clock deadline `seconds` from now, for ClientContext::set_deadline.
std::chrono::system_clock::time_point DeadlineAfter(double seconds);

/// True for the codes the rule keeps (see the file comment).
bool KeepsCode(grpc::StatusCode code);

/// The rule: the yamor::Error of the failed `status` of `rpc` on the
/// daemon `daemon` ("host:port"). `rpc` is the RPC's name, optionally with
/// what it was for ("LoadConfig quadruped.xml").
Error ToError(const grpc::Status& status, std::string_view daemon, std::string_view rpc);

/// True for the codes of a request that is wrong wherever it runs
/// (INVALID_ARGUMENT, OUT_OF_RANGE, NOT_FOUND, FAILED_PRECONDITION): a pool
/// does not retry them on another daemon.
bool IsCallerError(StatusCode code);

/// "CODE_NAME: message" of a status.
std::string DescribeStatus(const grpc::Status& status);

/// How one call runs.
struct CallOptions {
  /// Deadline [s]; <= 0: the client's. For a stream, <= 0 means none (a
  /// stream that lasts as long as the robot is ended by Cancel).
  double deadline = 0;
  /// Polled every 0.1 s while the call runs: true cancels it (kCancelled).
  std::function<bool()> cancelled;
};

/// A client of one yamord (yamor.v1.Host) over one channel.
///
/// Thread-safety: every method may be called from any thread; calls run
/// concurrently. Cancel ends the calls in flight and every later one.
class HostClient {
 public:
  /// A unary RPC of the Host stub, e.g. &v1::Host::Stub::GetInfo.
  template <typename Request, typename Response>
  using Unary = grpc::Status (v1::Host::Stub::*)(grpc::ClientContext*, const Request&, Response*);
  /// What a stream helper calls with each message: false ends the stream.
  template <typename Message>
  using OnMessage = std::function<bool(const std::type_identity_t<Message>&)>;
  /// A server-streaming RPC of the Host stub, e.g. &v1::Host::Stub::WatchState.
  template <typename Request, typename Message>
  using ServerStream = std::unique_ptr<grpc::ClientReader<Message>> (v1::Host::Stub::*)(
      grpc::ClientContext*, const Request&);

  /// A client of the yamord at `target` ("host:port") whose calls have
  /// `deadline` seconds unless told otherwise.
  HostClient(std::string target, double deadline, const ChannelOptions& options = {});
  /// A client over an existing channel (shared with other clients); `name`
  /// names the daemon in errors.
  HostClient(std::shared_ptr<grpc::Channel> channel, std::string name, double deadline);
  HostClient(const HostClient&) = delete;
  HostClient& operator=(const HostClient&) = delete;

  /// The daemon's address (as in errors).
  const std::string& name() const { return name_; }
  /// The channel (for other services on the same daemon, e.g. Lifelong).
  const std::shared_ptr<grpc::Channel>& channel() const { return channel_; }
  /// Deadline of a call without its own [s].
  double deadline() const { return deadline_; }

  /// Calls `method` and returns its response; throws ToError(...) naming
  /// `rpc` when it fails, kCancelled when this caller cancelled it.
  template <typename Request, typename Response>
  Response Call(Unary<Request, Response> method, const Request& request, std::string_view rpc,
                const CallOptions& options = {});

  /// Calls `method` and returns its status as the daemon gave it, for a
  /// caller that needs the raw code (yamorctl's exit status). A cancelled
  /// client gives CANCELLED without calling.
  template <typename Request, typename Response>
  grpc::Status TryCall(Unary<Request, Response> method, const Request& request, Response* response,
                       const CallOptions& options = {});

  /// Reads the server stream of `method` to its end, `on_message` for each
  /// message; `on_message` returning false ends the stream early (the call
  /// is cancelled; that is success). Returns the stream's final status; an
  /// exception from `on_message` cancels the call and propagates.
  template <typename Request, typename Message>
  grpc::Status TryStream(ServerStream<Request, Message> method, const Request& request,
                         const OnMessage<Message>& on_message,
                         const CallOptions& options = {});

  /// TryStream that throws ToError(...) naming `rpc` when the stream fails,
  /// kCancelled when this caller cancelled it.
  template <typename Request, typename Message>
  void Stream(ServerStream<Request, Message> method, const Request& request, std::string_view rpc,
              const OnMessage<Message>& on_message, const CallOptions& options = {});

  /// Cancels every call in flight; every later call ends with kCancelled.
  void Cancel();
  /// True once Cancel was called.
  bool cancelled() const;

 private:
  // One call in flight: its deadline, registration for Cancel, and the
  // poller of CallOptions::cancelled. Lives on the calling thread's stack.
  class Active {
   public:
    Active(HostClient& client, const CallOptions& options, bool stream);
    ~Active();
    Active(const Active&) = delete;
    Active& operator=(const Active&) = delete;
    grpc::ClientContext& context() { return context_; }
    /// True when this caller cancelled the call (or the client was cancelled).
    bool cancelled_here() const;

   private:
    HostClient& client_;
    grpc::ClientContext context_;
    mutable std::mutex mu_;
    std::condition_variable done_cv_;
    bool done_ = false;            // guarded by mu_
    bool cancelled_here_ = false;  // guarded by mu_
    std::thread poller_;
  };

  template <typename Request, typename Response>
  grpc::Status Invoke(Active& active, Unary<Request, Response> method, const Request& request,
                      Response* response);
  template <typename Request, typename Message>
  grpc::Status ReadStream(Active& active, ServerStream<Request, Message> method,
                          const Request& request,
                          const OnMessage<Message>& on_message);
  // What a call cancelled before it started returns.
  static grpc::Status CancelledStatus();
  // Throws kCancelled when this caller cancelled the call, else ToError.
  [[noreturn]] void Throw(const grpc::Status& status, std::string_view rpc, bool cancelled_here) const;

  std::string name_;
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::Host::Stub> stub_;
  double deadline_;
  mutable std::mutex mu_;
  std::set<Active*> active_;  // guarded by mu_
  bool cancelled_ = false;    // guarded by mu_
};

template <typename Request, typename Response>
grpc::Status HostClient::Invoke(Active& active, Unary<Request, Response> method,
                                const Request& request, Response* response) {
  if (active.cancelled_here()) return CancelledStatus();
  return ((*stub_).*method)(&active.context(), request, response);
}

template <typename Request, typename Message>
grpc::Status HostClient::ReadStream(Active& active, ServerStream<Request, Message> method,
                                    const Request& request,
                                    const OnMessage<Message>& on_message) {
  if (active.cancelled_here()) return CancelledStatus();
  std::unique_ptr<grpc::ClientReader<Message>> reader = ((*stub_).*method)(&active.context(), request);
  Message message;
  bool stopped = false;
  try {
    while (!stopped && reader->Read(&message)) stopped = !on_message(message);
  } catch (...) {
    active.context().TryCancel();
    reader->Finish();
    throw;
  }
  if (stopped) active.context().TryCancel();
  const grpc::Status status = reader->Finish();
  return stopped ? grpc::Status::OK : status;
}

template <typename Request, typename Response>
grpc::Status HostClient::TryCall(Unary<Request, Response> method, const Request& request,
                                 Response* response, const CallOptions& options) {
  Active active(*this, options, false);
  return Invoke(active, method, request, response);
}

template <typename Request, typename Response>
Response HostClient::Call(Unary<Request, Response> method, const Request& request,
                          std::string_view rpc, const CallOptions& options) {
  Response response;
  Active active(*this, options, false);
  const grpc::Status status = Invoke(active, method, request, &response);
  if (!status.ok()) Throw(status, rpc, active.cancelled_here());
  return response;
}

template <typename Request, typename Message>
grpc::Status HostClient::TryStream(ServerStream<Request, Message> method, const Request& request,
                                   const OnMessage<Message>& on_message,
                                   const CallOptions& options) {
  Active active(*this, options, true);
  return ReadStream(active, method, request, on_message);
}

template <typename Request, typename Message>
void HostClient::Stream(ServerStream<Request, Message> method, const Request& request,
                        std::string_view rpc, const OnMessage<Message>& on_message,
                        const CallOptions& options) {
  Active active(*this, options, true);
  const grpc::Status status = ReadStream(active, method, request, on_message);
  if (!status.ok()) Throw(status, rpc, active.cancelled_here());
}

}  // namespace yamor::client
