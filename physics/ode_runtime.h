// Process-wide ODE initialisation and per-thread ODE data. ODE must be
// initialised once per process and every thread that calls into ODE needs its
// own collision data; ODE's error and debug handlers are replaced by ones that
// log and throw (ODE would otherwise call exit()/abort() after them).
#pragma once

#include "common/status.h"

namespace yamor::physics {

/// Thrown (as a yamor::Error with code kInternal) by the ODE error/debug
/// handlers; callers that step a world catch it and mark the world diverged.
class OdeFailure : public Error {
 public:
  /// Wraps an ODE error/debug message.
  explicit OdeFailure(const std::string& message) : Error(StatusCode::kInternal, message) {}
};

/// Initialises ODE for the process (once) and for the calling thread (once per
/// thread, released at thread exit). Cheap after the first call; call it before
/// any ODE call. Thread-safety: safe from any thread.
void EnsureOdeForThisThread();

}  // namespace yamor::physics
