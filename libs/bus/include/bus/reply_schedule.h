#pragma once
// The status bytes a bus has promised but not yet handed to the client, each run with the time it
// is due: a fixed-capacity byte ring plus a ring of delivery segments, so the bus thread never
// allocates per packet. It keeps byte order (segments leave in the order they were added) and
// knows nothing of the pty or of the timing model.

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

namespace doppel::bus {

// What the model predicted for one reply, and when its last byte actually left (benchmarks
// compare written_ns with due_ns; all times CLOCK_MONOTONIC ns).
struct ReplyTrace {
  int64_t seen_ns = 0;             // Doppel read the chunk holding the instruction's last byte
  int64_t instruction_end_ns = 0;  // model: the instruction's last byte crossed the wire
  int64_t status_end_ns = 0;       // model: the reply's last status byte crossed the wire
  int64_t due_ns = 0;              // model: the host receives the last byte (adapter included)
  int64_t written_ns = 0;          // actual: the last byte was written to the pty
  uint32_t bytes = 0;              // status bytes in the reply (all statuses)
  uint32_t line_baud_bps = 0;      // line rate the instruction came at
  uint64_t sequence = 0;           // the transaction (BusServer's count of framed instructions)
  uint8_t id = 0;                  // instruction's target ID
  uint8_t instruction = 0;         // instruction code
};

class ReplySchedule {
 public:
  // Bytes waiting, all replies: ~1.5 s of output at 1 Mbps for a client that stops reading (the
  // pty itself holds only about 8 KiB).
  static constexpr std::size_t kByteCapacity = std::size_t{1} << 18;
  static constexpr std::size_t kSegmentCapacity = 1024;  // deliveries waiting (then merged)

  // Result of consume(): whether the front segment / its reply has been fully handed over.
  struct Progress {
    std::size_t bytes = 0;      // bytes of the front segment taken by this call
    bool segment_done = false;  // the front segment was completed (and removed)
    bool reply_done = false;    // it was the last segment of a reply: trace is valid
    int64_t due_ns = 0;         // due time of the completed segment
    ReplyTrace trace{};         // trace of the completed reply (written_ns left for the caller)
  };

  // True when `n` more bytes fit (segments never refuse: see push_segment). rt-safe.
  bool can_accept(std::size_t n) const noexcept { return kByteCapacity - byte_count_ >= n; }
  // Appends bytes of the reply being built; the caller checked can_accept. rt-safe.
  void push_bytes(const uint8_t* src, std::size_t n) noexcept;
  // Declares that the next `count` unassigned bytes are due at `due_ns` (made non-decreasing).
  // Bytes due at the same time as the previous segment of the same reply join it (one write).
  // When the segment ring is full the bytes join the last segment at the later time, so they are
  // late rather than lost; returns false in that case. rt-safe.
  bool push_segment(int64_t due_ns, std::size_t count) noexcept;
  // Marks the last pushed segment as the end of a reply carrying `trace`. rt-safe.
  void mark_reply_end(const ReplyTrace& trace) noexcept;

  bool empty() const noexcept { return segment_count_ == 0; }
  std::size_t pending_bytes() const noexcept { return byte_count_; }
  // Due time of the oldest segment; only when !empty(). rt-safe.
  int64_t front_due_ns() const noexcept { return segments_[segment_head_].due_ns; }
  // The unwritten bytes of every segment due by `now_ns`, as far as they are contiguous in the
  // ring: deliveries that fell due together (the bus thread woke late) leave in one write. rt-safe.
  std::span<const uint8_t> due_bytes(int64_t now_ns) const noexcept;
  // Records that the first `n` bytes of the front segment were handed over (at most the segment:
  // call again with the rest for bytes that reach into the next). rt-safe.
  Progress consume(std::size_t n) noexcept;
  // Drops everything (the client went away). rt-safe.
  void clear() noexcept;

 private:
  struct Segment {
    int64_t due_ns = 0;        // hand-over time
    std::size_t count = 0;     // bytes left in this segment
    bool reply_end = false;    // last segment of a reply
    ReplyTrace trace{};        // valid when reply_end
  };

  std::array<uint8_t, kByteCapacity> bytes_{};
  std::size_t byte_head_ = 0;      // oldest unwritten byte
  std::size_t byte_count_ = 0;     // bytes stored (assigned to segments or not)
  std::size_t assigned_bytes_ = 0; // bytes covered by segments
  std::array<Segment, kSegmentCapacity> segments_{};
  std::size_t segment_head_ = 0;
  std::size_t segment_count_ = 0;
  int64_t last_due_ns_ = INT64_MIN;
};

}  // namespace doppel::bus
