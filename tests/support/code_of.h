// CodeOf: the canonical code of the yamor::Error a call throws, for tests
// that check which error a caller gets (and, optionally, its message).
//
// Thread safety: a pure function of its argument.
#pragma once

#include <string>
#include <utility>

#include "common/status.h"

namespace yamor::testing {

/// Runs `call`; returns the code of the yamor::Error it throws (kOk when it
/// returns) and stores the error's text in `*message` when given.
template <typename F>
StatusCode CodeOf(F&& call, std::string* message = nullptr) {
  try {
    std::forward<F>(call)();
  } catch (const Error& e) {
    if (message != nullptr) *message = e.what();
    return e.code();
  }
  return StatusCode::kOk;
}

}  // namespace yamor::testing
