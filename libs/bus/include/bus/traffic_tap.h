#pragma once
// Everything that crosses one bus, as events the bus thread hands to a recorder without waiting:
// the driver's bytes as Doppel read them, each framed instruction (where its bytes sit in that
// stream and when the wire model had them), each status with its wire times, and when a reply was
// due and written. The recorder (record/) joins them into transactions; the bus thread only copies
// bytes into a fixed ring. A full ring drops whole events and counts them.

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "concurrency/spsc_byte_ring.h"

namespace doppel::bus {

enum class TapEventKind : uint8_t {
  kInput,         // bytes read from the driver; payload: the bytes
  kInstruction,   // a framed instruction packet (no payload: its bytes are in the input stream)
  kStatus,        // a status of the current reply; payload: its wire bytes
  kReply,         // the current reply is complete and scheduled
  kDelivered,     // a reply's last byte was written to the pty
  kReplyDropped,  // a reply was not scheduled: the client was not reading (schedule full)
  kConnect,       // a client opened the port
  kHangUp,        // the client closed the port; undelivered replies are discarded
  kTimeout,       // a partial packet was dropped by the inter-byte timeout
};

// The fixed part of every event; which fields mean what depends on `kind` (see each field).
struct TapEvent {
  TapEventKind kind = TapEventKind::kInput;
  uint8_t protocol = 0;      // kInstruction: 1 or 2
  bool checksum_ok = false;  // kInstruction
  uint8_t pad = 0;
  uint32_t baud_bps = 0;     // kInput, kInstruction: the line rate
  uint32_t value = 0;        // kInput: the model's line rate (0 fast); kInstruction: packet wire bytes; kStatus: Return Delay Time µs; kReply: adapter latency ms
  uint64_t sequence = 0;     // kInstruction .. kReplyDropped: the transaction (per bus, from 0); kInput: stream offset of the first byte
  uint64_t stream_end = 0;   // kInstruction: stream offset just past its last byte
  int64_t t0_ns = 0;         // kInput: read; kInstruction: model end; kStatus: model start; kReply: due; kDelivered: written; others: when
  int64_t t1_ns = 0;         // kInput: model start of the first byte; kInstruction: read (last byte); kStatus: model end
};

class TrafficTap {
 public:
  // A ring of `capacity_bytes` (a 4 Mbps bus writes about 1 MB/s into it). Setup only.
  explicit TrafficTap(std::size_t capacity_bytes = std::size_t{8} << 20) : ring_(capacity_bytes) {}

  // Bus thread only. false when the ring was full (the event is dropped and counted). rt-safe.
  bool push(const TapEvent& event, std::span<const uint8_t> payload = {}) noexcept {
    return ring_.try_write({reinterpret_cast<const uint8_t*>(&event), sizeof(event)}, payload);
  }

  // Recorder thread only. The oldest event and its payload; false when none is waiting (or a
  // record is malformed, which cannot happen unless memory is corrupt).
  bool pop(TapEvent& event, std::vector<uint8_t>& payload) {
    if (!ring_.try_read(scratch_) || scratch_.size() < sizeof(TapEvent)) return false;
    std::memcpy(&event, scratch_.data(), sizeof(TapEvent));
    payload.assign(scratch_.begin() + sizeof(TapEvent), scratch_.end());
    return true;
  }

  uint64_t dropped() const noexcept { return ring_.dropped(); }

 private:
  concurrency::SpscByteRing ring_;
  std::vector<uint8_t> scratch_;  // recorder thread
};

}  // namespace doppel::bus
