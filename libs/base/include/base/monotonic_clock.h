#pragma once
// The clock Doppel compares times on: CLOCK_MONOTONIC in nanoseconds (bus deadlines, frame publish
// stamps, latencies measured by tools and tests). One definition so that stamps taken in different
// folders and processes are on the same clock.

#include <time.h>

#include <cstdint>

namespace doppel {

// Now on `clock` (a POSIX clock id such as CLOCK_REALTIME), in ns. rt-safe (vDSO, no allocation).
inline int64_t clock_now_ns(clockid_t clock) noexcept {
  timespec ts{};
  ::clock_gettime(clock, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

// Now on CLOCK_MONOTONIC, in ns. rt-safe.
inline int64_t monotonic_now_ns() noexcept { return clock_now_ns(CLOCK_MONOTONIC); }

}  // namespace doppel
