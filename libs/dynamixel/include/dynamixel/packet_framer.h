#pragma once
// Frames the instruction packets of one bus on which Protocol 1.0 and 2.0 packets may both travel
// (reference §1.1, §2.1). It hunts for both headers at once: `FF FF FD 00` starts a Protocol 2.0
// packet (P1 has no LEN 0), any other `FF FF ID` a Protocol 1.0 packet (ID 0xFD included), and hands
// the packet's bytes to that protocol's parser until the packet is complete or rejected. A packet's
// body is never searched for headers, so parameters that happen to look like a packet of the other
// protocol are not framed. Pure logic; the bus layer applies each protocol's inter-byte timeout.

#include <cstdint>

#include "dynamixel/packet.h"
#include "dynamixel/protocol1.h"
#include "dynamixel/protocol2.h"

namespace doppel::dynamixel {

class PacketFramer {
 public:
  enum class Result : uint8_t { kIncomplete, kPacket };

  // Consumes one byte. kPacket: packet() holds a complete packet of either protocol. rt-safe.
  Result push(uint8_t byte) noexcept;
  // The last complete packet (packet().protocol tells which); valid until the next push().
  const InstructionPacket& packet() const noexcept;

  // Drops a partial packet (inter-byte timeout, reopened port). rt-safe.
  void reset() noexcept;
  // True when nothing is buffered.
  bool idle() const noexcept { return active_ == Active::kNone && prefix_ == 0; }
  // True while a Protocol 2.0 packet (or a header that may become one) is being received: the
  // bus then applies P2's 1.5 ms inter-byte timeout instead of P1's 100 ms.
  bool receiving_protocol2() const noexcept { return active_ == Active::kV2 || prefix_ == 3; }

  // Both parsers' counters added up, plus the bytes dropped while hunting. rt-safe.
  ParserCounters counters() const noexcept;

 private:
  enum class Active : uint8_t { kNone, kV1, kV2 };
  Result feed_active(uint8_t byte) noexcept;

  Protocol1Parser p1_;
  Protocol2Parser p2_;
  Active active_ = Active::kNone;
  Active last_ = Active::kV1;  // protocol of the last complete packet
  uint8_t prefix_ = 0;         // header bytes seen while hunting: FF, FF FF, FF FF FD
  uint64_t dropped_ = 0;
};

}  // namespace doppel::dynamixel
