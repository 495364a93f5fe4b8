#pragma once
// What the analyzer needs to know about one recorded instruction packet: its kind ("P2 SYNC
// READ"), the devices it addresses and how many bytes each is asked for, a signature that is equal
// for repetitions of the same request (written data left out), and the same packet re-encoded for
// a subset of its devices (the "spread over N buses" what-if). Built on dynamixel's parsers and
// encoders, so the byte counts are the protocol's packet layout, stuffing included. Not for the
// real-time path: it allocates.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

namespace doppel::analyzer {

// USB2AX's own SYNC READ (Protocol 1.0, answered by the adapter, dynamixel/usb2ax.h).
inline constexpr uint8_t kUsb2axSyncRead = 0x84;

struct Instruction {
  bool framed = false;           // the bytes held exactly one whole packet of the protocol
  uint32_t protocol = 0;         // 1 or 2
  uint8_t id = 0;                // target ID (0xFE broadcast)
  uint8_t code = 0;              // instruction code (dynamixel::instruction)
  std::vector<uint8_t> params;   // parameters, unstuffed
};

// One device a multi-device instruction addresses, in packet order.
struct Addressed {
  uint8_t id = 0;
  uint16_t read_bytes = 0;  // bytes it is asked to read (0 for writes)
};

// Decodes `bytes` as one `protocol` (1 or 2) instruction packet. framed = false when they are not
// exactly one packet (the checksum is not checked: a packet with a bad one is still a packet).
Instruction decode_instruction(uint32_t protocol, std::span<const uint8_t> bytes);

// "P2 SYNC READ", "P1 BULK READ", "P1 SYNC READ (USB2AX)", "P2 0x77" for an unknown code.
std::string kind_name(uint32_t protocol, uint8_t code);

// True for SYNC READ/WRITE, BULK READ/WRITE, FAST SYNC/BULK READ and the USB2AX SYNC READ: one
// packet carrying a list of devices.
bool is_multi_device(uint32_t protocol, uint8_t code);
// True for the instructions whose answers are data: PING, READ and the multi-device reads.
bool is_read(uint32_t protocol, uint8_t code);
// FAST SYNC READ / FAST BULK READ: one combined status whose blocks follow each other.
bool is_fast_read(uint32_t protocol, uint8_t code);

// The devices a multi-device instruction addresses (empty when its parameters do not parse, or it
// is not one).
std::vector<Addressed> addressed_devices(const Instruction& instruction);

// Equal for repetitions of the same request: protocol, code, ID and the parameters, with the data
// of WRITE, REG WRITE, SYNC WRITE and BULK WRITE left out (their addresses, lengths and IDs kept).
std::string signature(const Instruction& instruction);

// The wire bytes of `instruction` (multi-device) for only the devices `keep` accepts, re-encoded
// with the protocol's layout; empty when it keeps none (or the parameters do not parse).
std::vector<uint8_t> encode_subset(const Instruction& instruction, const std::function<bool(uint8_t)>& keep);

// Bytes of the header a P2 FAST SYNC/BULK READ status carries in front of its first block
// (FF FF FD 00 FE LEN_L LEN_H 55).
inline constexpr std::size_t kFastStatusHeaderBytes = 8;

}  // namespace doppel::analyzer
