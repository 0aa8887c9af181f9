// Shared by the libFuzzer targets: an assertion that aborts (a libFuzzer
// finding) naming the fuzzer, the condition and the line.
#pragma once

#include <cstdio>
#include <cstdlib>

#define FUZZ_ASSERT(condition)                                                   \
  do {                                                                           \
    if (!(condition)) {                                                          \
      std::fprintf(stderr, "%s: %s failed at line %d\n", __FILE__, #condition,   \
                   __LINE__);                                                    \
      std::abort();                                                              \
    }                                                                            \
  } while (false)
