#pragma once
// A device on a Dynamixel bus (servo, IMU, foot board) as its firmware behaves: it sees every
// instruction packet on the wire, decides itself whether it is addressed (its ID, broadcast, its
// block in a SYNC WRITE / BULK READ), executes it and maybe answers. Timing is not its business:
// it reports *when in the reply order* it transmits, and the bus layer turns that into time.

#include <cstdint>
#include <span>
#include <string>
#include <string_view>

#include "dynamixel/packet.h"

namespace doppel::dynamixel {

// When a device's status goes on the wire.
enum class ReplyTiming : uint8_t {
  kAfterInstruction,  // Return Delay Time after the instruction's last byte
  kAfterPrevious,     // after the status of the device at chain_position - 1 has ended (BULK READ chain)
  // Protocol 2.0 broadcast PING: answers go out in ascending ID order, each after the previous
  // one plus a 3 ms slot for every unused ID in between (the slot scheme of ROBOTIS' slave
  // firmware; chain_position is not used, BusDevices orders by ID).
  kIdOrder,
  // One block of the single combined status of a P2 FAST SYNC/BULK READ: block 0 (it carries the
  // header) answers like kAfterInstruction, block k follows block k - 1 without a gap; BusDevices
  // fills in the running CRC of every block.
  kFastBlock,
};

struct Response {
  bool transmits = false;                              // false: the device stays silent
  ReplyTiming timing = ReplyTiming::kAfterInstruction;  // see ReplyTiming
  uint16_t chain_position = 0;                         // kAfterPrevious: index in the instruction's device list
  StatusPacket status;                                 // the bytes it sends when transmits
};

class Device {
 public:
  virtual ~Device() = default;

  virtual Protocol protocol() const noexcept = 0;
  virtual uint8_t id() const noexcept = 0;                 // current ID register
  virtual uint32_t baud_bps() const noexcept = 0;          // rate its UART listens at, from its Baud Rate register
  virtual uint32_t return_delay_us() const noexcept = 0;   // Return Delay Time register in µs (2 µs per unit)
  virtual std::string_view model_name() const noexcept = 0;  // its registry name (model_registry.h)
  virtual uint16_t model_number() const noexcept = 0;

  // Reacts to one instruction packet seen on the bus and fills `response` (response.transmits is
  // false on entry). rt-safe: no allocation, no lock, no exception.
  virtual void handle(const InstructionPacket& packet, Response& response) noexcept = 0;

  // The bytes the device keeps across a power cycle (its EEPROM area, from address 0), as stored
  // now; empty for a device that keeps none. The gateway saves them in its state directory.
  // rt-safe; read it on the bus thread (or while the bus thread is stopped).
  virtual std::span<const uint8_t> eeprom() const noexcept { return {}; }
  // Setup: loads a saved EEPROM area (the size of eeprom()) and powers the device on again with it.
  // Returns "" or why `bytes` cannot be this device's EEPROM (a read-only byte that differs from the
  // model's, a value outside its item's range, a wrong size); the device is unchanged then.
  virtual std::string restore_eeprom(std::span<const uint8_t> bytes);
  // Setup: writes `value` into the item that starts at `address`, as a WRITE from the host would,
  // the firmware's checks included (its EEPROM rules too). Returns "" or why the firmware refuses.
  virtual std::string write_item(uint16_t address, int64_t value);
};

}  // namespace doppel::dynamixel
