#pragma once
// The byte pipe between Doppel and a servo-bus driver, as an interface so tests and benchmarks can
// replace the pseudo-terminal with a fake. It moves bytes only: framing, timing and connection
// handling live above it (BusServer) or in the concrete port (PtyPort).

#include <cstddef>
#include <cstdint>

namespace doppel::bus {

class Transport {
 public:
  virtual ~Transport() = default;

  // Copies up to `capacity` received bytes into `dst`; 0 when nothing is waiting. Never blocks.
  // rt-safe.
  virtual std::size_t read(uint8_t* dst, std::size_t capacity) noexcept = 0;

  // Queues up to `n` bytes for the client; returns how many were accepted (possibly fewer when the
  // pipe is full, 0 when nobody is connected). Never blocks. rt-safe.
  virtual std::size_t write(const uint8_t* src, std::size_t n) noexcept = 0;
};

}  // namespace doppel::bus
