// What the framework's gRPC clients of yamord share (the host pool and the
// live evaluator): how a channel to one daemon is made, deadlines, and how a
// daemon's status is described and classified.
#pragma once

#include <grpcpp/support/status.h>

#include <chrono>
#include <memory>
#include <string>

#include "optimizer-plugins/framework/evaluator.h"

namespace grpc {
class Channel;
}  // namespace grpc

namespace yamor::optimizer {

/// An insecure channel to the yamord at `target` ("host:port") of its own
/// (not shared with other channels to the address), whose reconnect backoff
/// runs from `reconnect_initial` to `reconnect_max` seconds: the caller's own
/// retry policy decides when a daemon is tried again. Thread-safe.
/// `max_receive_bytes` > 0 raises gRPC's 4 MB limit on a reply (filmed
/// evaluations carry their frames).
std::shared_ptr<grpc::Channel> MakeHostChannel(const std::string& target, double reconnect_initial,
                                               double reconnect_max, int max_receive_bytes = 0);

/// The wall-clock deadline `seconds` from now, for ClientContext::set_deadline.
std::chrono::system_clock::time_point DeadlineAfter(double seconds);

/// True for the codes a daemon gives a caller's mistake (INVALID_ARGUMENT,
/// OUT_OF_RANGE, NOT_FOUND, FAILED_PRECONDITION): retrying elsewhere would
/// not help. Every other failure is the daemon's or its link's.
bool IsCallerError(grpc::StatusCode code);

/// "CODE_NAME: message" of a status.
std::string DescribeStatus(const grpc::Status& status);

/// "{name=value, ...}" of a candidate, for error messages.
std::string FormatCandidate(const Candidate& candidate);

}  // namespace yamor::optimizer
