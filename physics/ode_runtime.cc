#include "physics/ode_runtime.h"

#include <cstdarg>
#include <cstdio>
#include <mutex>

#include <ode/ode.h>

#include "common/log.h"

namespace yamor::physics {
namespace {

std::string Format(const char* message, va_list args) {
  char buffer[1024];
  std::vsnprintf(buffer, sizeof(buffer), message, args);
  return buffer;
}

// dError calls exit(1) and dDebug abort() once the handler returns, so these
// never return: they unwind out of ODE with an exception (libode is C++ built
// with unwind tables).
void OnOdeError(int number, const char* message, va_list args) {
  const std::string text = "ODE error " + std::to_string(number) + ": " + Format(message, args);
  Log().error("{}", text);
  throw OdeFailure(text);
}

void OnOdeDebug(int number, const char* message, va_list args) {
  const std::string text =
      "ODE internal error " + std::to_string(number) + ": " + Format(message, args);
  Log().error("{}", text);
  throw OdeFailure(text);
}

void OnOdeMessage(int number, const char* message, va_list args) {
  // Typically "LCP internal error" notes from the solver: informative only.
  Log().debug("ODE message {}: {}", number, Format(message, args));
}

struct ThreadData {
  ThreadData() {
    if (dAllocateODEDataForThread(dAllocateMaskAll) == 0) {
      throw Error(StatusCode::kResourceExhausted, "ODE could not allocate per-thread data");
    }
  }
  ~ThreadData() { dCleanupODEAllDataForThread(); }
};

}  // namespace

void EnsureOdeForThisThread() {
  static std::once_flag once;
  std::call_once(once, [] {
    if (dInitODE2(0) == 0) {
      throw Error(StatusCode::kInternal, "ODE initialisation failed");
    }
    dSetErrorHandler(&OnOdeError);
    dSetDebugHandler(&OnOdeDebug);
    dSetMessageHandler(&OnOdeMessage);
    Log().debug("ODE initialised: {}", dGetConfiguration());
  });
  thread_local ThreadData thread_data;
}

}  // namespace yamor::physics
