// A unary yamor.v1.Host call with a deadline, and ASSERT_OK for its status:
// the end-to-end tests that drive a real yamord share them.
//
// Thread safety: Call may be used from any thread (a stub is thread-safe).
#pragma once

#include <gtest/gtest.h>
#include <grpcpp/grpcpp.h>

#include <chrono>

#include "yamor/v1/host.grpc.pb.h"

namespace yamor::testing {

/// Calls `method` on `stub` with `request` and a deadline `deadline_s`
/// seconds away; the reply goes to `response` when given.
template <typename Request, typename Response>
grpc::Status Call(yamor::v1::Host::Stub& stub,
                  grpc::Status (yamor::v1::Host::Stub::*method)(grpc::ClientContext*,
                                                                const Request&, Response*),
                  const Request& request, Response* response = nullptr, int deadline_s = 120) {
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(deadline_s));
  Response scratch;
  return (stub.*method)(&context, request, response ? response : &scratch);
}

}  // namespace yamor::testing

/// Fails the test (and returns) unless `expr` gives an OK grpc::Status.
#define ASSERT_OK(expr)                                                        \
  do {                                                                         \
    const grpc::Status status_ = (expr);                                       \
    ASSERT_TRUE(status_.ok()) << #expr << ": " << status_.error_code() << " " \
                              << status_.error_message();                      \
  } while (false)
