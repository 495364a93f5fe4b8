#pragma once
// The latest value of something, handed from one writer thread to one reader thread (a triple
// buffer): the writer publishes whole values, the reader always gets the newest complete one and
// skips older ones. Neither side ever blocks, waits or allocates. It is not a queue (values can be
// skipped) and supports exactly one writer and one reader thread. A value that owns storage (a
// vector) is filled in place through back() and read in place through latest(): once every slot
// has its capacity (the constructor's `initial`), handing it over allocates nothing.

#include <array>
#include <atomic>
#include <cstdint>
#include <type_traits>

#include "concurrency/spsc_queue.h"

namespace doppel::concurrency {

template <class T>
class Snapshot {
 public:
  Snapshot() noexcept(std::is_nothrow_default_constructible_v<T>) = default;
  // Every slot starts as `initial`, so the reader sees it until the first publish. Setup: may
  // throw when copying T does (a vector that allocates).
  explicit Snapshot(const T& initial) noexcept(std::is_nothrow_copy_assignable_v<T>) {
    for (auto& slot : slots_) slot.value = initial;
  }

  // Writer thread only. The slot the next publish() hands over. It holds stale data: overwrite the
  // whole value before publishing. rt-safe.
  T& back() noexcept { return slots_[back_].value; }

  // Writer thread only. Makes back() the newest value. rt-safe, wait-free.
  void publish() noexcept {
    back_ = middle_.exchange(back_ | kFresh, std::memory_order_acq_rel) & kIndexMask;
  }

  // Writer thread only. Copies `value` into back() and publishes it. rt-safe, wait-free.
  void publish(const T& value) noexcept {
    static_assert(std::is_nothrow_copy_assignable_v<T>, "publish copies without throwing");
    back() = value;
    publish();
  }

  // Reader thread only. Takes the newest published value if there is one the reader has not seen;
  // true when it did. rt-safe, wait-free.
  bool update() noexcept {
    if ((middle_.load(std::memory_order_relaxed) & kFresh) == 0) return false;
    front_ = middle_.exchange(front_, std::memory_order_acq_rel) & kIndexMask;
    return true;
  }

  // Reader thread only. The newest complete value; the reference stays valid and unchanged until
  // this thread's next update()/latest()/read(). rt-safe.
  const T& latest() noexcept {
    update();
    return slots_[front_].value;
  }

  // Reader thread only. Copies the newest value into `out`; true when it is newer than the one
  // returned before. rt-safe.
  bool read(T& out) noexcept {
    static_assert(std::is_nothrow_copy_assignable_v<T>, "read copies without throwing");
    const bool fresh = update();
    out = slots_[front_].value;
    return fresh;
  }

 private:
  static constexpr uint8_t kIndexMask = 0x3;
  static constexpr uint8_t kFresh = 0x4;  // set in middle_ when it holds an unread value

  struct alignas(kCacheLineBytes) Slot {
    T value{};
  };

  std::array<Slot, 3> slots_{};                             // three buffers: front, middle, back
  alignas(kCacheLineBytes) std::atomic<uint8_t> middle_{1};  // index of the hand-over slot | kFresh
  alignas(kCacheLineBytes) uint8_t back_ = 2;                // writer's slot
  alignas(kCacheLineBytes) uint8_t front_ = 0;               // reader's slot
};

}  // namespace doppel::concurrency
