#pragma once
// Paces a loop at a fixed period with CLOCK_MONOTONIC absolute deadlines, so the period does not
// drift with the loop's own run time. After an overrun it resynchronises to "now" instead of
// racing to catch up, and counts the missed ticks (as MuJoCo's simulate does).

#include <cstdint>
#include <ctime>

namespace doppel::gateway {

class FixedRateClock {
 public:
  explicit FixedRateClock(int64_t period_ns) noexcept;

  // Sleeps until the next deadline. rt-safe.
  void wait_next() noexcept;

  int64_t period_ns() const noexcept { return period_ns_; }
  uint64_t ticks() const noexcept { return ticks_; }
  uint64_t missed_ticks() const noexcept { return missed_ticks_; }

 private:
  int64_t period_ns_;
  timespec deadline_{};
  uint64_t ticks_ = 0;
  uint64_t missed_ticks_ = 0;
};

}  // namespace doppel::gateway
