#include "optimizer-plugins/framework/host_rpc.h"

#include <grpcpp/grpcpp.h>
#include <spdlog/fmt/fmt.h>

#include <algorithm>

#include "common/status.h"

namespace yamor::optimizer {
namespace {

int Milliseconds(double seconds) {
  return static_cast<int>(std::clamp(seconds * 1000.0, 1.0, 1e9));
}

}  // namespace

std::shared_ptr<grpc::Channel> MakeHostChannel(const std::string& target, double reconnect_initial,
                                               double reconnect_max, int max_receive_bytes) {
  grpc::ChannelArguments args;
  // gRPC's default reconnect backoff (up to 120 s) would delay the call that
  // finds a restarted daemon back; channels to one address stay independent.
  args.SetInt(GRPC_ARG_INITIAL_RECONNECT_BACKOFF_MS, Milliseconds(reconnect_initial));
  args.SetInt(GRPC_ARG_MAX_RECONNECT_BACKOFF_MS, Milliseconds(reconnect_max));
  args.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
  if (max_receive_bytes > 0) args.SetMaxReceiveMessageSize(max_receive_bytes);
  return grpc::CreateCustomChannel(target, grpc::InsecureChannelCredentials(), args);
}

std::chrono::system_clock::time_point DeadlineAfter(double seconds) {
  return std::chrono::system_clock::now() +
         std::chrono::duration_cast<std::chrono::system_clock::duration>(
             std::chrono::duration<double>(seconds));
}

bool IsCallerError(grpc::StatusCode code) {
  return code == grpc::StatusCode::INVALID_ARGUMENT || code == grpc::StatusCode::OUT_OF_RANGE ||
         code == grpc::StatusCode::NOT_FOUND || code == grpc::StatusCode::FAILED_PRECONDITION;
}

std::string DescribeStatus(const grpc::Status& status) {
  return std::string(StatusCodeName(static_cast<StatusCode>(status.error_code()))) + ": " +
         status.error_message();
}

std::string FormatCandidate(const Candidate& candidate) {
  std::string out = "{";
  for (const auto& [name, value] : candidate.parameters) {
    if (out.size() > 1) out += ", ";
    out += fmt::format("{}={}", name, value);
  }
  return out + "}";
}

}  // namespace yamor::optimizer
