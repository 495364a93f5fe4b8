#pragma once
// The Protocol 2.0 firmware core of Doppel's X-series servos: a control table laid out by a
// P2ModelSpec (16-bit addresses, 1/2/4-byte items, indirect addressing) and every instruction of
// reference §2.4 - PING, READ, WRITE, REG WRITE, ACTION, FACTORY RESET, REBOOT, CLEAR, CONTROL TABLE
// BACKUP, SYNC READ/WRITE, FAST SYNC READ, BULK READ/WRITE, FAST BULK READ - with broadcast,
// Secondary ID, Status Return Level, error numbers 1..7 and the Alert bit (§2.5, §3.7).
// Protocol Type (13) = 1 switches the firmware to Protocol 1.0: it then answers Protocol 1.0
// packets (the instruction set of §1.2, one-byte addresses 0..255, the P1 error bits of §1.4) on
// the same control table through the front end Protocol1Device uses, and ignores Protocol 2.0
// packets, until 13 = 2 is written over P1 or a FACTORY RESET restores the default. The status of
// the write that switches goes out in the old protocol. FAST reads and CONTROL TABLE BACKUP exist
// only where the model's firmware has them.
// It is not a servo: Protocol2Servo adds the value rules that depend on the operating mode and the
// link to the simulation. Every behaviour choice is listed in docs/devices.md (Protocol 2.0 part).

#include <array>
#include <bitset>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>

#include "dynamixel/device.h"
#include "dynamixel/protocol1_device.h"
#include "dynamixel/protocol2.h"
#include "dynamixel/protocol2_models.h"

namespace doppel::dynamixel {

class Protocol2Device : public Device {
 public:
  static constexpr std::size_t kTableCapacity = 1024;  // bytes of control table storage
  static constexpr std::size_t kMaxItems = 256;        // items a model may define
  using Table = std::array<uint8_t, kTableCapacity>;
  using ItemSet = std::bitset<kMaxItems>;              // indexes into spec().registers

  // The protocol it speaks now: Protocol Type (13) 1 = Protocol 1.0, else 2.0.
  Protocol protocol() const noexcept override {
    return table_[x430::kProtocolType] == x430::kProtocolType1 ? Protocol::kV1 : Protocol::kV2;
  }
  uint8_t id() const noexcept override { return table_[x430::kId]; }
  // From the Baud Rate register (reference §3.3).
  uint32_t baud_bps() const noexcept override;
  // Return Delay Time register x 2 µs.
  uint32_t return_delay_us() const noexcept override { return 2u * table_[x430::kReturnDelayTime]; }
  std::string_view model_name() const noexcept override { return spec_.name; }
  uint16_t model_number() const noexcept override { return spec_.model_number; }
  // Executes `packet` as the firmware does and fills `response`. rt-safe.
  void handle(const InstructionPacket& packet, Response& response) noexcept override;
  // Addresses 0..63, the EEPROM area (Protocol Type included).
  std::span<const uint8_t> eeprom() const noexcept override { return {table_.data(), x430::kEepromEnd}; }
  // Read-only items must hold the model's values, the others values within their range; then the
  // device reboots (RAM to its power-on values).
  std::string restore_eeprom(std::span<const uint8_t> bytes) override;
  std::string write_item(uint16_t address, int64_t value) override;

  // Its supply was switched off and on (a sub-controller's Dynamixel Power): RAM to its power-on
  // values as after REBOOT, EEPROM kept. rt-safe.
  void power_cycle() noexcept { reboot(); }

  const P2ModelSpec& spec() const noexcept { return spec_; }
  // Value of the item that starts at `address` (sign-extended for signed items); 0 when no item
  // starts there. Reads the stored bytes (Indirect Data reads its own, not its target). rt-safe.
  int64_t register_value(uint16_t address) const noexcept;
  // The control table bytes 0..spec().table_bytes-1 as stored (reserved bytes 0).
  std::span<const uint8_t> table() const noexcept { return {table_.data(), spec_.table_bytes}; }
  bool torque_enabled() const noexcept { return table_[x430::kTorqueEnable] != 0; }
  // Hardware Error Status (70); non-zero means every status carries the Alert bit.
  uint8_t hardware_error() const noexcept { return table_[x430::kHardwareErrorStatus]; }
  // A CONTROL TABLE BACKUP is stored.
  bool has_backup() const noexcept { return has_backup_; }
  const DeviceCounters& counters() const noexcept { return counters_; }

 protected:
  // Loads the factory defaults of `spec`, then the given ID, Baud Rate and Return Delay Time.
  // Throws std::invalid_argument when a value is outside its item's range or the spec has no table.
  Protocol2Device(const P2ModelSpec& spec, uint8_t id, uint8_t baud_raw, uint8_t return_delay_raw);

  // Model rules of a write, run on `candidate` (the table as it would be afterwards) for the
  // items in `touched`. Returns an error number (p2_error), 0 to accept. Runs after the generic
  // access, length and range checks.
  virtual uint8_t check_write(const Table& candidate, const ItemSet& touched) const noexcept;
  // Side effects of a committed write (`before` is the table before it).
  virtual void after_write(const Table& before, const ItemSet& touched) noexcept;
  // RAM to power-on values after REBOOT, FACTORY RESET or a backup restore (EEPROM already set).
  virtual void reboot() noexcept;
  // CLEAR with option 0x01 (multi-turn reset); returns an error number.
  virtual uint8_t clear_multi_turn() noexcept { return p2_error::kInstruction; }
  // Called for every packet that concerns this device (own ID, broadcast, listed): Bus Watchdog.
  virtual void on_communication() noexcept {}

  // Index of the item containing `address` in spec().registers, -1 for none. rt-safe.
  int item_at(uint16_t address) const noexcept;
  bool touches(const ItemSet& touched, uint16_t address) const noexcept;
  // Value of the item at `address` in `table` (sign-extended for signed items). rt-safe.
  int64_t value_in(const Table& table, uint16_t address) const noexcept;
  // Sets an item without any check (the device's own updates of read-only values). rt-safe.
  void set_register(uint16_t address, int64_t value) noexcept;
  // Every item to its factory default; with `ram_only` only the RAM area. Forgets REG WRITE.
  void load_defaults(bool ram_only) noexcept;
  const Table& raw_table() const noexcept { return table_; }

 private:
  // Target of a host byte address: Indirect Data n -> Indirect Address n, else the address.
  uint16_t resolve(uint16_t address) const noexcept;
  uint8_t write(uint16_t start, const uint8_t* data, std::size_t n, bool commit, bool via_secondary) noexcept;
  // REG WRITE (either protocol): keeps n validated bytes for `start` until ACTION, Registered Instruction = 1.
  void hold_reg_write(uint16_t start, const uint8_t* data, std::size_t n) noexcept;
  // ACTION with a held REG WRITE: writes and forgets it; returns the write's error number.
  uint8_t apply_reg_write(bool via_secondary) noexcept;
  // Copies n bytes starting at `start` as the host sees them; false if outside the table.
  bool read(uint16_t start, std::size_t n, uint8_t* out) const noexcept;
  bool answers(uint8_t instruction) const noexcept;
  uint8_t error_byte(uint8_t error) const noexcept;
  void reply(uint8_t error, const uint8_t* data, std::size_t n, Response& response) noexcept;
  void handle_unicast(const InstructionPacket& packet, bool answer, bool via_secondary, Response& response) noexcept;
  // FACTORY RESET, REBOOT, CLEAR, CONTROL TABLE BACKUP: the error number of the parameters, 0 to go ahead.
  uint8_t maintenance_error(const InstructionPacket& packet) const noexcept;
  // Executes a checked FACTORY RESET, REBOOT or CONTROL TABLE BACKUP (its status has gone out).
  void run_maintenance(const InstructionPacket& packet) noexcept;
  void handle_sync_read(const InstructionPacket& packet, bool fast, Response& response) noexcept;
  void handle_bulk_read(const InstructionPacket& packet, bool fast, Response& response) noexcept;
  void handle_sync_write(const InstructionPacket& packet) noexcept;
  void handle_bulk_write(const InstructionPacket& packet) noexcept;
  void chain_reply(uint16_t position, bool fast, uint32_t total_data, uint32_t devices, uint16_t start,
                   uint16_t length, Response& response) noexcept;
  class Protocol1Registers;  // Protocol Type 1: this device as the register file of the Protocol 1.0 front end
  void handle_protocol1(const InstructionPacket& packet, Response& response) noexcept;

  const P2ModelSpec& spec_;
  Table table_{};
  uint8_t reply_id_ = 0;                         // ID when the current packet arrived
  std::array<int16_t, kTableCapacity> owner_{};  // item index per byte, -1 = reserved
  HeldWrite held_write_{};
  std::array<uint8_t, x430::kEepromEnd> backup_{};  // CONTROL TABLE BACKUP of the EEPROM area
  bool has_backup_ = false;
  std::array<uint8_t, kMaxInstructionParams> scratch_{};  // READ data
  DeviceCounters counters_{};
};

}  // namespace doppel::dynamixel
