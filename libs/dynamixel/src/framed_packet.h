#pragma once
// Private helper of the Protocol 1.0 and 2.0 parsers (protocol1.cpp, protocol2.cpp): what both do
// when the last byte of a packet has arrived. Not part of the public API.

#include "dynamixel/packet.h"
#include "dynamixel/protocol1.h"

namespace doppel::dynamixel::detail {

// Marks `packet` complete with its checksum (P1) or CRC (P2) verdict and counts it in `counters`
// (packets, bad_checksums). rt-safe.
inline void count_framed_packet(bool checksum_ok, InstructionPacket& packet, ParserCounters& counters) noexcept {
  packet.checksum_ok = checksum_ok;
  ++counters.packets;
  if (!checksum_ok) {
    ++counters.bad_checksums;
  }
}

}  // namespace doppel::dynamixel::detail
