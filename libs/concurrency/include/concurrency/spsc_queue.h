#pragma once
// A bounded single-producer / single-consumer ring for handing plain records between two threads
// without locks or allocation. It is not a multi-producer queue: exactly one thread may push and
// exactly one (other) thread may pop. When full, try_push drops the value and counts it, so the
// producer (the bus or physics thread) never waits for a slow consumer.

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <type_traits>

namespace doppel::concurrency {

// Size of the block two cores fight over; members written by different threads are kept this far
// apart. A constant rather than std::hardware_destructive_interference_size, whose value g++ warns
// may change between compiler versions.
inline constexpr std::size_t kCacheLineBytes = 64;

template <class T, std::size_t N>
class SpscQueue {
  static_assert(N >= 2 && (N & (N - 1)) == 0, "capacity must be a power of two");
  static_assert(std::is_nothrow_default_constructible_v<T>, "slots are constructed up front");
  static_assert(std::is_nothrow_copy_assignable_v<T>, "push/pop copy without throwing");

 public:
  static constexpr std::size_t capacity() noexcept { return N; }

  // Producer thread only. Copies `value` in; false (and dropped() grows) when the queue is full.
  // rt-safe, wait-free.
  bool try_push(const T& value) noexcept {
    const uint64_t head = head_.load(std::memory_order_relaxed);
    if (head - cached_tail_ == N) {
      cached_tail_ = tail_.load(std::memory_order_acquire);
      if (head - cached_tail_ == N) {
        dropped_.store(dropped_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
        return false;
      }
    }
    slots_[head & (N - 1)] = value;
    head_.store(head + 1, std::memory_order_release);
    return true;
  }

  // Consumer thread only. Copies the oldest value into `out`; false when empty. rt-safe, wait-free.
  bool try_pop(T& out) noexcept {
    const uint64_t tail = tail_.load(std::memory_order_relaxed);
    if (tail == cached_head_) {
      cached_head_ = head_.load(std::memory_order_acquire);
      if (tail == cached_head_) return false;
    }
    out = slots_[tail & (N - 1)];
    tail_.store(tail + 1, std::memory_order_release);
    return true;
  }

  // Consumer thread only. The oldest value, or nullopt when empty. rt-safe.
  std::optional<T> try_pop() noexcept {
    T value{};
    if (!try_pop(value)) return std::nullopt;
    return value;
  }

  // Values queued at some recent instant (exact only when neither side is active). Any thread.
  std::size_t size_approx() const noexcept {
    const uint64_t tail = tail_.load(std::memory_order_acquire);
    const uint64_t head = head_.load(std::memory_order_acquire);
    return static_cast<std::size_t>(head - tail);
  }

  // Values refused by try_push because the queue was full. Any thread.
  uint64_t dropped() const noexcept { return dropped_.load(std::memory_order_relaxed); }

 private:
  alignas(kCacheLineBytes) std::atomic<uint64_t> head_{0};  // next slot to write (producer)
  uint64_t cached_tail_ = 0;                                  // producer's last view of tail_
  std::atomic<uint64_t> dropped_{0};                          // refused pushes (producer writes)
  alignas(kCacheLineBytes) std::atomic<uint64_t> tail_{0};  // next slot to read (consumer)
  uint64_t cached_head_ = 0;                                  // consumer's last view of head_
  alignas(kCacheLineBytes) std::array<T, N> slots_{};       // ring storage
};

}  // namespace doppel::concurrency
