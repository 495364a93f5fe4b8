#include "dynamixel/packet_framer.h"

namespace doppel::dynamixel {

namespace {
constexpr uint8_t kFf = 0xFF;
constexpr uint8_t kFd = 0xFD;
}  // namespace

const InstructionPacket& PacketFramer::packet() const noexcept {
  return last_ == Active::kV2 ? p2_.packet() : p1_.packet();
}

PacketFramer::Result PacketFramer::feed_active(uint8_t byte) noexcept {
  if (active_ == Active::kV1) {
    const bool done = p1_.push(byte) == Protocol1Parser::Result::kPacket;
    if (done || p1_.idle()) {
      active_ = Active::kNone;
    }
    if (done) {
      last_ = Active::kV1;
      return Result::kPacket;
    }
    return Result::kIncomplete;
  }
  const bool done = p2_.push(byte) == Protocol2Parser::Result::kPacket;
  if (done || !p2_.in_packet()) {
    // After an impossible LEN the P2 parser may hold the start of a new header: hunt on from it
    // here, where a P1 header is recognised too.
    prefix_ = done ? 0 : p2_.header_bytes();
    p2_.release_header();
    active_ = Active::kNone;
  }
  if (done) {
    last_ = Active::kV2;
    return Result::kPacket;
  }
  return Result::kIncomplete;
}

PacketFramer::Result PacketFramer::push(uint8_t byte) noexcept {
  if (active_ != Active::kNone) {
    return feed_active(byte);
  }
  switch (prefix_) {
    case 0:
      if (byte == kFf) {
        prefix_ = 1;
      } else {
        ++dropped_;
      }
      return Result::kIncomplete;
    case 1:
      if (byte == kFf) {
        prefix_ = 2;
      } else {
        dropped_ += 2;
        prefix_ = 0;
      }
      return Result::kIncomplete;
    case 2:
      if (byte == kFf) {
        ++dropped_;  // FF FF FF: keep the last two
        return Result::kIncomplete;
      }
      if (byte == kFd) {
        prefix_ = 3;  // P2 header, or a P1 packet for ID 0xFD
        return Result::kIncomplete;
      }
      prefix_ = 0;
      active_ = Active::kV1;
      p1_.push(kFf);
      p1_.push(kFf);
      return feed_active(byte);
    default:
      prefix_ = 0;
      if (byte == 0x00) {
        active_ = Active::kV2;
        p2_.push(kFf);
        p2_.push(kFf);
        p2_.push(kFd);
        return feed_active(byte);
      }
      active_ = Active::kV1;
      p1_.push(kFf);
      p1_.push(kFf);
      p1_.push(kFd);
      return feed_active(byte);
  }
}

void PacketFramer::reset() noexcept {
  if (active_ == Active::kV1) {
    p1_.reset();
  } else if (active_ == Active::kV2) {
    p2_.reset();
  } else {
    dropped_ += prefix_;
  }
  active_ = Active::kNone;
  prefix_ = 0;
}

ParserCounters PacketFramer::counters() const noexcept {
  const ParserCounters& a = p1_.counters();
  const ParserCounters& b = p2_.counters();
  ParserCounters sum;
  sum.packets = a.packets + b.packets;
  sum.bad_checksums = a.bad_checksums + b.bad_checksums;
  sum.dropped_bytes = a.dropped_bytes + b.dropped_bytes + dropped_;
  sum.bad_lengths = a.bad_lengths + b.bad_lengths;
  sum.timeouts = a.timeouts + b.timeouts;
  return sum;
}

}  // namespace doppel::dynamixel
