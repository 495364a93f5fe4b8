#pragma once
// The invariant check every fuzz harness uses: aborts with the failed condition and its line, so
// libFuzzer keeps the input that broke it (and a corpus replay in tests/fuzz/ fails).
#include <cstdio>
#include <cstdlib>

#define FUZZ_CHECK(cond)                                                          \
  do {                                                                            \
    if (!(cond)) {                                                                \
      std::fprintf(stderr, "invariant failed: %s (line %d)\n", #cond, __LINE__); \
      std::abort();                                                               \
    }                                                                             \
  } while (0)
