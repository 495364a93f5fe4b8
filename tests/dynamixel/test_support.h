#pragma once
// Helpers for the dynamixel tests: golden instruction bytes go through the parser, and the device's
// status comes back as bytes to compare with hand-built expectations.

#include <cstdint>
#include <initializer_list>
#include <vector>

#include "dynamixel/device.h"
#include "dynamixel/protocol1.h"

namespace doppel::dynamixel::testing {

using Bytes = std::vector<uint8_t>;

// Parses exactly one instruction packet from `bytes` (must frame).
inline InstructionPacket parse_one(const Bytes& bytes) {
  Protocol1Parser parser;
  for (uint8_t b : bytes) {
    if (parser.push(b) == Protocol1Parser::Result::kPacket) {
      return parser.packet();
    }
  }
  return InstructionPacket{.protocol = Protocol::kV1, .id = 0, .instruction = 0xFF, .checksum_ok = false};
}

// Builds an instruction packet directly (for cases where the bytes themselves are not the point).
inline InstructionPacket make_packet(uint8_t id, uint8_t inst, std::initializer_list<uint8_t> params = {}) {
  InstructionPacket p;
  p.protocol = Protocol::kV1;
  p.id = id;
  p.instruction = inst;
  for (uint8_t b : params) {
    p.params[p.param_count++] = b;
  }
  return p;
}

inline Bytes status_bytes(const Response& r) {
  if (!r.transmits) {
    return {};
  }
  return Bytes(r.status.bytes.begin(), r.status.bytes.begin() + r.status.size);
}

// Feeds one packet to `device`; returns its status bytes (empty when it stays silent).
inline Bytes transact(Device& device, const InstructionPacket& packet) {
  Response r;
  device.handle(packet, r);
  return status_bytes(r);
}

inline Bytes transact(Device& device, const Bytes& wire) { return transact(device, parse_one(wire)); }

}  // namespace doppel::dynamixel::testing
