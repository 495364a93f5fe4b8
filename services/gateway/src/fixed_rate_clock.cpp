#include "gateway/fixed_rate_clock.h"

#include <cerrno>

#include "base/monotonic_clock.h"

namespace doppel::gateway {
namespace {

constexpr int64_t kNsPerSecond = 1'000'000'000;

int64_t to_ns(const timespec& t) { return static_cast<int64_t>(t.tv_sec) * kNsPerSecond + t.tv_nsec; }

timespec from_ns(int64_t ns) {
  return timespec{static_cast<time_t>(ns / kNsPerSecond), static_cast<long>(ns % kNsPerSecond)};
}

}  // namespace

FixedRateClock::FixedRateClock(int64_t period_ns) noexcept
    : period_ns_(period_ns), deadline_(from_ns(monotonic_now_ns())) {}

void FixedRateClock::wait_next() noexcept {
  int64_t next = to_ns(deadline_) + period_ns_;
  int64_t now = monotonic_now_ns();
  if (now > next + period_ns_) {
    missed_ticks_ += static_cast<uint64_t>((now - next) / period_ns_);
    next = now;
  }
  deadline_ = from_ns(next);
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &deadline_, nullptr) == EINTR) {
  }
  ++ticks_;
}

}  // namespace doppel::gateway
