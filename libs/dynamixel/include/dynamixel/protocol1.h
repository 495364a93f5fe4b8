#pragma once
// Protocol 1.0 framing (reference §1.1): a push parser that takes bytes in any chunking and
// resynchronises after garbage, and encoders for status and instruction packets.
// The parser frames like servo firmware: it hunts for FF FF, takes LEN bytes, and reports a
// packet whose checksum does not match as such (the device decides whether to answer it).

#include <cstddef>
#include <cstdint>

#include "dynamixel/packet.h"

namespace doppel::dynamixel {

// ~(sum of bytes) & 0xFF over ID, LEN, INST/ERR and parameters.
uint8_t protocol1_checksum(const uint8_t* bytes, std::size_t n) noexcept;

struct ParserCounters {
  uint64_t packets = 0;         // packets framed (good or bad checksum)
  uint64_t bad_checksums = 0;   // of those, with a wrong checksum / CRC
  uint64_t dropped_bytes = 0;   // bytes discarded while hunting for a header
  uint64_t bad_lengths = 0;     // headers rejected for an impossible LEN
  uint64_t timeouts = 0;        // partial packets dropped by reset() (inter-byte timeout, reopen)
};

class Protocol1Parser {
 public:
  enum class Result : uint8_t { kIncomplete, kPacket };

  // Consumes one byte. kPacket: packet() holds a complete packet (check packet().checksum_ok).
  // rt-safe.
  Result push(uint8_t byte) noexcept;

  // The last complete packet; valid until the next push().
  const InstructionPacket& packet() const noexcept { return packet_; }

  // Drops a partial packet (the device's 100 ms inter-byte timeout, or the port was reopened).
  void reset() noexcept;
  // True when no partial packet is buffered.
  bool idle() const noexcept;

  const ParserCounters& counters() const noexcept { return counters_; }

 private:
  enum class State : uint8_t { kHeader1, kHeader2, kId, kLength, kInstruction, kParams, kChecksum };
  State state_ = State::kHeader1;
  uint8_t length_ = 0;
  uint8_t sum_ = 0;
  InstructionPacket packet_{};
  ParserCounters counters_{};
};

// Writes `FF FF ID LEN ERR params CKSUM` into `out`. Returns false (and leaves out.size 0) when
// params do not fit a P1 packet (n > 253).
bool encode_protocol1_status(uint8_t id, uint8_t error, const uint8_t* params, std::size_t n,
                             StatusPacket& out) noexcept;

// Writes `FF FF ID LEN INST params CKSUM` into `out` (capacity `capacity`); returns bytes written,
// or 0 if it does not fit. For Doppel's own tools and benchmarks; tests of Doppel use golden bytes.
std::size_t encode_protocol1_instruction(uint8_t id, uint8_t instruction, const uint8_t* params,
                                         std::size_t n, uint8_t* out, std::size_t capacity) noexcept;

}  // namespace doppel::dynamixel
