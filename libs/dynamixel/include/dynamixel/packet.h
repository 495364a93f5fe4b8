#pragma once
// Instruction and status packets as plain values, shared by Protocol 1.0 and 2.0.
// The codecs (protocol1.h, later protocol2.h) fill and emit these; devices only see them.
// Fixed capacity, so the real-time path never allocates for a packet.

#include <array>
#include <cstddef>
#include <cstdint>

namespace doppel::dynamixel {

enum class Protocol : uint8_t { kV1 = 1, kV2 = 2 };

inline constexpr uint8_t kBroadcastId = 0xFE;

// The largest parameter block accepted in one instruction packet. P1's LEN byte limits it to 253;
// P2 to what the SDK and firmware buffer (1024-byte packets).
inline constexpr std::size_t kMaxInstructionParams = 1024;
// The largest status packet a device emits (P2: 1024 data bytes plus framing, before stuffing growth).
inline constexpr std::size_t kMaxStatusBytes = 1400;

// Instruction codes, named as in the ROBOTIS e-Manual.
namespace instruction {
inline constexpr uint8_t kPing = 0x01;
inline constexpr uint8_t kRead = 0x02;
inline constexpr uint8_t kWrite = 0x03;
inline constexpr uint8_t kRegWrite = 0x04;
inline constexpr uint8_t kAction = 0x05;
inline constexpr uint8_t kFactoryReset = 0x06;
inline constexpr uint8_t kReboot = 0x08;
inline constexpr uint8_t kClear = 0x10;
inline constexpr uint8_t kControlTableBackup = 0x20;
inline constexpr uint8_t kStatus = 0x55;
inline constexpr uint8_t kSyncRead = 0x82;
inline constexpr uint8_t kSyncWrite = 0x83;
inline constexpr uint8_t kFastSyncRead = 0x8A;
inline constexpr uint8_t kBulkRead = 0x92;
inline constexpr uint8_t kBulkWrite = 0x93;
inline constexpr uint8_t kFastBulkRead = 0x9A;
}  // namespace instruction

// One instruction packet as a device's UART receives it.
struct InstructionPacket {
  Protocol protocol = Protocol::kV1;  // which framing carried it
  uint8_t id = 0;                     // target ID, kBroadcastId for all
  uint8_t instruction = 0;            // instruction code (namespace instruction)
  bool checksum_ok = true;            // false: framing was valid but the checksum / CRC was not
  uint16_t param_count = 0;           // number of valid bytes in params (after P2 unstuffing)
  uint16_t wire_bytes = 0;            // bytes it took on the wire: header to checksum, P2 stuffing included
  std::array<uint8_t, kMaxInstructionParams> params{};  // parameter bytes
};

// One status packet, byte-exact as it crosses the wire (header, stuffing and checksum included).
struct StatusPacket {
  uint16_t size = 0;                           // bytes used
  std::array<uint8_t, kMaxStatusBytes> bytes{};  // wire bytes
};

}  // namespace doppel::dynamixel
