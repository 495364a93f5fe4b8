#include "record/bus_transcriber.h"

#include <algorithm>
#include <utility>

#include "bus/wire_timing.h"

namespace doppel::record {

using bus::TapEventKind;

namespace {

// The answering device's ID, read from a status packet's header (P1: FF FF ID, P2: FF FF FD 00 ID).
uint32_t status_id(std::span<const uint8_t> bytes) {
  const bool p2 = bytes.size() >= 5 && bytes[2] == 0xFD && bytes[3] == 0x00;
  if (p2) return bytes[4];
  return bytes.size() >= 3 ? bytes[2] : 0;
}

}  // namespace

BusTranscriber::BusTranscriber(uint32_t robot, uint32_t bus, std::string adapter, TranscriptSink sink)
    : robot_(robot), bus_(bus), adapter_(std::move(adapter)), sink_(std::move(sink)) {}

BusTranscriber::Waiting* BusTranscriber::find(uint64_t sequence) {
  for (auto it = waiting_.rbegin(); it != waiting_.rend(); ++it) {
    if (it->transaction.sequence() == sequence) return &*it;
  }
  return nullptr;
}

const BusTranscriber::Chunk* BusTranscriber::chunk_at(uint64_t offset) const {
  for (const Chunk& chunk : chunks_) {
    if (offset >= chunk.offset && offset < chunk.offset + chunk.size) return &chunk;
  }
  return nullptr;
}

void BusTranscriber::feed(const bus::TapEvent& event, std::span<const uint8_t> payload) {
  switch (event.kind) {
    case TapEventKind::kInput: {
      close_open();
      const uint64_t end = stream_base_ + stream_.size();
      if (event.sequence != end) {
        // Events were lost to a full tap: what is left of the old stream cannot be framed any more.
        flush_noise(end, "gap");
        stream_.clear();
        chunks_.clear();
        stream_base_ = accounted_ = event.sequence;
      }
      chunks_.push_back({event.sequence, payload.size(), event.t0_ns, event.t1_ns, event.value});
      stream_.insert(stream_.end(), payload.begin(), payload.end());
      break;
    }
    case TapEventKind::kInstruction: {
      close_open();
      const uint64_t end = event.stream_end;
      const uint64_t start = end >= event.value ? end - event.value : 0;
      flush_noise(start, "unframed");
      recording::BusTransaction t;
      t.set_robot(robot_);
      t.set_bus(bus_);
      t.set_sequence(event.sequence);
      t.set_protocol(event.protocol);
      t.set_checksum_ok(event.checksum_ok);
      t.set_baud_bps(event.baud_bps);
      t.set_adapter(adapter_);
      if (start >= stream_base_ && end <= stream_base_ + stream_.size()) {
        t.set_instruction(std::string(stream_.begin() + static_cast<std::ptrdiff_t>(start - stream_base_),
                                      stream_.begin() + static_cast<std::ptrdiff_t>(end - stream_base_)));
      }
      if (const Chunk* chunk = chunk_at(start)) {
        t.set_first_seen_ns(chunk->seen_ns);
        t.set_instruction_start_ns(chunk->model_start_ns +
                                   bus::wire_duration_ns(static_cast<std::size_t>(start - chunk->offset), chunk->model_baud_bps));
      }
      t.set_seen_ns(event.t1_ns);
      t.set_instruction_end_ns(event.t0_ns);
      accounted_ = std::max(accounted_, end);
      waiting_.push_back({std::move(t), true, false, false});
      trim();
      break;
    }
    case TapEventKind::kStatus:
      if (Waiting* w = find(event.sequence)) {
        recording::Status* status = w->transaction.add_statuses();
        status->set_id(status_id(payload));
        status->set_bytes(std::string(payload.begin(), payload.end()));
        status->set_start_ns(event.t0_ns);
        status->set_end_ns(event.t1_ns);
        status->set_return_delay_us(event.value);
      }
      break;
    case TapEventKind::kReply:
      if (Waiting* w = find(event.sequence)) {
        w->transaction.set_due_ns(event.t0_ns);
        w->transaction.set_adapter_latency_ms(event.value);
        w->has_reply = true;
      }
      break;
    case TapEventKind::kReplyDropped:
      if (Waiting* w = find(event.sequence)) {
        w->transaction.set_reply_dropped(true);
        w->open = false;
        w->done = true;
      }
      emit_done();
      break;
    case TapEventKind::kDelivered:
      for (Waiting& w : waiting_) {
        if (w.transaction.sequence() > event.sequence) break;
        if (w.transaction.sequence() == event.sequence) {
          w.transaction.set_written_ns(event.t0_ns);
          w.open = false;
          w.done = true;
        } else if (w.has_reply) {
          w.done = true;  // delivered before this one; its own event was lost
        }
      }
      emit_done();
      break;
    case TapEventKind::kConnect:
    case TapEventKind::kHangUp: {
      close_open();
      const bool hang_up = event.kind == TapEventKind::kHangUp;
      if (hang_up) {
        flush_noise(stream_base_ + stream_.size(), "hang_up");
        for (Waiting& w : waiting_) {
          if (!w.done) {
            w.transaction.set_reply_dropped(true);
            w.done = true;
          }
        }
        emit_done();
      }
      recording::BusEvent e;
      e.set_robot(robot_);
      e.set_bus(bus_);
      e.set_time_ns(event.t0_ns);
      e.set_event(hang_up ? "hang_up" : "connect");
      if (sink_.event) sink_.event(e);
      break;
    }
    case TapEventKind::kTimeout:
      close_open();
      flush_noise(stream_base_ + stream_.size(), "timeout");
      break;
  }
}

void BusTranscriber::finish() {
  close_open();
  for (Waiting& w : waiting_) w.done = true;
  emit_done();
  flush_noise(stream_base_ + stream_.size(), "unframed");
}

void BusTranscriber::close_open() {
  if (waiting_.empty() || !waiting_.back().open) return;
  Waiting& w = waiting_.back();
  w.open = false;
  if (!w.has_reply) w.done = true;
  emit_done();
}

void BusTranscriber::emit_done() {
  while (!waiting_.empty() && (waiting_.front().done || waiting_.size() > kMaxWaiting)) {
    if (sink_.transaction) sink_.transaction(waiting_.front().transaction);
    waiting_.pop_front();
    ++transactions_;
  }
}

void BusTranscriber::flush_noise(uint64_t until, const char* reason) {
  const uint64_t from = std::max(accounted_, stream_base_);
  const uint64_t to = std::min(until, stream_base_ + stream_.size());
  if (to > from) {
    recording::BusNoise noise;
    noise.set_robot(robot_);
    noise.set_bus(bus_);
    const Chunk* chunk = chunk_at(from);
    noise.set_seen_ns(chunk != nullptr ? chunk->seen_ns : 0);
    noise.set_bytes(std::string(stream_.begin() + static_cast<std::ptrdiff_t>(from - stream_base_),
                                stream_.begin() + static_cast<std::ptrdiff_t>(to - stream_base_)));
    noise.set_reason(reason);
    if (sink_.noise) sink_.noise(noise);
  }
  accounted_ = std::max(accounted_, until);
  trim();
}

void BusTranscriber::trim() {
  const uint64_t keep_from = std::min(accounted_, stream_base_ + stream_.size());
  if (keep_from > stream_base_) {
    stream_.erase(stream_.begin(), stream_.begin() + static_cast<std::ptrdiff_t>(keep_from - stream_base_));
    stream_base_ = keep_from;
  }
  while (!chunks_.empty() && chunks_.front().offset + chunks_.front().size <= stream_base_ && chunks_.size() > 1) {
    chunks_.pop_front();
  }
}

}  // namespace doppel::record
