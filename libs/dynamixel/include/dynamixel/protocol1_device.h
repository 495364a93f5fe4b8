#pragma once
// The Protocol 1.0 firmware core shared by every Doppel device model: a control table laid out by a
// ModelSpec with its Lock and range rules, served by the Protocol 1.0 front end that X servos in
// Protocol Type 1 share (PING, READ, WRITE, REG_WRITE, ACTION, RESET, SYNC WRITE, BULK READ with
// broadcast, Status Return Level and error-bit rules, reference §1).
// It is not a servo or a sensor: Protocol1Servo and the FUmanoid boards derive from it and add
// their value rules and the link to the simulation. Every behaviour choice is listed in docs/devices.md.

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>

#include "dynamixel/control_table.h"
#include "dynamixel/device.h"
#include "dynamixel/models.h"

namespace doppel::dynamixel {

// Per-device diagnostics (plain integers, written only by the bus thread).
struct DeviceCounters {
  // packets addressed to this device: own ID or broadcast; a SYNC / BULK instruction only where it lists the device
  uint64_t handled = 0;
  uint64_t bad_checksums = 0;   // of those, with a wrong checksum (not executed)
  uint64_t errors = 0;          // of those, answered or dropped with an instruction/range/angle error
};

// A REG WRITE held until ACTION (either protocol): bytes already validated for one address range.
struct HeldWrite {
  bool held = false;                                  // a REG WRITE waits for ACTION
  uint16_t address = 0;                               // address of the first byte
  uint16_t size = 0;                                  // bytes held
  std::array<uint8_t, kMaxInstructionParams> data{};  // the bytes, data[0] for `address`

  void hold(uint16_t start, const uint8_t* bytes, std::size_t n) noexcept {
    held = true;
    address = start;
    size = static_cast<uint16_t>(n);
    std::copy_n(bytes, n, data.begin());
  }
};

// What the Protocol 1.0 front end needs from the device whose control table it serves: a
// Protocol1Device is one, an X servo in Protocol Type 1 lends it its table. Error results are P1
// error bits (p1_error); every call is rt-safe.
class Protocol1RegisterFile {
 public:
  virtual uint8_t id() const noexcept = 0;
  // The Status Return Level lets a status go back for `instruction`.
  virtual bool answers(uint8_t instruction) const noexcept = 0;
  // The firmware knows BULK READ (0x92).
  virtual bool has_bulk_read() const noexcept = 0;
  // The `length` bytes at `start` as the host reads them; nullptr when not all of them exist.
  virtual const uint8_t* read(uint8_t start, uint8_t length) noexcept = 0;
  // Validates n bytes at `start` as one write (all or nothing) and with `commit` applies them.
  // `start` is above 255 only for a REG WRITE held from Protocol 2.0.
  virtual uint8_t write(uint16_t start, const uint8_t* data, std::size_t n, bool commit) noexcept = 0;
  // The REG WRITE store, and the Registered register that shows whether it holds one.
  virtual HeldWrite& held_write() noexcept = 0;
  virtual void set_registered(bool registered) noexcept = 0;
  // RESET: every register to its factory default, then the device reboots.
  virtual void factory_reset() noexcept = 0;
  // Overload, overheating and input voltage bits every status carries besides the instruction's own.
  virtual uint8_t condition_bits() const noexcept = 0;
  // Called for every executed packet that concerns the device (the Bus Watchdog of an X servo).
  virtual void on_communication() noexcept {}

 protected:
  ~Protocol1RegisterFile() = default;
};

class Protocol1Device : public Device, private Protocol1RegisterFile {
 public:
  using Table = std::array<uint8_t, 256>;  // one byte per P1 address; undefined bytes stay 0

  Protocol protocol() const noexcept override { return Protocol::kV1; }
  uint8_t id() const noexcept override { return table_[p1::kId]; }
  // From the Baud Rate register (reference §3.2).
  uint32_t baud_bps() const noexcept override;
  // Return Delay Time register x 2 µs.
  uint32_t return_delay_us() const noexcept override { return 2u * table_[p1::kReturnDelayTime]; }
  std::string_view model_name() const noexcept override { return spec_.name; }
  uint16_t model_number() const noexcept override { return spec_.model_number; }
  // Executes `packet` as the firmware does and fills `response`. rt-safe.
  void handle(const InstructionPacket& packet, Response& response) noexcept override;
  // Addresses 0 up to the end of the last EEPROM register.
  std::span<const uint8_t> eeprom() const noexcept override { return {table_.data(), eeprom_bytes_}; }
  // Read-only EEPROM registers must hold the model's values, the others values within their range;
  // then RAM gets its power-on values (after_factory_reset()).
  std::string restore_eeprom(std::span<const uint8_t> bytes) override;
  std::string write_item(uint16_t address, int64_t value) override;

  // Its supply was switched off and on (a sub-controller's Dynamixel Power): RAM to its power-on
  // values as at RESET's reboot (after_factory_reset()), EEPROM kept. rt-safe.
  void power_cycle() noexcept {
    load_defaults(true);
    after_factory_reset();
  }

  const ModelSpec& spec() const noexcept { return spec_; }
  // Unsigned value of the register that starts at `address` (1 or 2 bytes, little-endian);
  // 0 when no register starts there. rt-safe.
  uint16_t register_raw(uint8_t address) const noexcept;
  // The control table bytes 0..spec().table_bytes-1 (reserved bytes read 0).
  std::span<const uint8_t> table() const noexcept { return {table_.data(), spec_.table_bytes}; }
  // Lock (47) is 1: only addresses 24..35 accept writes until the device is rebuilt (power cycle).
  // Models without a Lock register (CM-730: byte 47 is ACC_Y) are never locked.
  bool locked() const noexcept { return has_lock_ && table_[p1::kLock] != 0; }
  const DeviceCounters& counters() const noexcept { return counters_; }

 protected:
  // Loads the factory defaults of `spec`, then the given ID, Baud Rate and Return Delay Time
  // registers. Throws std::invalid_argument when a value is outside its register's range.
  Protocol1Device(const ModelSpec& spec, uint8_t id, uint8_t baud_raw, uint8_t return_delay_raw);

  // Condition bits (overload, overheating, input voltage) every status reports besides the
  // instruction's own errors.
  uint8_t condition_bits() const noexcept override { return 0; }
  // Model-specific checks of a write, run on `candidate` (the table as it would be after writing
  // [start, start + n)). Returns error bits; non-zero rejects the whole write.
  virtual uint8_t check_write(const Table& candidate, uint8_t start, std::size_t n) const noexcept;
  // Called after RESET has restored the factory defaults (the device reboots), and after a saved
  // EEPROM area was restored at power-on.
  virtual void after_factory_reset() noexcept {}
  // Side effects of a committed write of [start, start + n) (the firmware's own register updates).
  virtual void after_write(uint8_t start, std::size_t n) noexcept;

  // Sets a register without any check (the device's own updates of read-only values).
  void set_register(uint8_t address, uint16_t value) noexcept;
  static uint16_t read_le(const Table& table, uint8_t address, uint8_t size) noexcept;
  static bool touches(uint8_t start, std::size_t n, uint8_t address, uint8_t size) noexcept {
    return start < address + size && address < start + n;
  }
  // Restores every register (or only the RAM area) to its factory default and forgets a pending
  // REG_WRITE.
  void load_defaults(bool ram_only = false) noexcept;

 private:
  // The register file of the Protocol 1.0 front end (Protocol1RegisterFile).
  bool answers(uint8_t instruction) const noexcept override;
  bool has_bulk_read() const noexcept override { return spec_.bulk_read; }
  const uint8_t* read(uint8_t start, uint8_t length) noexcept override;
  uint8_t write(uint16_t start, const uint8_t* data, std::size_t n, bool commit) noexcept override;
  HeldWrite& held_write() noexcept override { return held_write_; }
  // Only models with a Registered register (44) show it (CM-730: byte 44 is ACC_X).
  void set_registered(bool registered) noexcept override {
    if (has_registered_) {
      table_[p1::kRegistered] = registered ? 1 : 0;
    }
  }
  void factory_reset() noexcept override;

  const ModelSpec& spec_;
  std::size_t eeprom_bytes_ = 0;  // addresses 0..eeprom_bytes_-1 are the EEPROM area
  Table table_{};
  Table owner_{};  // index + 1 into spec_.registers of the register covering each byte; 0 = none
  HeldWrite held_write_{};
  DeviceCounters counters_{};
  bool has_lock_ = false;        // a one-byte register "Lock" at 47
  bool has_registered_ = false;  // a one-byte register "Registered" at 44
};

}  // namespace doppel::dynamixel
