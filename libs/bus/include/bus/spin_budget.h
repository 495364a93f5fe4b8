#pragma once
// How many bus threads may busy-wait for a due delivery at the same time. Spinning buys
// microsecond accuracy only while a core is free for it: four bus threads spinning on two cores
// preempt each other and the clients they serve, and every delivery ends up later than if they had
// slept. A thread that gets no slot sleeps until the due time instead (timer slack 1 ns).

#include <atomic>

namespace doppel::bus {

class SpinBudget {
 public:
  // `slots` threads may spin at once (0 = nobody spins). Setup only.
  explicit SpinBudget(int slots) noexcept : free_(slots > 0 ? slots : 0), slots_(slots > 0 ? slots : 0) {}

  SpinBudget(const SpinBudget&) = delete;
  SpinBudget& operator=(const SpinBudget&) = delete;

  // Takes a slot if one is free; pair a true result with release(). Lock-free, rt-safe.
  bool try_acquire() noexcept;
  // Returns a slot taken by try_acquire(). rt-safe.
  void release() noexcept { free_.fetch_add(1, std::memory_order_release); }

  // Whether a slot is free right now (may change at once): decides how early to wake. rt-safe.
  bool has_free_slot() const noexcept { return free_.load(std::memory_order_relaxed) > 0; }
  int slots() const noexcept { return slots_; }

  // The budget every BusServer of this process shares unless told otherwise: one slot per online
  // CPU beyond the first, which stays for the clients and the kernel's pty work.
  static SpinBudget& process() noexcept;

 private:
  std::atomic<int> free_;
  int slots_;
};

}  // namespace doppel::bus
