#pragma once
// Turns one bus' tap events (bus/traffic_tap.h) back into what a bus analyzer wants to read: one
// BusTransaction per framed instruction, with the instruction's bytes cut from the driver's byte
// stream and every status and time attached, in the order the instructions came; bytes that were
// not part of any packet as BusNoise; connects and hang-ups as BusEvent. Runs on the recorder's
// thread (it allocates); the bus thread only pushes events.
//
// A transaction is complete when its reply was written (kDelivered), dropped, discarded by a
// hang-up, or when it had no reply (the next event shows the bus moved on). Replies leave in
// order, so a delivery also completes every older transaction still waiting (their own delivery
// event was lost to a full tap: written_ns stays 0).

#include <cstdint>
#include <deque>
#include <functional>
#include <span>
#include <vector>

#include "bus/traffic_tap.h"
#include "proto/recording.pb.h"

namespace doppel::record {

struct TranscriptSink {
  std::function<void(const recording::BusTransaction&)> transaction;
  std::function<void(const recording::BusNoise&)> noise;
  std::function<void(const recording::BusEvent&)> event;
};

class BusTranscriber {
 public:
  // Transactions waiting for their reply beyond this are written without it (a client that
  // stopped reading): bounds memory.
  static constexpr std::size_t kMaxWaiting = 4096;

  BusTranscriber(uint32_t robot, uint32_t bus, std::string adapter, TranscriptSink sink);

  void feed(const bus::TapEvent& event, std::span<const uint8_t> payload);
  // The recording ends: waiting transactions are written as they are, unframed bytes as noise.
  void finish();

  uint64_t transactions() const noexcept { return transactions_; }

 private:
  struct Chunk {
    uint64_t offset = 0;     // stream position of its first byte
    uint64_t size = 0;
    int64_t seen_ns = 0;
    int64_t model_start_ns = 0;
    uint32_t model_baud_bps = 0;  // 0: fast mode (no wire duration)
  };
  struct Waiting {
    recording::BusTransaction transaction;
    bool open = true;        // events of its dispatch may still come
    bool has_reply = false;  // a kReply came: it waits for kDelivered
    bool done = false;
  };

  void close_open();
  void emit_done();
  void flush_noise(uint64_t until, const char* reason);
  const Chunk* chunk_at(uint64_t offset) const;
  void trim();
  Waiting* find(uint64_t sequence);

  uint32_t robot_;
  uint32_t bus_;
  std::string adapter_;
  TranscriptSink sink_;
  std::vector<uint8_t> stream_;   // driver bytes from stream_base_ on
  uint64_t stream_base_ = 0;
  uint64_t accounted_ = 0;        // stream position up to which bytes are framed or written as noise
  std::deque<Chunk> chunks_;
  std::deque<Waiting> waiting_;   // by sequence
  uint64_t transactions_ = 0;
};

}  // namespace doppel::record
