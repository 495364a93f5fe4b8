#include "dynamixel/protocol2.h"

#include <array>

#include "framed_packet.h"

namespace doppel::dynamixel {

namespace {

constexpr uint8_t kFd = 0xFD;
constexpr uint8_t kFf = 0xFF;
constexpr uint8_t kFastStatusId = 0xFE;
// INST/0x55 + CRC: LEN of a packet without parameters or ERR.
constexpr std::size_t kLenOverhead = 3;

// table[i] = bitwise CRC of the single byte i (reference §2.2 table form).
constexpr std::array<uint16_t, 256> make_crc_table() {
  std::array<uint16_t, 256> table{};
  for (unsigned i = 0; i < 256; ++i) {
    uint16_t crc = static_cast<uint16_t>(i << 8);
    for (int bit = 0; bit < 8; ++bit) {
      crc = static_cast<uint16_t>((crc & 0x8000) != 0 ? (crc << 1) ^ 0x8005 : crc << 1);
    }
    table[i] = crc;
  }
  return table;
}
constexpr std::array<uint16_t, 256> kCrcTable = make_crc_table();

inline uint16_t crc_step(uint16_t crc, uint8_t byte) noexcept {
  return static_cast<uint16_t>((crc << 8) ^ kCrcTable[((crc >> 8) ^ byte) & 0xFF]);
}

// How much of the pattern FF FF FD ends a byte sequence after appending `byte` (0..3).
inline uint8_t next_pattern(uint8_t pattern, uint8_t byte) noexcept {
  if (byte == kFf) {
    return pattern == 0 ? 1 : 2;  // FF FF FF still ends in FF FF
  }
  if (byte == kFd && pattern == 2) {
    return 3;
  }
  return 0;
}

// Appends `n` bytes to out[pos...] with stuffing, continuing the pattern state. Returns false
// when capacity is exceeded.
bool append_stuffed(const uint8_t* in, std::size_t n, uint8_t* out, std::size_t capacity, std::size_t& pos,
                    uint8_t& pattern) noexcept {
  for (std::size_t i = 0; i < n; ++i) {
    if (pos >= capacity) {
      return false;
    }
    out[pos++] = in[i];
    pattern = next_pattern(pattern, in[i]);
    if (pattern == 3) {
      if (pos >= capacity) {
        return false;
      }
      out[pos++] = kFd;
      pattern = 0;
    }
  }
  return true;
}

// Writes the stuffed packet FF FF FD 00 ID LEN <lead...> <params...> CRC; `lead` is INST, or
// 0x55 and ERR. Returns the total size or 0.
std::size_t encode_packet(uint8_t id, const uint8_t* lead, std::size_t lead_n, const uint8_t* params, std::size_t n,
                          uint8_t* out, std::size_t capacity) noexcept {
  if (capacity < kP2HeaderBytes + lead_n + 2) {
    return 0;
  }
  out[0] = kFf;
  out[1] = kFf;
  out[2] = kFd;
  out[3] = 0x00;
  out[4] = id;
  std::size_t pos = kP2HeaderBytes;
  uint8_t pattern = 0;
  if (!append_stuffed(lead, lead_n, out, capacity, pos, pattern) ||
      !append_stuffed(params, n, out, capacity, pos, pattern) || pos + 2 > capacity) {
    return 0;
  }
  const std::size_t length = pos - kP2HeaderBytes + 2;
  if (length > 0xFFFF) {
    return 0;
  }
  out[5] = static_cast<uint8_t>(length & 0xFF);
  out[6] = static_cast<uint8_t>(length >> 8);
  const uint16_t crc = protocol2_crc(out, pos);
  out[pos++] = static_cast<uint8_t>(crc & 0xFF);
  out[pos++] = static_cast<uint8_t>(crc >> 8);
  return pos;
}

}  // namespace

uint16_t protocol2_crc(const uint8_t* bytes, std::size_t n, uint16_t crc) noexcept {
  for (std::size_t i = 0; i < n; ++i) {
    crc = crc_step(crc, bytes[i]);
  }
  return crc;
}

std::size_t protocol2_stuff(const uint8_t* in, std::size_t n, uint8_t* out, std::size_t capacity) noexcept {
  std::size_t pos = 0;
  uint8_t pattern = 0;
  return append_stuffed(in, n, out, capacity, pos, pattern) ? pos : 0;
}

std::size_t protocol2_unstuff(const uint8_t* in, std::size_t n, uint8_t* out) noexcept {
  std::size_t pos = 0;
  uint8_t pattern = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const uint8_t byte = in[i];
    if (pattern == 3) {
      pattern = 0;
      if (byte == kFd) {
        continue;
      }
    }
    out[pos++] = byte;
    pattern = next_pattern(pattern, byte);
  }
  return pos;
}

void Protocol2Parser::hunt(uint8_t byte) noexcept {
  switch (state_) {
    case State::kHeader1:
      if (byte == kFf) {
        state_ = State::kHeader2;
      } else {
        ++counters_.dropped_bytes;
      }
      return;
    case State::kHeader2:
      if (byte == kFf) {
        state_ = State::kHeader3;
      } else {
        counters_.dropped_bytes += 2;
        state_ = State::kHeader1;
      }
      return;
    case State::kHeader3:
      if (byte == kFd) {
        state_ = State::kReserved;
      } else if (byte == kFf) {
        ++counters_.dropped_bytes;  // FF FF FF: the last two may still start a header
      } else {
        counters_.dropped_bytes += 3;
        state_ = State::kHeader1;
      }
      return;
    case State::kReserved:
      if (byte == 0x00) {
        state_ = State::kId;
      } else if (byte == kFf) {
        counters_.dropped_bytes += 3;  // FF FF FD FF: the last FF may start a header
        state_ = State::kHeader2;
      } else {
        // FF FF FD FD is a stuffed pattern, anything else a broken header (reserved byte must be 00).
        counters_.dropped_bytes += 4;
        state_ = State::kHeader1;
      }
      return;
    default:
      return;
  }
}

void Protocol2Parser::body_byte(uint8_t byte) noexcept {
  if (pattern_ == 3) {
    pattern_ = 0;
    if (byte == kFd) {
      return;  // the stuffing byte
    }
  }
  pattern_ = next_pattern(pattern_, byte);
  if (!have_instruction_) {
    packet_.instruction = byte;
    have_instruction_ = true;
    return;
  }
  packet_.params[packet_.param_count++] = byte;
}

Protocol2Parser::Result Protocol2Parser::push(uint8_t byte) noexcept {
  switch (state_) {
    case State::kHeader1:
    case State::kHeader2:
    case State::kHeader3:
    case State::kReserved:
      hunt(byte);
      return Result::kIncomplete;
    case State::kId:
      id_ = byte;
      state_ = State::kLengthLow;
      return Result::kIncomplete;
    case State::kLengthLow:
      length_low_ = byte;
      state_ = State::kLengthHigh;
      return Result::kIncomplete;
    case State::kLengthHigh: {
      length_ = static_cast<uint16_t>(length_low_ | (byte << 8));
      if (length_ < kLenOverhead || length_ > kP2MaxInstructionLength) {
        // Impossible LEN: drop FF FF FD 00 (none of them can start a header inside it) and hunt
        // again through ID, LEN_L and LEN_H, which may hold the start of the next header.
        ++counters_.bad_lengths;
        counters_.dropped_bytes += 4;
        state_ = State::kHeader1;
        hunt(id_);
        hunt(length_low_);
        hunt(byte);
        return Result::kIncomplete;
      }
      const uint8_t header[kP2HeaderBytes] = {kFf, kFf, kFd, 0x00, id_, length_low_, byte};
      crc_ = protocol2_crc(header, kP2HeaderBytes);
      packet_.protocol = Protocol::kV2;
      packet_.id = id_;
      packet_.instruction = 0;
      packet_.param_count = 0;
      have_instruction_ = false;
      pattern_ = 0;
      body_left_ = static_cast<uint16_t>(length_ - 2);
      state_ = State::kBody;
      return Result::kIncomplete;
    }
    case State::kBody:
      crc_ = crc_step(crc_, byte);
      body_byte(byte);
      if (--body_left_ == 0) {
        state_ = State::kCrcLow;
      }
      return Result::kIncomplete;
    case State::kCrcLow:
      crc_low_ = byte;
      state_ = State::kCrcHigh;
      return Result::kIncomplete;
    case State::kCrcHigh:
      packet_.wire_bytes = static_cast<uint16_t>(length_ + kP2HeaderBytes);
      detail::count_framed_packet(static_cast<uint16_t>(crc_low_ | (byte << 8)) == crc_, packet_, counters_);
      state_ = State::kHeader1;
      return Result::kPacket;
  }
  return Result::kIncomplete;
}

void Protocol2Parser::reset() noexcept {
  switch (state_) {
    case State::kHeader1:
      return;
    case State::kHeader2:
      counters_.dropped_bytes += 1;
      break;
    case State::kHeader3:
      counters_.dropped_bytes += 2;
      break;
    case State::kReserved:
      counters_.dropped_bytes += 3;
      break;
    default:
      ++counters_.timeouts;
      break;
  }
  state_ = State::kHeader1;
}

uint8_t Protocol2Parser::header_bytes() const noexcept {
  switch (state_) {
    case State::kHeader2:
      return 1;
    case State::kHeader3:
      return 2;
    case State::kReserved:
      return 3;
    default:
      return 0;
  }
}

void Protocol2Parser::release_header() noexcept {
  if (!in_packet()) {
    state_ = State::kHeader1;
  }
}

bool encode_protocol2_status(uint8_t id, uint8_t error, const uint8_t* params, std::size_t n,
                             StatusPacket& out) noexcept {
  const uint8_t lead[2] = {instruction::kStatus, error};
  const std::size_t size = encode_packet(id, lead, 2, params, n, out.bytes.data(), out.bytes.size());
  out.size = static_cast<uint16_t>(size);
  return size != 0;
}

std::size_t encode_protocol2_instruction(uint8_t id, uint8_t instruction_code, const uint8_t* params, std::size_t n,
                                         uint8_t* out, std::size_t capacity) noexcept {
  const uint8_t lead[1] = {instruction_code};
  return encode_packet(id, lead, 1, params, n, out, capacity);
}

bool encode_fast_block(bool first, uint32_t total_data_bytes, uint32_t devices, uint8_t error, uint8_t id,
                       const uint8_t* data, std::size_t n, StatusPacket& out) noexcept {
  out.size = 0;
  const uint64_t length = 1u + static_cast<uint64_t>(total_data_bytes) + 4u * static_cast<uint64_t>(devices);
  const std::size_t header = first ? kP2HeaderBytes + 1 : 0;
  if (length > 0xFFFF || header + n + 4 > out.bytes.size()) {
    return false;
  }
  auto& b = out.bytes;
  std::size_t pos = 0;
  if (first) {
    b[0] = kFf;
    b[1] = kFf;
    b[2] = kFd;
    b[3] = 0x00;
    b[4] = kFastStatusId;
    b[5] = static_cast<uint8_t>(length & 0xFF);
    b[6] = static_cast<uint8_t>(length >> 8);
    b[7] = instruction::kStatus;
    pos = header;
  }
  b[pos++] = error;
  b[pos++] = id;
  for (std::size_t i = 0; i < n; ++i) {
    b[pos++] = data[i];
  }
  b[pos++] = 0;
  b[pos++] = 0;
  out.size = static_cast<uint16_t>(pos);
  return true;
}

uint16_t seal_fast_block(StatusPacket& block, uint16_t running_crc) noexcept {
  if (block.size < 2) {
    return running_crc;
  }
  const std::size_t body = block.size - 2u;
  const uint16_t crc = protocol2_crc(block.bytes.data(), body, running_crc);
  block.bytes[body] = static_cast<uint8_t>(crc & 0xFF);
  block.bytes[body + 1] = static_cast<uint8_t>(crc >> 8);
  return protocol2_crc(&block.bytes[body], 2, crc);
}

}  // namespace doppel::dynamixel
