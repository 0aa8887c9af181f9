// Canonical error codes and the project-wide exception type.
#pragma once

#include <stdexcept>
#include <string>
#include <string_view>

namespace yamor {

/// Canonical status codes: the same numbering as grpc::StatusCode, so the
/// service layer maps them without a table.
enum class StatusCode : int {
  kOk = 0,
  kCancelled = 1,
  kUnknown = 2,
  kInvalidArgument = 3,
  kDeadlineExceeded = 4,
  kNotFound = 5,
  kAlreadyExists = 6,
  kPermissionDenied = 7,
  kResourceExhausted = 8,
  kFailedPrecondition = 9,
  kAborted = 10,
  kOutOfRange = 11,
  kUnimplemented = 12,
  kInternal = 13,
  kUnavailable = 14,
  kDataLoss = 15,
  kUnauthenticated = 16,
};

/// Upper-case canonical name of a code, e.g. "INVALID_ARGUMENT".
std::string_view StatusCodeName(StatusCode code);

/// A caller error: a canonical code plus a message that names the bad value.
/// Thread-safety: immutable after construction; safe to share.
class Error : public std::runtime_error {
 public:
  /// Builds an error with `code` and a human-readable `message`.
  Error(StatusCode code, const std::string& message)
      : std::runtime_error(message), code_(code) {}

  /// The canonical code of this error.
  StatusCode code() const noexcept { return code_; }

 private:
  StatusCode code_;
};

/// Aborts the process with `message` when `condition` is false: for internal
/// invariants only, never for caller input.
#define YAMOR_CHECK(condition, message)                                   \
  do {                                                                    \
    if (!(condition)) ::yamor::internal::CheckFailed(#condition, message, \
                                                     __FILE__, __LINE__); \
  } while (false)

namespace internal {
/// Logs a failed invariant and aborts; called by YAMOR_CHECK.
[[noreturn]] void CheckFailed(const char* condition, std::string_view message,
                              const char* file, int line);
}  // namespace internal

}  // namespace yamor
