#include "dynamixel/protocol1.h"

#include "framed_packet.h"

namespace doppel::dynamixel {

namespace {
// Header (2) + ID + LEN + INST/ERR + CKSUM.
constexpr std::size_t kFramingBytes = 6;
// LEN is one byte and counts INST/ERR and the checksum.
constexpr std::size_t kMaxP1Params = 255 - 2;

// Writes `FF FF ID LEN lead params CKSUM` (lead: INST or ERR); returns its size, 0 if it does not
// fit `capacity` or a P1 packet.
std::size_t encode_packet(uint8_t id, uint8_t lead, const uint8_t* params, std::size_t n, uint8_t* out,
                          std::size_t capacity) noexcept {
  if (n > kMaxP1Params || n + kFramingBytes > capacity) {
    return 0;
  }
  out[0] = 0xFF;
  out[1] = 0xFF;
  out[2] = id;
  out[3] = static_cast<uint8_t>(n + 2);
  out[4] = lead;
  for (std::size_t i = 0; i < n; ++i) {
    out[5 + i] = params[i];
  }
  out[5 + n] = protocol1_checksum(out + 2, n + 3);
  return n + kFramingBytes;
}

}  // namespace

uint8_t protocol1_checksum(const uint8_t* bytes, std::size_t n) noexcept {
  uint8_t sum = 0;
  for (std::size_t i = 0; i < n; ++i) {
    sum = static_cast<uint8_t>(sum + bytes[i]);
  }
  return static_cast<uint8_t>(~sum);
}

Protocol1Parser::Result Protocol1Parser::push(uint8_t byte) noexcept {
  switch (state_) {
    case State::kHeader1:
      if (byte == 0xFF) {
        state_ = State::kHeader2;
      } else {
        ++counters_.dropped_bytes;
      }
      return Result::kIncomplete;
    case State::kHeader2:
      if (byte == 0xFF) {
        state_ = State::kId;
      } else {
        // Neither the lone FF nor this byte can start a header.
        counters_.dropped_bytes += 2;
        state_ = State::kHeader1;
      }
      return Result::kIncomplete;
    case State::kId:
      if (byte == 0xFF) {
        // FF FF FF: 0xFF is no ID; the last two FF are the header.
        ++counters_.dropped_bytes;
        return Result::kIncomplete;
      }
      packet_.protocol = Protocol::kV1;
      packet_.id = byte;
      sum_ = byte;
      state_ = State::kLength;
      return Result::kIncomplete;
    case State::kLength:
      if (byte < 2) {
        // LEN counts at least INST and CKSUM. None of FF FF ID LEN can start a new header
        // (ID and LEN are not FF), so all four bytes go.
        ++counters_.bad_lengths;
        counters_.dropped_bytes += 4;
        state_ = State::kHeader1;
        return Result::kIncomplete;
      }
      length_ = byte;
      sum_ = static_cast<uint8_t>(sum_ + byte);
      state_ = State::kInstruction;
      return Result::kIncomplete;
    case State::kInstruction:
      packet_.instruction = byte;
      packet_.param_count = 0;
      sum_ = static_cast<uint8_t>(sum_ + byte);
      state_ = length_ > 2 ? State::kParams : State::kChecksum;
      return Result::kIncomplete;
    case State::kParams:
      packet_.params[packet_.param_count++] = byte;
      sum_ = static_cast<uint8_t>(sum_ + byte);
      if (packet_.param_count == length_ - 2) {
        state_ = State::kChecksum;
      }
      return Result::kIncomplete;
    case State::kChecksum:
      packet_.wire_bytes = static_cast<uint16_t>(length_ + 4);  // FF FF ID LEN, then LEN bytes
      detail::count_framed_packet(static_cast<uint8_t>(~sum_) == byte, packet_, counters_);
      state_ = State::kHeader1;
      return Result::kPacket;
  }
  return Result::kIncomplete;
}

void Protocol1Parser::reset() noexcept {
  if (state_ == State::kHeader2) {
    ++counters_.dropped_bytes;
  } else if (state_ != State::kHeader1) {
    ++counters_.timeouts;
  }
  state_ = State::kHeader1;
}

bool Protocol1Parser::idle() const noexcept { return state_ == State::kHeader1; }

bool encode_protocol1_status(uint8_t id, uint8_t error, const uint8_t* params, std::size_t n,
                             StatusPacket& out) noexcept {
  const std::size_t size = encode_packet(id, error, params, n, out.bytes.data(), out.bytes.size());
  out.size = static_cast<uint16_t>(size);
  return size != 0;
}

std::size_t encode_protocol1_instruction(uint8_t id, uint8_t instruction, const uint8_t* params,
                                         std::size_t n, uint8_t* out, std::size_t capacity) noexcept {
  return encode_packet(id, instruction, params, n, out, capacity);
}

}  // namespace doppel::dynamixel
