#pragma once
// The Protocol 1.0 firmware, written once for every device that speaks it: Protocol1Device (AX, RX,
// MX, FUmanoid boards) and an X or MX(2.0) servo that Protocol Type (13) = 1 switched to Protocol 1.0.
// It holds the instruction set of reference §1.2 with the broadcast, Status Return Level, checksum
// and REG_WRITE/ACTION rules and the P1 error bits of §1.4; the device behind it is a register file
// reached through one-byte addresses. Private to doppel_dynamixel.

#include <array>
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

// What the front end needs from the device whose control table it serves. Every error result is a
// set of P1 error bits (p1_error); every call is rt-safe.
class Protocol1RegisterFile {
 public:
  virtual uint8_t id() const noexcept = 0;
  // The device's Status Return Level lets a status go back for `instruction` (status_returned).
  virtual bool answers(uint8_t instruction) const noexcept = 0;
  // The firmware knows BULK READ (0x92).
  virtual bool has_bulk_read() const noexcept = 0;
  // The `length` bytes at `start` as the host reads them; nullptr when not all of them exist.
  virtual const uint8_t* read(uint8_t start, uint8_t length) noexcept = 0;
  // Validates the n bytes at `start` as one write (all or nothing) and, with `commit`, applies them.
  // `start` is above 255 only for a REG WRITE held from Protocol 2.0.
  virtual uint8_t write(uint16_t start, const uint8_t* data, std::size_t n, bool commit) noexcept = 0;
  // The device's REG WRITE store (shared with its Protocol 2.0 firmware, if it has one).
  virtual HeldWrite& held_write() noexcept = 0;
  // Sets the Registered (Instruction) register to 1 or 0.
  virtual void set_registered(bool registered) noexcept = 0;
  // RESET: every register to its factory default, then the device reboots.
  virtual void factory_reset() noexcept = 0;
  // Overload, overheating and input voltage bits every status carries besides the instruction's own.
  virtual uint8_t condition_bits() const noexcept = 0;
  // Called for every executed packet that concerns the device (the Bus Watchdog of an X servo).
  virtual void on_communication() noexcept {}
  virtual DeviceCounters& counters() noexcept = 0;

 protected:
  ~Protocol1RegisterFile() = default;
};

// Executes a Protocol 1.0 `packet` on `device` as the firmware does and fills `response` (silent
// for packets of another protocol). rt-safe.
void handle_protocol1(Protocol1RegisterFile& device, const InstructionPacket& packet, Response& response) noexcept;

}  // namespace doppel::dynamixel::detail
