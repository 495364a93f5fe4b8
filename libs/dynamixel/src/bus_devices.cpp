#include "dynamixel/bus_devices.h"

#include <algorithm>
#include <bitset>
#include <stdexcept>
#include <string>

#include "dynamixel/protocol2.h"

namespace doppel::dynamixel {

namespace {

// Position of a reply in the wire order: the direct reply is slot 0, chained replies follow their
// predecessor. A chained reply claiming slot 0 has no predecessor to wait for (device bug): it is
// treated as unreachable.
constexpr uint32_t kUnreachableSlot = 0xFFFFFFFFu;

uint32_t reply_slot(const Response& r) noexcept {
  switch (r.timing) {
    case ReplyTiming::kAfterInstruction:
      return 0;
    case ReplyTiming::kFastBlock:
    case ReplyTiming::kIdOrder:  // chain_position set by dispatch() from the ID rank
      return r.chain_position;
    case ReplyTiming::kAfterPrevious:
      break;
  }
  return r.chain_position == 0 ? kUnreachableSlot : r.chain_position;
}

// Protocol 2.0 broadcast PING (reference §2.6): ROBOTIS' slave firmware lets ID n answer once the
// status of the previous ID has been seen, or after 3 ms of silence per missing ID.
constexpr int64_t kPingSlotNs = 3'000'000;

// The wire carries the AND of the bits every driver pushes (an idle line reads 1).
void wired_and(StatusPacket& into, const StatusPacket& other) noexcept {
  const uint16_t common = std::min(into.size, other.size);
  for (uint16_t i = 0; i < common; ++i) {
    into.bytes[i] = static_cast<uint8_t>(into.bytes[i] & other.bytes[i]);
  }
  for (uint16_t i = into.size; i < other.size; ++i) {
    into.bytes[i] = other.bytes[i];
  }
  into.size = std::max(into.size, other.size);
}

}  // namespace

bool baud_rates_match(uint32_t device_bps, uint32_t line_bps) noexcept {
  if (device_bps == 0 || line_bps == 0) {
    return false;
  }
  const double ratio = static_cast<double>(line_bps) / static_cast<double>(device_bps);
  return ratio >= 1.0 - BusDevices::kBaudTolerance && ratio <= 1.0 + BusDevices::kBaudTolerance;
}

void BusDevices::add(Device& device) {
  if (count_ == kMaxDevices) {
    throw std::length_error("BusDevices: a bus holds at most " + std::to_string(kMaxDevices) +
                            " devices");
  }
  powered_[count_] = true;
  reachable_[count_] = true;
  devices_[count_++] = &device;
}

void BusDevices::set_powered(std::size_t index, bool powered) noexcept {
  if (index < count_) {
    powered_[index] = powered;
  }
}

void BusDevices::set_reachable(std::size_t index, bool reachable) noexcept {
  if (index < count_) {
    reachable_[index] = reachable;
  }
}

std::span<const OutgoingStatus> BusDevices::dispatch(const InstructionPacket& packet,
                                                     uint32_t line_baud_bps) noexcept {
  ++counters_.instructions;

  // Every device whose UART decodes the line sees the packet; note its ID before it may change.
  std::size_t listeners = 0;
  std::size_t powered = 0;
  std::size_t transmitting = 0;
  for (std::size_t i = 0; i < count_; ++i) {
    Response& r = responses_[i];
    r.transmits = false;
    r.timing = ReplyTiming::kAfterInstruction;
    r.chain_position = 0;
    r.status.size = 0;
    Device& d = *devices_[i];
    if (!powered_[i] || !reachable_[i]) {
      continue;
    }
    ++powered;
    if (!baud_rates_match(d.baud_bps(), line_baud_bps)) {
      continue;
    }
    ++listeners;
    sender_ids_[i] = d.id();
    sender_delays_us_[i] = d.return_delay_us();
    d.handle(packet, r);
    if (r.transmits) {
      order_[transmitting++] = static_cast<uint8_t>(i);
    }
  }
  if (listeners == 0 && powered > 0) {
    ++counters_.baud_mismatches;
  }

  // P2 broadcast PING: the slot of an answer is the rank of its ID among the answering IDs.
  for (std::size_t a = 0; a < transmitting; ++a) {
    Response& r = responses_[order_[a]];
    if (r.timing != ReplyTiming::kIdOrder) {
      continue;
    }
    std::bitset<256> lower;
    for (std::size_t b = 0; b < transmitting; ++b) {
      if (responses_[order_[b]].timing == ReplyTiming::kIdOrder && sender_ids_[order_[b]] < sender_ids_[order_[a]]) {
        lower.set(sender_ids_[order_[b]]);
      }
    }
    r.chain_position = static_cast<uint16_t>(lower.count());
  }

  // Wire order: by slot, ties (collisions) in the order the devices were added.
  for (std::size_t a = 1; a < transmitting; ++a) {
    const uint8_t idx = order_[a];
    const uint32_t slot = reply_slot(responses_[idx]);
    std::size_t b = a;
    while (b > 0 && reply_slot(responses_[order_[b - 1]]) > slot) {
      order_[b] = order_[b - 1];
      --b;
    }
    order_[b] = idx;
  }

  std::size_t out = 0;
  uint32_t expected_slot = 0;
  std::size_t k = 0;
  uint16_t fast_crc = 0;  // running CRC of a P2 fast-read combined status
  int previous_id = -1;   // P2 broadcast PING: ID of the previous answer
  while (k < transmitting) {
    const uint8_t first = order_[k];
    const uint32_t slot = reply_slot(responses_[first]);
    if (slot != expected_slot) {
      // The predecessor of this reply stayed silent: nobody after it gets a cue.
      counters_.broken_chains += transmitting - k;
      break;
    }
    Response& base = responses_[first];
    OutgoingStatus& o = outgoing_[out++];
    o.device_id = sender_ids_[first];
    o.return_delay_us = sender_delays_us_[first];
    o.after_previous = base.timing == ReplyTiming::kAfterPrevious;
    o.collision = false;
    o.extra_delay_ns = 0;
    o.continues_previous = false;
    const uint16_t block_crc = fast_crc;
    if (base.timing == ReplyTiming::kFastBlock) {
      o.after_previous = slot > 0;
      o.continues_previous = slot > 0;
      fast_crc = seal_fast_block(base.status, block_crc);
    } else if (base.timing == ReplyTiming::kIdOrder) {
      const int id = sender_ids_[first];
      const int idle_slots = previous_id < 0 ? std::max(0, id - 1) : std::max(0, id - previous_id - 1);
      o.after_previous = previous_id >= 0;
      o.extra_delay_ns = idle_slots * kPingSlotNs;
      previous_id = id;
    }
    ++k;
    while (k < transmitting && reply_slot(responses_[order_[k]]) == slot) {
      const uint8_t other = order_[k];
      if (responses_[other].timing == ReplyTiming::kFastBlock) {
        seal_fast_block(responses_[other].status, block_crc);
      }
      wired_and(base.status, responses_[other].status);
      o.return_delay_us = std::min(o.return_delay_us, sender_delays_us_[other]);
      o.collision = true;
      ++k;
    }
    if (o.collision) {
      ++counters_.collisions;
    }
    o.packet = &base.status;
    ++expected_slot;
  }
  return {outgoing_.data(), out};
}

}  // namespace doppel::dynamixel
