#pragma once
// When bytes cross a half-duplex Dynamixel line: a pure model with explicit times (ns, any common
// origin), so it can be tested with hand-computed numbers. It does no I/O and reads no clock.
//
// Model (reference §4.1, §1.6):
// - 8N1 framing: 10 bit times per byte at the line's baud rate.
// - One sender at a time. Host bytes that Doppel sees at time t start crossing at
//   max(t, wire_free_at); an instruction packet has ended when its last byte has crossed.
// - A status starts `processing_ns` (firmware time, default 50 µs as measured on an MX-64) plus the
//   device's Return Delay Time after the end of the instruction, and ends bytes × byte time later.
// - Chained status (OutgoingStatus::after_previous, BULK READ): starts processing_ns + its own
//   Return Delay Time after the previous status has ended. ASSUMPTION: the e-Manual only says the
//   next device "transmits when the previous one finishes" and reference §6 says the spacing is not
//   documented; adding the same firmware time and the device's own RDT keeps a chained device no
//   faster than a unicast reply from it.
// - Protocol 2.0 (BusDevices decides the order): a broadcast PING answer waits 3 ms more for
//   every unused ID before it; the blocks of a FAST SYNC/BULK READ status follow each other
//   without a gap, as one packet.
// - A status never starts before the previous status of the same instruction has ended (one
//   sender at a time); overlapping replies are BusDevices' business (it marks collisions).
// - Fast mode: no model delay at all; everything happens at the time it is seen.

#include <cstddef>
#include <cstdint>

namespace doppel::bus {

enum class TimingMode : uint8_t {
  kWire,  // replies at the wire timing of the line's baud rate (default)
  kFast,  // replies as soon as possible: zero model delay
};

// Time for `n_bytes` 8N1 bytes at `baud_bps`, rounded up to whole ns; 0 when baud_bps is 0 (B0).
// Exact for long runs: computed from the total, not summed per byte. rt-safe.
constexpr int64_t wire_duration_ns(std::size_t n_bytes, uint32_t baud_bps) noexcept {
  if (baud_bps == 0) return 0;
  const uint64_t bit_ns = static_cast<uint64_t>(n_bytes) * 10u * 1'000'000'000u;
  return static_cast<int64_t>((bit_ns + baud_bps - 1) / baud_bps);
}

// A run of bytes on the wire: byte i (0-based) has crossed at byte_end_ns(i).
struct WireSpan {
  int64_t start_ns = 0;   // first bit of the first byte
  int64_t end_ns = 0;     // last bit of the last byte
  uint32_t baud_bps = 0;  // line rate the bytes travel at (0 in fast mode: no duration)

  int64_t byte_end_ns(std::size_t index) const noexcept {
    return start_ns + wire_duration_ns(index + 1, baud_bps);
  }
};

class WireTiming {
 public:
  static constexpr int64_t kDefaultProcessingNs = 50'000;  // MX-64 firmware, instruction end -> RDT start

  // Throws std::invalid_argument when processing_ns is negative. Setup only.
  explicit WireTiming(TimingMode mode = TimingMode::kWire, int64_t processing_ns = kDefaultProcessingNs);

  // `n` host bytes that Doppel read at `t_seen_ns`, sent at `baud_bps`. Returns where they sit on
  // the wire and marks the wire busy until they have crossed. rt-safe.
  WireSpan host_bytes(int64_t t_seen_ns, std::size_t n, uint32_t baud_bps) noexcept;

  // Starts the replies to an instruction whose last byte crossed at `instruction_end_ns`. rt-safe.
  void begin_reply(int64_t instruction_end_ns) noexcept;

  // Places the next status of the current reply: `n` bytes from a device with the given Return
  // Delay Time (µs), chained after the previous status or not, `extra_delay_ns` later still (idle
  // ID slots of a Protocol 2.0 broadcast PING). `continues_previous` (a block of a P2 fast-read
  // combined status) starts right where the previous status ended, with no firmware time or
  // Return Delay Time. Marks the wire busy. rt-safe.
  WireSpan status(std::size_t n, uint32_t return_delay_us, bool after_previous, uint32_t baud_bps,
                  int64_t extra_delay_ns = 0, bool continues_previous = false) noexcept;

  // Marks the wire busy until `t_ns` (an adapter talking to the servos on its own). rt-safe.
  void hold_until(int64_t t_ns) noexcept {
    if (t_ns > wire_free_at_ns_) wire_free_at_ns_ = t_ns;
  }
  // Forgets the wire's state (a new client session starts with an idle line). rt-safe.
  void reset() noexcept;

  int64_t wire_free_at_ns() const noexcept { return wire_free_at_ns_; }
  TimingMode mode() const noexcept { return mode_; }
  int64_t processing_ns() const noexcept { return processing_ns_; }

 private:
  TimingMode mode_;
  int64_t processing_ns_;
  int64_t wire_free_at_ns_ = INT64_MIN;     // end of the last byte placed on the wire
  int64_t instruction_end_ns_ = 0;          // of the reply being placed
  int64_t previous_status_end_ns_ = 0;      // end of the last status of this reply
  bool have_previous_status_ = false;       // a status of this reply was placed already
};

}  // namespace doppel::bus
