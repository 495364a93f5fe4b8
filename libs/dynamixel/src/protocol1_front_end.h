#pragma once
// The Protocol 1.0 firmware, written once for every device that speaks it: Protocol1Device (AX, RX,
// MX, FUmanoid boards) and an X or MX(2.0) servo that Protocol Type (13) = 1 switched to Protocol 1.0.
// It holds the instruction set of reference §1.2 with the broadcast, Status Return Level, checksum
// and REG_WRITE/ACTION rules and the P1 error bits of §1.4; the device behind it is a register file
// reached through one-byte addresses (Protocol1RegisterFile). Private to doppel_dynamixel.

#include <cstddef>
#include <cstdint>

#include "dynamixel/device.h"
#include "dynamixel/packet.h"
#include "dynamixel/protocol1_device.h"

namespace doppel::dynamixel::detail {

// Whether a status goes back under Status Return Level `level` (both protocols): PING always, an
// instruction that `reads` from level 1, every other instruction from level 2. rt-safe.
constexpr bool status_returned(uint8_t level, uint8_t instruction_code, bool reads) noexcept {
  return instruction_code == instruction::kPing || level >= (reads ? 1 : 2);
}

// Executes a Protocol 1.0 `packet` on `device` as the firmware does, counts it in the device's
// `counters` and fills `response` (silent for packets of another protocol). rt-safe.
void handle_protocol1(Protocol1RegisterFile& device, DeviceCounters& counters, const InstructionPacket& packet,
                      Response& response) noexcept;

}  // namespace doppel::dynamixel::detail
