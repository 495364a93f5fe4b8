#pragma once
// FNV-1a, 64 bit (Fowler/Noll/Vo, IETF draft-eastlake-fnv): the run hash of lockstep runs
// (docs/lockstep.md). Not cryptographic; chosen because it is a few lines, byte-order fixed and
// the same on every machine, so that two runs compare by one number per simulated second.

#include <cstddef>
#include <cstdint>
#include <cstring>

namespace doppel {

class Fnv1a {
 public:
  static constexpr uint64_t kOffsetBasis = 14695981039346656037ULL;
  static constexpr uint64_t kPrime = 1099511628211ULL;

  void add(const void* data, std::size_t n) noexcept {
    const auto* bytes = static_cast<const uint8_t*>(data);
    for (std::size_t i = 0; i < n; ++i) {
      hash_ = (hash_ ^ bytes[i]) * kPrime;
    }
  }
  void add_u8(uint8_t v) noexcept { hash_ = (hash_ ^ v) * kPrime; }
  // Little-endian bytes of `v`, whatever the machine's byte order.
  void add_u64(uint64_t v) noexcept {
    for (int i = 0; i < 8; ++i) add_u8(static_cast<uint8_t>(v >> (8 * i)));
  }
  void add_i64(int64_t v) noexcept { add_u64(static_cast<uint64_t>(v)); }
  // The bit pattern of `v` (so -0.0 and 0.0 differ: bit-identical is what is compared).
  void add_double(double v) noexcept {
    uint64_t bits = 0;
    std::memcpy(&bits, &v, sizeof bits);
    add_u64(bits);
  }
  uint64_t value() const noexcept { return hash_; }
  void reset() noexcept { hash_ = kOffsetBasis; }

 private:
  uint64_t hash_ = kOffsetBasis;
};

}  // namespace doppel
