#pragma once
// A bounded single-producer / single-consumer ring of variable-length records (a header and a
// payload, each a run of bytes), for handing packets of any size from a real-time thread to a
// writer thread without locks or allocation: SpscQueue would need every slot as large as the
// largest record. A record is written whole or not at all; when it does not fit it is dropped and
// counted, so the producer never waits.

#include <algorithm>
#include <bit>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <span>
#include <vector>

#include "concurrency/spsc_queue.h"

namespace doppel::concurrency {

class SpscByteRing {
 public:
  // `capacity_bytes` is rounded up to a power of two. Setup only (allocates).
  explicit SpscByteRing(std::size_t capacity_bytes)
      : capacity_(std::bit_ceil(std::max<std::size_t>(capacity_bytes, 64))),
        mask_(capacity_ - 1),
        bytes_(std::make_unique<uint8_t[]>(capacity_)) {}

  SpscByteRing(const SpscByteRing&) = delete;
  SpscByteRing& operator=(const SpscByteRing&) = delete;

  std::size_t capacity() const noexcept { return capacity_; }

  // Producer thread only. Appends one record made of `head` followed by `payload`; false (and
  // dropped() grows) when it does not fit. rt-safe, wait-free.
  bool try_write(std::span<const uint8_t> head, std::span<const uint8_t> payload = {}) noexcept {
    const uint64_t length = head.size() + payload.size();
    const uint64_t needed = sizeof(uint32_t) + length;
    const uint64_t write = write_.load(std::memory_order_relaxed);
    if (capacity_ - (write - cached_read_) < needed) {
      cached_read_ = read_.load(std::memory_order_acquire);
      if (capacity_ - (write - cached_read_) < needed || length > UINT32_MAX) {
        dropped_.store(dropped_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
        return false;
      }
    }
    const auto size = static_cast<uint32_t>(length);
    copy_in(write, reinterpret_cast<const uint8_t*>(&size), sizeof(size));
    copy_in(write + sizeof(size), head.data(), head.size());
    copy_in(write + sizeof(size) + head.size(), payload.data(), payload.size());
    write_.store(write + needed, std::memory_order_release);
    return true;
  }

  // Consumer thread only. Moves the oldest record into `out` (resized to it); false when empty.
  // Allocates only when `out` must grow.
  bool try_read(std::vector<uint8_t>& out) {
    const uint64_t read = read_.load(std::memory_order_relaxed);
    if (read == cached_write_) {
      cached_write_ = write_.load(std::memory_order_acquire);
      if (read == cached_write_) return false;
    }
    uint32_t size = 0;
    copy_out(read, reinterpret_cast<uint8_t*>(&size), sizeof(size));
    out.resize(size);
    copy_out(read + sizeof(size), out.data(), size);
    read_.store(read + sizeof(size) + size, std::memory_order_release);
    return true;
  }

  // Records refused by try_write because they did not fit. Any thread.
  uint64_t dropped() const noexcept { return dropped_.load(std::memory_order_relaxed); }

 private:
  void copy_in(uint64_t at, const uint8_t* src, std::size_t n) noexcept {
    const std::size_t offset = at & mask_;
    const std::size_t first = std::min(n, capacity_ - offset);
    if (first > 0) std::memcpy(bytes_.get() + offset, src, first);
    if (n > first) std::memcpy(bytes_.get(), src + first, n - first);
  }
  void copy_out(uint64_t at, uint8_t* dst, std::size_t n) const noexcept {
    const std::size_t offset = at & mask_;
    const std::size_t first = std::min(n, capacity_ - offset);
    if (first > 0) std::memcpy(dst, bytes_.get() + offset, first);
    if (n > first) std::memcpy(dst + first, bytes_.get(), n - first);
  }

  const std::size_t capacity_;
  const std::size_t mask_;
  std::unique_ptr<uint8_t[]> bytes_;
  alignas(kCacheLineBytes) std::atomic<uint64_t> write_{0};  // total bytes written (producer)
  uint64_t cached_read_ = 0;                                   // producer's last view of read_
  std::atomic<uint64_t> dropped_{0};
  alignas(kCacheLineBytes) std::atomic<uint64_t> read_{0};   // total bytes read (consumer)
  uint64_t cached_write_ = 0;                                  // consumer's last view of write_
};

}  // namespace doppel::concurrency
