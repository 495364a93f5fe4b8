#pragma once
// When the host receives the bytes the devices put on the wire, given the USB-serial adapter in
// between (FTDI FT232 as in the U2D2, reference §4.3). A pure model with explicit times in ns; it
// does no I/O. It says nothing about wire timing itself (WireTiming does that).
//
// Model (FTDI AN232B-04, "Small amounts of data and end of buffer conditions"): the chip sends a
// USB packet to the host when its buffer holds 62 payload bytes (64-byte full-speed packet minus
// 2 status bytes), or when the latency timer expires. The timer "measures the time since data was
// last sent to the PC" and is reset every time data is sent; an idle chip still sends its 2 status
// bytes at every expiry. So the timer ticks freely with the latency period, and a full-buffer send
// restarts it. Here the first tick phase is the clock origin (t = 0), i.e. arbitrary relative to
// the host, as on hardware: a short reply waits a uniformly distributed (0, L] after its end.
// Not modelled: the host's USB polling and the ftdi_sio/URB path (a few hundred µs on hardware).
//
// Latency 0 = no adapter (a plain pty): each status is handed over when its last byte has crossed.
// Bytes are never reordered or lost; deliveries come out in byte order with non-decreasing times.

#include <algorithm>
#include <cstddef>
#include <cstdint>

#include "bus/wire_timing.h"

namespace doppel::bus {

// Bytes [offset, offset + count) of the current reply reach the host at due_ns.
struct Delivery {
  int64_t due_ns = 0;      // when the host can read them
  std::size_t offset = 0;  // first byte, counted from the start of the reply (all its statuses)
  std::size_t count = 0;   // number of bytes
};

class AdapterLatency {
 public:
  static constexpr std::size_t kUsbPayloadBytes = 62;  // full-speed bulk packet 64 B - 2 status bytes
  static constexpr uint32_t kMaxLatencyMs = 255;       // FTDI range 1..255 ms
  static constexpr uint32_t kFtdiDefaultLatencyMs = 16;

  // latency_ms: 0 = off (pty default), else the adapter's latency timer (FTDI default 16, teams
  // often set 1). Throws std::invalid_argument above kMaxLatencyMs. Setup only.
  explicit AdapterLatency(uint32_t latency_ms = 0);

  // Starts the statuses answering one instruction; offsets restart at 0. rt-safe.
  void begin_reply() noexcept { reply_offset_ = 0; }

  // Feeds one status of `n` bytes that occupies `span` on the wire, and calls
  // emit(const Delivery&) for every hand-over that is decided. rt-safe if emit is.
  template <class Emit>
  void add_status(const WireSpan& span, std::size_t n, Emit&& emit) noexcept;

  // Ends the reply: hands over the bytes still waiting for the timer. rt-safe if emit is.
  template <class Emit>
  void end_reply(Emit&& emit) noexcept;

  // Empties the adapter buffer (new client session); the timer keeps its phase. rt-safe.
  void reset() noexcept { batch_count_ = 0; reply_offset_ = 0; }

  // Changes the latency timer between replies (0 = off); the timer keeps its phase. False (and no
  // change) above kMaxLatencyMs. rt-safe.
  bool set_latency_ms(uint32_t latency_ms) noexcept {
    if (latency_ms > kMaxLatencyMs) return false;
    latency_ms_ = latency_ms;
    period_ns_ = static_cast<int64_t>(latency_ms) * 1'000'000;
    return true;
  }

  uint32_t latency_ms() const noexcept { return latency_ms_; }

 private:
  // First timer expiry at or after t_ns.
  int64_t next_tick_ns(int64_t t_ns) const noexcept {
    if (t_ns <= anchor_ns_) return anchor_ns_;
    const int64_t periods = (t_ns - anchor_ns_ + period_ns_ - 1) / period_ns_;
    return anchor_ns_ + periods * period_ns_;
  }
  // Bytes of `span` (1-based count) that have crossed by t_ns.
  static std::size_t crossed_by(const WireSpan& span, std::size_t n, int64_t t_ns) noexcept {
    if (t_ns >= span.end_ns || span.baud_bps == 0) return n;
    if (t_ns < span.start_ns) return 0;
    const uint64_t elapsed_bits = static_cast<uint64_t>(t_ns - span.start_ns) * span.baud_bps;
    return std::min<std::size_t>(n, static_cast<std::size_t>(elapsed_bits / 10'000'000'000u));
  }

  uint32_t latency_ms_ = 0;
  int64_t period_ns_ = 0;
  int64_t anchor_ns_ = 0;          // last timer restart; expiries at anchor + k * period
  std::size_t reply_offset_ = 0;   // bytes of the current reply fed so far
  std::size_t batch_offset_ = 0;   // first byte in the adapter buffer (reply offset)
  std::size_t batch_count_ = 0;    // bytes in the adapter buffer
  int64_t batch_tick_ns_ = 0;      // expiry that will send the buffer
};

template <class Emit>
void AdapterLatency::add_status(const WireSpan& span, std::size_t n, Emit&& emit) noexcept {
  if (n == 0) return;
  if (latency_ms_ == 0) {
    emit(Delivery{span.end_ns, reply_offset_, n});
    reply_offset_ += n;
    return;
  }
  std::size_t k = 0;  // next byte of this status
  while (k < n) {
    const int64_t arrival_ns = span.byte_end_ns(k);
    if (batch_count_ > 0 && arrival_ns > batch_tick_ns_) {
      emit(Delivery{batch_tick_ns_, batch_offset_, batch_count_});
      anchor_ns_ = std::max(anchor_ns_, batch_tick_ns_);
      batch_count_ = 0;
    }
    if (batch_count_ == 0) {
      batch_offset_ = reply_offset_ + k;
      batch_tick_ns_ = next_tick_ns(arrival_ns);
    }
    // Every byte that crosses before the expiry joins this buffer, up to a full USB packet.
    const std::size_t by_tick = std::max(crossed_by(span, n, batch_tick_ns_), k + 1);
    const std::size_t joining = std::min(by_tick - k, kUsbPayloadBytes - batch_count_);
    k += joining;
    batch_count_ += joining;
    if (batch_count_ == kUsbPayloadBytes) {
      const int64_t full_ns = span.byte_end_ns(k - 1);
      emit(Delivery{full_ns, batch_offset_, batch_count_});
      anchor_ns_ = full_ns;  // sending data restarts the latency timer
      batch_count_ = 0;
    }
  }
  reply_offset_ += n;
}

template <class Emit>
void AdapterLatency::end_reply(Emit&& emit) noexcept {
  if (batch_count_ == 0) return;
  emit(Delivery{batch_tick_ns_, batch_offset_, batch_count_});
  anchor_ns_ = std::max(anchor_ns_, batch_tick_ns_);
  batch_count_ = 0;
}

}  // namespace doppel::bus
