#include "bus/reply_schedule.h"

#include <algorithm>
#include <cstring>

namespace doppel::bus {

void ReplySchedule::push_bytes(const uint8_t* src, std::size_t n) noexcept {
  std::size_t tail = (byte_head_ + byte_count_) % kByteCapacity;
  while (n > 0) {
    const std::size_t chunk = std::min(n, kByteCapacity - tail);
    std::memcpy(bytes_.data() + tail, src, chunk);
    src += chunk;
    n -= chunk;
    byte_count_ += chunk;
    tail = (tail + chunk) % kByteCapacity;
  }
}

bool ReplySchedule::push_segment(int64_t due_ns, std::size_t count) noexcept {
  if (count == 0) return true;
  due_ns = std::max(due_ns, last_due_ns_);
  last_due_ns_ = due_ns;
  assigned_bytes_ += count;
  if (segment_count_ > 0) {
    Segment& last = segments_[(segment_head_ + segment_count_ - 1) % kSegmentCapacity];
    // Bytes of the same reply due at the same time (fast mode, or chained statuses the adapter
    // hands over together) leave in one write: one wake-up of the client instead of several.
    if (!last.reply_end && last.due_ns == due_ns) {
      last.count += count;
      return true;
    }
    if (segment_count_ == kSegmentCapacity) {
      last.count += count;
      last.due_ns = due_ns;
      return false;
    }
  }
  Segment& segment = segments_[(segment_head_ + segment_count_) % kSegmentCapacity];
  segment = Segment{due_ns, count, false, {}};
  ++segment_count_;
  return true;
}

void ReplySchedule::mark_reply_end(const ReplyTrace& trace) noexcept {
  if (segment_count_ == 0) return;
  Segment& last = segments_[(segment_head_ + segment_count_ - 1) % kSegmentCapacity];
  last.reply_end = true;
  last.trace = trace;
}

std::span<const uint8_t> ReplySchedule::due_bytes(int64_t now_ns) const noexcept {
  std::size_t due = 0;
  for (std::size_t k = 0; k < segment_count_; ++k) {
    const Segment& segment = segments_[(segment_head_ + k) % kSegmentCapacity];
    if (segment.due_ns > now_ns) break;
    due += segment.count;
  }
  return {bytes_.data() + byte_head_, std::min(due, kByteCapacity - byte_head_)};
}

ReplySchedule::Progress ReplySchedule::consume(std::size_t n) noexcept {
  Progress progress;
  if (segment_count_ == 0) return progress;
  Segment& front = segments_[segment_head_];
  n = std::min(n, front.count);
  progress.bytes = n;
  front.count -= n;
  byte_head_ = (byte_head_ + n) % kByteCapacity;
  byte_count_ -= n;
  assigned_bytes_ -= n;
  if (front.count == 0) {
    progress.segment_done = true;
    progress.reply_done = front.reply_end;
    progress.due_ns = front.due_ns;
    progress.trace = front.trace;
    segment_head_ = (segment_head_ + 1) % kSegmentCapacity;
    --segment_count_;
  }
  return progress;
}

void ReplySchedule::clear() noexcept {
  byte_head_ = 0;
  byte_count_ = 0;
  assigned_bytes_ = 0;
  segment_head_ = 0;
  segment_count_ = 0;
  last_due_ns_ = INT64_MIN;
}

}  // namespace doppel::bus
