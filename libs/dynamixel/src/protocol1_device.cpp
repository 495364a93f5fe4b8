#include "dynamixel/protocol1_device.h"

#include <algorithm>
#include <array>
#include <stdexcept>
#include <string>

#include "dynamixel/protocol1.h"

#include "protocol1_front_end.h"

namespace doppel::dynamixel {

namespace {

int32_t as_value(const RegisterSpec& r, uint16_t raw) noexcept {
  return r.is_signed && r.size == 2 ? static_cast<int32_t>(static_cast<int16_t>(raw)) : static_cast<int32_t>(raw);
}

}  // namespace

Protocol1Device::Protocol1Device(const ModelSpec& spec, uint8_t id, uint8_t baud_raw, uint8_t return_delay_raw)
    : spec_(spec) {
  if (spec.table_bytes == 0 || spec.table_bytes > table_.size() || spec.registers.size() >= 255) {
    throw std::invalid_argument("model " + std::string(spec.name) + " has no usable control table");
  }
  for (std::size_t i = 0; i < spec.registers.size(); ++i) {
    const RegisterSpec& r = spec.registers[i];
    for (uint8_t b = 0; b < r.size; ++b) {
      owner_[r.address + b] = static_cast<uint8_t>(i + 1);
    }
    if (r.area == Area::kEeprom) {
      eeprom_bytes_ = std::max<std::size_t>(eeprom_bytes_, std::size_t{r.address} + r.size);
    }
  }
  const auto one_byte_named = [&](uint8_t address, std::string_view name) {
    const RegisterSpec* r = find_register(spec.registers, address);
    return r != nullptr && r->address == address && r->size == 1 && r->name == name;
  };
  has_lock_ = one_byte_named(p1::kLock, "Lock");
  has_registered_ = one_byte_named(p1::kRegistered, "Registered");
  load_defaults();
  const auto check = [&](uint8_t address, uint8_t value, const char* what) {
    const RegisterSpec* r = find_register(spec.registers, address);
    if (r == nullptr || value < r->min_raw || value > r->max_raw) {
      throw std::invalid_argument(std::string(spec.name) + ": " + what + " " + std::to_string(value) +
                                  " is outside the register's range");
    }
    table_[address] = value;
  };
  check(p1::kId, id, "ID");
  check(p1::kBaudRate, baud_raw, "Baud Rate register value");
  check(p1::kReturnDelayTime, return_delay_raw, "Return Delay Time register value");
}

uint32_t Protocol1Device::baud_bps() const noexcept {
  return p1_baud_bps(table_[p1::kBaudRate], spec_.mx_baud_codes);
}

uint16_t Protocol1Device::read_le(const Table& table, uint8_t address, uint8_t size) noexcept {
  if (size == 2 && address < 255) {
    return static_cast<uint16_t>(table[address] | (table[address + 1] << 8));
  }
  return table[address];
}

uint16_t Protocol1Device::register_raw(uint8_t address) const noexcept {
  const uint8_t owner = owner_[address];
  if (owner == 0 || spec_.registers[owner - 1].address != address) {
    return 0;
  }
  return read_le(table_, address, spec_.registers[owner - 1].size);
}

void Protocol1Device::set_register(uint8_t address, uint16_t value) noexcept {
  const uint8_t owner = owner_[address];
  if (owner == 0) {
    return;
  }
  table_[address] = static_cast<uint8_t>(value & 0xFF);
  if (spec_.registers[owner - 1].size == 2 && address < 255) {
    table_[address + 1] = static_cast<uint8_t>(value >> 8);
  }
}

void Protocol1Device::load_defaults(bool ram_only) noexcept {
  if (!ram_only) {
    table_.fill(0);
  }
  for (const RegisterSpec& r : spec_.registers) {
    if (ram_only && r.area != Area::kRam) {
      continue;
    }
    const auto raw = static_cast<uint16_t>(r.default_raw);
    table_[r.address] = static_cast<uint8_t>(raw & 0xFF);
    if (r.size == 2) {
      table_[r.address + 1] = static_cast<uint8_t>(raw >> 8);
    }
  }
  held_write_.held = false;
}

uint8_t Protocol1Device::check_write(const Table&, uint8_t, std::size_t) const noexcept { return 0; }

void Protocol1Device::after_write(uint8_t, std::size_t) noexcept {}

std::string Protocol1Device::restore_eeprom(std::span<const uint8_t> bytes) {
  if (bytes.size() != eeprom_bytes_) {
    return std::to_string(bytes.size()) + " EEPROM bytes for " + std::string(spec_.name) + ", which has " +
           std::to_string(eeprom_bytes_);
  }
  Table candidate = table_;
  std::copy(bytes.begin(), bytes.end(), candidate.begin());
  for (const RegisterSpec& r : spec_.registers) {
    if (r.area != Area::kEeprom) {
      continue;
    }
    const int32_t value = as_value(r, read_le(candidate, r.address, r.size));
    if (r.access == Access::kRead ? value != r.default_raw : (value < r.min_raw || value > r.max_raw)) {
      return std::string(r.name) + " (" + std::to_string(r.address) + ") = " + std::to_string(value) +
             (r.access == Access::kRead ? " differs from the model's " + std::to_string(r.default_raw)
                                        : " is outside " + std::to_string(r.min_raw) + ".." + std::to_string(r.max_raw));
    }
  }
  std::copy(bytes.begin(), bytes.end(), table_.begin());
  load_defaults(true);
  after_factory_reset();
  return {};
}

std::string Protocol1Device::write_item(uint16_t address, int64_t value) {
  const RegisterSpec* r = address < 256 ? find_register(spec_.registers, static_cast<uint8_t>(address)) : nullptr;
  if (r == nullptr || r->address != address) {
    return "no item of " + std::string(spec_.name) + " starts at address " + std::to_string(address);
  }
  if (value < -32768 || value > 65535) {
    return std::string(r->name) + " = " + std::to_string(value) + " does not fit its " + std::to_string(r->size) +
           " byte(s)";
  }
  const auto raw = static_cast<uint16_t>(value);
  const std::array<uint8_t, 2> bytes{static_cast<uint8_t>(raw & 0xFF), static_cast<uint8_t>(raw >> 8)};
  const uint8_t error = write(address, bytes.data(), r->size, true);
  if (error != 0) {
    return "the firmware refuses " + std::string(r->name) + " = " + std::to_string(value) +
           ((error & p1_error::kAngleLimit) != 0 ? " (Angle Limit Error)" : " (Range Error)");
  }
  return {};
}

uint8_t Protocol1Device::write(uint16_t start, const uint8_t* data, std::size_t n, bool commit) noexcept {
  if (n == 0) {
    return p1_error::kInstruction;
  }
  if (start + n > spec_.table_bytes) {
    return p1_error::kRange;
  }
  // Every byte must belong to a writable register, and to the unlocked window while locked.
  const bool is_locked = locked();
  for (std::size_t a = start; a < start + n; ++a) {
    const uint8_t owner = owner_[a];
    if (owner == 0 || spec_.registers[owner - 1].access != Access::kReadWrite) {
      return p1_error::kRange;
    }
    if (is_locked && (a < p1::kLockedWritableFirst || a > p1::kLockedWritableLast)) {
      return p1_error::kRange;
    }
  }
  // Validate the table as it would be afterwards: the write is atomic.
  Table candidate = table_;
  for (std::size_t i = 0; i < n; ++i) {
    candidate[start + i] = data[i];
  }
  uint8_t previous_owner = 0;
  for (std::size_t a = start; a < start + n; ++a) {
    const uint8_t owner = owner_[a];
    if (owner == previous_owner) {
      continue;
    }
    previous_owner = owner;
    const RegisterSpec& r = spec_.registers[owner - 1];
    const int32_t value = as_value(r, read_le(candidate, r.address, r.size));
    if (value < r.min_raw || value > r.max_raw) {
      return p1_error::kRange;
    }
  }
  const uint8_t error = check_write(candidate, static_cast<uint8_t>(start), n);
  if (error != 0 || !commit) {
    return error;
  }
  for (std::size_t i = 0; i < n; ++i) {
    table_[start + i] = data[i];
  }
  after_write(static_cast<uint8_t>(start), n);
  return 0;
}

bool Protocol1Device::answers(uint8_t instruction_code) const noexcept {
  const bool reads = instruction_code == instruction::kRead || instruction_code == instruction::kBulkRead;
  return detail::status_returned(table_[p1::kStatusReturnLevel], instruction_code, reads);
}

const uint8_t* Protocol1Device::read(uint8_t start, uint8_t length) noexcept {
  return start + length <= spec_.table_bytes ? &table_[start] : nullptr;
}

void Protocol1Device::factory_reset() noexcept {
  load_defaults();
  after_factory_reset();
}

void Protocol1Device::handle(const InstructionPacket& packet, Response& response) noexcept {
  detail::handle_protocol1(*this, counters_, packet, response);
}

}  // namespace doppel::dynamixel
