#pragma once
// Protocol 2.0 framing (reference §2.1-2.3, §2.7): the CRC-16, byte stuffing, a push parser that
// frames instruction packets from bytes in any chunking and resynchronises after garbage, and
// encoders for status packets (stuffed), instruction packets (for Doppel's own tools) and the
// blocks of the single combined status of FAST SYNC READ / FAST BULK READ.
// Like servo firmware the parser frames by LEN and reports a packet with a wrong CRC as such;
// the device decides whether to answer it. It is not a device and knows no control table.

#include <cstddef>
#include <cstdint>

#include "dynamixel/packet.h"
#include "dynamixel/protocol1.h"

namespace doppel::dynamixel {

// Error numbers of a Protocol 2.0 status (reference §2.5): bits 6..0 hold one number, bit 7 the Alert.
namespace p2_error {
inline constexpr uint8_t kResultFail = 0x01;   // could not process (CLEAR while moving, BACKUP with torque on)
inline constexpr uint8_t kInstruction = 0x02;  // undefined instruction, ACTION without REG WRITE
inline constexpr uint8_t kCrc = 0x03;          // instruction packet CRC mismatch
inline constexpr uint8_t kDataRange = 0x04;    // value outside the item's range
inline constexpr uint8_t kDataLength = 0x05;   // write shorter than the item, malformed parameter count
inline constexpr uint8_t kDataLimit = 0x06;    // value outside the configured limit item
inline constexpr uint8_t kAccess = 0x07;       // read-only/undefined address, EEPROM while torque is on
inline constexpr uint8_t kAlert = 0x80;        // the device has a hardware error (Hardware Error Status)
}  // namespace p2_error

// Header `FF FF FD 00`, ID, LEN_L, LEN_H: bytes before the instruction / 0x55.
inline constexpr std::size_t kP2HeaderBytes = 7;
// The largest LEN Doppel's devices accept: INST + kMaxInstructionParams stuffed bytes + CRC.
inline constexpr uint16_t kP2MaxInstructionLength = kMaxInstructionParams + 3;

// CRC-16 of reference §2.2 (polynomial 0x8005, initial 0, MSB first, no final XOR) over `n`
// bytes, continuing from `crc` (pass the previous result to extend a running CRC). rt-safe.
uint16_t protocol2_crc(const uint8_t* bytes, std::size_t n, uint16_t crc = 0) noexcept;

// Copies `n` bytes to `out` and appends an extra FD after every FF FF FD (reference §2.3).
// Returns the bytes written, or 0 when they would exceed `capacity`. rt-safe.
std::size_t protocol2_stuff(const uint8_t* in, std::size_t n, uint8_t* out, std::size_t capacity) noexcept;
// Removes the FD that follows every FF FF FD. Returns the bytes written (<= n); `out` may equal
// `in`. rt-safe.
std::size_t protocol2_unstuff(const uint8_t* in, std::size_t n, uint8_t* out) noexcept;

class Protocol2Parser {
 public:
  enum class Result : uint8_t { kIncomplete, kPacket };

  // Consumes one byte. kPacket: packet() holds a complete packet, parameters unstuffed (check
  // packet().checksum_ok for the CRC). rt-safe.
  Result push(uint8_t byte) noexcept;

  // The last complete packet; valid until the next push().
  const InstructionPacket& packet() const noexcept { return packet_; }

  // Drops a partial packet (the 1.5 ms inter-byte timeout, or the port was reopened). rt-safe.
  void reset() noexcept;
  // True when no partial packet (and no partial header) is buffered.
  bool idle() const noexcept { return state_ == State::kHeader1; }
  // True once a full header `FF FF FD 00` has been seen and the packet is being received.
  bool in_packet() const noexcept { return state_ >= State::kId; }
  // While hunting: how many bytes of a possible header (FF, FF FF, FF FF FD) are held (0..3).
  uint8_t header_bytes() const noexcept;
  // Forgets held header bytes without counting them (a caller that keeps hunting itself). rt-safe.
  void release_header() noexcept;

  const ParserCounters& counters() const noexcept { return counters_; }

 private:
  enum class State : uint8_t { kHeader1, kHeader2, kHeader3, kReserved, kId, kLengthLow, kLengthHigh, kBody, kCrcLow, kCrcHigh };
  void hunt(uint8_t byte) noexcept;
  void body_byte(uint8_t byte) noexcept;

  State state_ = State::kHeader1;
  uint16_t length_ = 0;      // LEN field
  uint16_t body_left_ = 0;   // INST + stuffed parameter bytes still to come
  uint16_t crc_ = 0;         // running CRC over the raw bytes so far
  uint8_t crc_low_ = 0;
  uint8_t pattern_ = 0;      // unstuffing: how much of FF FF FD ends the unstuffed output (0..3)
  bool have_instruction_ = false;
  uint8_t id_ = 0;
  uint8_t length_low_ = 0;
  InstructionPacket packet_{};
  ParserCounters counters_{};
};

// Writes `FF FF FD 00 ID LEN 55 ERR params CRC` into `out`, byte-stuffed. Returns false (and
// leaves out.size 0) when the packet does not fit a StatusPacket. rt-safe.
bool encode_protocol2_status(uint8_t id, uint8_t error, const uint8_t* params, std::size_t n,
                             StatusPacket& out) noexcept;

// Writes a stuffed instruction packet into `out` (capacity `capacity`); returns the bytes
// written, or 0 if it does not fit. For Doppel's own tools and benchmarks; tests of Doppel use
// golden bytes. rt-safe.
std::size_t encode_protocol2_instruction(uint8_t id, uint8_t instruction, const uint8_t* params, std::size_t n,
                                         uint8_t* out, std::size_t capacity) noexcept;

// FAST SYNC READ / FAST BULK READ (reference §2.7): one status with ID 0xFE, never stuffed, one
// block `ERR ID data CRC_L CRC_H` per device in request order, each CRC the running CRC of the
// whole packet up to that block's data. Devices write their block with the CRC left 0 (the first
// one after the 8-byte header `FF FF FD 00 FE LEN_L LEN_H 55`); seal_fast_block() fills the CRC.
//
// `total_data_bytes` = sum of the requested lengths, `devices` = number of blocks:
// LEN = 1 + total_data_bytes + 4 * devices. rt-safe.
bool encode_fast_block(bool first, uint32_t total_data_bytes, uint32_t devices, uint8_t error, uint8_t id,
                       const uint8_t* data, std::size_t n, StatusPacket& out) noexcept;
// Extends `running_crc` over `block` (all but its last two bytes), stores the result in those
// two bytes (low first) and returns the CRC continued over them, for the next block. rt-safe.
uint16_t seal_fast_block(StatusPacket& block, uint16_t running_crc) noexcept;

}  // namespace doppel::dynamixel
