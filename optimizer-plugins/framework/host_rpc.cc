#include "optimizer-plugins/framework/host_rpc.h"

#include <spdlog/fmt/fmt.h>

#include <algorithm>
#include <utility>

namespace yamor::client {
namespace {

// yamor::StatusCode is numbered as grpc::StatusCode (common/status.h): the
// service layer's ToGrpcStatus and ToError below cast one into the other.
constexpr std::pair<StatusCode, grpc::StatusCode> kSameCodes[] = {
    {StatusCode::kOk, grpc::StatusCode::OK},
    {StatusCode::kCancelled, grpc::StatusCode::CANCELLED},
    {StatusCode::kUnknown, grpc::StatusCode::UNKNOWN},
    {StatusCode::kInvalidArgument, grpc::StatusCode::INVALID_ARGUMENT},
    {StatusCode::kDeadlineExceeded, grpc::StatusCode::DEADLINE_EXCEEDED},
    {StatusCode::kNotFound, grpc::StatusCode::NOT_FOUND},
    {StatusCode::kAlreadyExists, grpc::StatusCode::ALREADY_EXISTS},
    {StatusCode::kPermissionDenied, grpc::StatusCode::PERMISSION_DENIED},
    {StatusCode::kResourceExhausted, grpc::StatusCode::RESOURCE_EXHAUSTED},
    {StatusCode::kFailedPrecondition, grpc::StatusCode::FAILED_PRECONDITION},
    {StatusCode::kAborted, grpc::StatusCode::ABORTED},
    {StatusCode::kOutOfRange, grpc::StatusCode::OUT_OF_RANGE},
    {StatusCode::kUnimplemented, grpc::StatusCode::UNIMPLEMENTED},
    {StatusCode::kInternal, grpc::StatusCode::INTERNAL},
    {StatusCode::kUnavailable, grpc::StatusCode::UNAVAILABLE},
    {StatusCode::kDataLoss, grpc::StatusCode::DATA_LOSS},
    {StatusCode::kUnauthenticated, grpc::StatusCode::UNAUTHENTICATED},
};

constexpr bool CodesMatch() {
  for (const auto& [ours, theirs] : kSameCodes) {
    if (static_cast<int>(ours) != static_cast<int>(theirs)) return false;
  }
  return std::size(kSameCodes) == static_cast<std::size_t>(StatusCode::kUnauthenticated) + 1;
}
static_assert(CodesMatch(), "yamor::StatusCode must number its codes as grpc::StatusCode");

StatusCode Ours(grpc::StatusCode code) { return static_cast<StatusCode>(code); }

int Milliseconds(double seconds) {
  return static_cast<int>(std::clamp(seconds * 1000.0, 1.0, 1e9));
}

// How often CallOptions::cancelled is asked.
constexpr auto kCancelPoll = std::chrono::milliseconds(100);

}  // namespace

std::shared_ptr<grpc::Channel> MakeChannel(const std::string& target, const ChannelOptions& options) {
  grpc::ChannelArguments args;
  if (options.reconnect_initial > 0) {
    args.SetInt(GRPC_ARG_INITIAL_RECONNECT_BACKOFF_MS, Milliseconds(options.reconnect_initial));
  }
  if (options.reconnect_max > 0) {
    args.SetInt(GRPC_ARG_MAX_RECONNECT_BACKOFF_MS, Milliseconds(options.reconnect_max));
  }
  if (options.own_connection) args.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
  if (options.max_receive_bytes > 0) args.SetMaxReceiveMessageSize(options.max_receive_bytes);
  return grpc::CreateCustomChannel(target, grpc::InsecureChannelCredentials(), args);
}

std::chrono::system_clock::time_point DeadlineAfter(double seconds) {
  return std::chrono::system_clock::now() +
         std::chrono::duration_cast<std::chrono::system_clock::duration>(
             std::chrono::duration<double>(seconds));
}

bool KeepsCode(grpc::StatusCode code) {
  switch (code) {
    case grpc::StatusCode::INVALID_ARGUMENT:
    case grpc::StatusCode::OUT_OF_RANGE:
    case grpc::StatusCode::NOT_FOUND:
    case grpc::StatusCode::FAILED_PRECONDITION:
    case grpc::StatusCode::ALREADY_EXISTS:
    case grpc::StatusCode::UNIMPLEMENTED:
    case grpc::StatusCode::PERMISSION_DENIED:
    case grpc::StatusCode::UNAUTHENTICATED:
      return true;
    default:
      return false;
  }
}

Error ToError(const grpc::Status& status, std::string_view daemon, std::string_view rpc) {
  const StatusCode code = KeepsCode(status.error_code()) ? Ours(status.error_code())
                                                         : StatusCode::kUnavailable;
  return Error(code, fmt::format("yamord {} {}: {}", daemon, rpc, DescribeStatus(status)));
}

bool IsCallerError(StatusCode code) {
  return code == StatusCode::kInvalidArgument || code == StatusCode::kOutOfRange ||
         code == StatusCode::kNotFound || code == StatusCode::kFailedPrecondition;
}

std::string DescribeStatus(const grpc::Status& status) {
  return std::string(StatusCodeName(Ours(status.error_code()))) + ": " + status.error_message();
}

// ---- HostClient ---------------------------------------------------------------------

HostClient::HostClient(std::string target, double deadline, const ChannelOptions& options)
    : HostClient(MakeChannel(target, options), target, deadline) {}

HostClient::HostClient(std::shared_ptr<grpc::Channel> channel, std::string name, double deadline)
    : name_(std::move(name)), channel_(std::move(channel)), deadline_(deadline) {
  if (!channel_) throw Error(StatusCode::kInvalidArgument, "client of " + name_ + " without a channel");
  if (!(deadline_ > 0)) {
    throw Error(StatusCode::kInvalidArgument,
                fmt::format("client of {}: deadline must be > 0 s, got {}", name_, deadline_));
  }
  stub_ = v1::Host::NewStub(channel_);
}

void HostClient::Cancel() {
  std::lock_guard lock(mu_);
  cancelled_ = true;
  for (Active* call : active_) call->context().TryCancel();
}

bool HostClient::cancelled() const {
  std::lock_guard lock(mu_);
  return cancelled_;
}

grpc::Status HostClient::CancelledStatus() {
  return grpc::Status(grpc::StatusCode::CANCELLED, "cancelled by the caller");
}

void HostClient::Throw(const grpc::Status& status, std::string_view rpc, bool cancelled_here) const {
  if (cancelled_here) {
    throw Error(StatusCode::kCancelled, fmt::format("yamord {} {}: cancelled", name_, rpc));
  }
  throw ToError(status, name_, rpc);
}

HostClient::Active::Active(HostClient& client, const CallOptions& options, bool stream)
    : client_(client) {
  if (options.deadline > 0) {
    context_.set_deadline(DeadlineAfter(options.deadline));
  } else if (!stream) {
    context_.set_deadline(DeadlineAfter(client_.deadline_));
  }
  {
    std::lock_guard lock(client_.mu_);
    if (client_.cancelled_) {
      cancelled_here_ = true;
      return;
    }
    client_.active_.insert(this);
  }
  if (options.cancelled) {
    poller_ = std::thread([this, cancelled = options.cancelled] {
      std::unique_lock lock(mu_);
      while (!done_) {
        if (done_cv_.wait_for(lock, kCancelPoll, [this] { return done_; })) return;
        lock.unlock();
        const bool cancel = cancelled();
        lock.lock();
        if (cancel && !done_) {
          cancelled_here_ = true;
          context_.TryCancel();
          return;
        }
      }
    });
  }
}

HostClient::Active::~Active() {
  {
    std::lock_guard lock(mu_);
    done_ = true;
  }
  done_cv_.notify_all();
  if (poller_.joinable()) poller_.join();
  std::lock_guard lock(client_.mu_);
  client_.active_.erase(this);
}

bool HostClient::Active::cancelled_here() const {
  {
    std::lock_guard lock(mu_);
    if (cancelled_here_) return true;
  }
  std::lock_guard lock(client_.mu_);
  return client_.cancelled_;
}

}  // namespace yamor::client
