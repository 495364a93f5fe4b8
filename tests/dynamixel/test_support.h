#pragma once
// Helpers for the dynamixel tests: golden instruction bytes go through the parser, and the device's
// status comes back as bytes to compare with hand-built expectations.

#include <gtest/gtest.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <vector>

#include "dynamixel/device.h"
#include "dynamixel/protocol1.h"
#include "dynamixel/protocol2.h"

namespace doppel::dynamixel::testing {

using Bytes = std::vector<uint8_t>;

// Every packet a parser framed from a byte stream, and its counters.
struct Parsed {
  std::vector<InstructionPacket> packets;
  ParserCounters counters;
};

// Feeds `bytes` to a fresh `Parser` (Protocol1Parser or Protocol2Parser) in chunks of `chunk` bytes
// (a chunk is a loop of push calls, as the bus layer does after each read()).
template <class Parser>
Parsed parse_all(const Bytes& bytes, std::size_t chunk = 1) {
  Parser sut;
  Parsed result;
  for (std::size_t start = 0; start < bytes.size(); start += chunk) {
    for (std::size_t i = start; i < std::min(bytes.size(), start + chunk); ++i) {
      if (sut.push(bytes[i]) == Parser::Result::kPacket) {
        result.packets.push_back(sut.packet());
      }
    }
  }
  result.counters = sut.counters();
  return result;
}

// The first packet `Framer` (Protocol2Parser, PacketFramer, ...) frames from `wire`; a test failure
// when none frames.
template <class Framer>
InstructionPacket frame_one(const Bytes& wire) {
  Framer framer;
  for (uint8_t b : wire) {
    if (framer.push(b) == Framer::Result::kPacket) {
      return framer.packet();
    }
  }
  ADD_FAILURE() << "packet did not frame";
  return {};
}

inline Bytes params_of(const InstructionPacket& p) { return Bytes(p.params.begin(), p.params.begin() + p.param_count); }

// The low `n` bytes of `v`, little-endian (the byte order of every multi-byte register).
inline Bytes le(int64_t v, int n) {
  Bytes b;
  for (int i = 0; i < n; ++i) {
    b.push_back(static_cast<uint8_t>((static_cast<uint64_t>(v) >> (8 * i)) & 0xFF));
  }
  return b;
}

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

// The same for Protocol 2.0 devices: wire bytes go through Protocol2Parser.
namespace doppel::dynamixel::testing::p2 {

inline InstructionPacket parse(const Bytes& wire) { return frame_one<Protocol2Parser>(wire); }

inline Bytes transact(Device& device, const Bytes& wire) { return testing::transact(device, parse(wire)); }

// An instruction as Doppel's encoder frames it (stuffed, reference §2.1-2.3).
inline Bytes instruction(uint8_t id, uint8_t inst, const Bytes& params = {}) {
  uint8_t out[1500];
  const std::size_t n = encode_protocol2_instruction(id, inst, params.data(), params.size(), out, sizeof out);
  return Bytes(out, out + n);
}

// A packet as §2.1 frames it around `body` (instruction or 0x55, error, params), CRC of §2.2, written
// from the reference; no stuffing, so only for bodies without FF FF FD.
inline Bytes frame(uint8_t id, const Bytes& body) {
  Bytes b = {0xFF, 0xFF, 0xFD, 0x00, id, static_cast<uint8_t>(body.size() + 2), 0x00};
  b.insert(b.end(), body.begin(), body.end());
  const uint16_t crc = protocol2_crc(b.data(), b.size());
  b.push_back(static_cast<uint8_t>(crc & 0xFF));
  b.push_back(static_cast<uint8_t>(crc >> 8));
  return b;
}

// A status as §2.1 frames it (see frame()).
inline Bytes status(uint8_t id, uint8_t error, const Bytes& params = {}) {
  Bytes body = {0x55, error};
  body.insert(body.end(), params.begin(), params.end());
  return frame(id, body);
}

// WRITE parameters: the 2-byte address, then `value` in `size` bytes.
inline Bytes write_params(uint16_t address, int64_t value, int size) {
  Bytes p = le(address, 2);
  const Bytes v = le(value, size);
  p.insert(p.end(), v.begin(), v.end());
  return p;
}

}  // namespace doppel::dynamixel::testing::p2
