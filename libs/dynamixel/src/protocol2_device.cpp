// The X control table as a register file: item layout, Indirect Data, write validation and the REG WRITE store.
#include "dynamixel/protocol2_device.h"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "protocol2_params.h"

namespace doppel::dynamixel {

Protocol2Device::Protocol2Device(const P2ModelSpec& spec, uint8_t id, uint8_t baud_raw, uint8_t return_delay_raw)
    : spec_(spec) {
  if (spec.registers.empty() || spec.table_bytes == 0 || spec.table_bytes > kTableCapacity ||
      spec.registers.size() > kMaxItems) {
    throw std::invalid_argument("model " + std::string(spec.name) + " has no usable Protocol 2.0 control table");
  }
  owner_.fill(-1);
  for (std::size_t i = 0; i < spec.registers.size(); ++i) {
    const P2RegisterSpec& r = spec.registers[i];
    for (uint8_t b = 0; b < r.size; ++b) {
      owner_[r.address + b] = static_cast<int16_t>(i);
    }
  }
  load_defaults(false);
  const auto check = [&](uint16_t address, uint8_t value, const char* what) {
    const P2RegisterSpec* r = find_p2_register(spec.registers, address);
    if (r == nullptr || value < r->min_raw || value > r->max_raw) {
      throw std::invalid_argument(std::string(spec.name) + ": " + what + " " + std::to_string(value) +
                                  " is outside the item's range");
    }
    table_[address] = value;
  };
  check(x430::kId, id, "ID");
  check(x430::kBaudRate, baud_raw, "Baud Rate register value");
  check(x430::kReturnDelayTime, return_delay_raw, "Return Delay Time register value");
}

uint32_t Protocol2Device::baud_bps() const noexcept {
  return p2_baud_bps(table_[x430::kBaudRate], spec_.baud7_is_5m);
}

int Protocol2Device::item_at(uint16_t address) const noexcept {
  return address < kTableCapacity ? owner_[address] : -1;
}

bool Protocol2Device::touches(const ItemSet& touched, uint16_t address) const noexcept {
  const int item = item_at(address);
  return item >= 0 && touched.test(static_cast<std::size_t>(item));
}

int64_t Protocol2Device::value_in(const Table& table, uint16_t address) const noexcept {
  const int item = item_at(address);
  if (item < 0) {
    return 0;
  }
  const P2RegisterSpec& r = spec_.registers[static_cast<std::size_t>(item)];
  if (r.address != address) {
    return 0;
  }
  uint32_t raw = 0;
  for (uint8_t b = 0; b < r.size; ++b) {
    raw |= static_cast<uint32_t>(table[address + b]) << (8 * b);
  }
  if (!r.is_signed) {
    return raw;
  }
  switch (r.size) {
    case 1:
      return static_cast<int8_t>(raw);
    case 2:
      return static_cast<int16_t>(raw);
    default:
      return static_cast<int32_t>(raw);
  }
}

int64_t Protocol2Device::register_value(uint16_t address) const noexcept { return value_in(table_, address); }

void Protocol2Device::set_register(uint16_t address, int64_t value) noexcept {
  const int item = item_at(address);
  if (item < 0) {
    return;
  }
  const P2RegisterSpec& r = spec_.registers[static_cast<std::size_t>(item)];
  const auto raw = static_cast<uint32_t>(value);
  for (uint8_t b = 0; b < r.size; ++b) {
    table_[r.address + b] = static_cast<uint8_t>(raw >> (8 * b));
  }
}

void Protocol2Device::load_defaults(bool ram_only) noexcept {
  if (!ram_only) {
    table_.fill(0);
  }
  for (const P2RegisterSpec& r : spec_.registers) {
    if (ram_only && r.area != Area::kRam) {
      continue;
    }
    set_register(r.address, r.default_raw);
  }
  held_write_.held = false;
}

uint16_t Protocol2Device::resolve(uint16_t address) const noexcept {
  if (address >= x430::kIndirectData1 && address < x430::kIndirectData1 + x430::kIndirectSlots) {
    return detail::le16(&table_[x430::kIndirectAddress1 + 2 * (address - x430::kIndirectData1)]);
  }
  if (address >= x430::kIndirectData29 && address < x430::kIndirectData29 + x430::kIndirectSlots) {
    return detail::le16(&table_[x430::kIndirectAddress29 + 2 * (address - x430::kIndirectData29)]);
  }
  return address;
}

bool Protocol2Device::read(uint16_t start, std::size_t n, uint8_t* out) const noexcept {
  if (n == 0 || start + n > spec_.table_bytes) {
    return false;
  }
  for (std::size_t i = 0; i < n; ++i) {
    const uint16_t target = resolve(static_cast<uint16_t>(start + i));
    out[i] = target < spec_.table_bytes ? table_[target] : 0;
  }
  return true;
}

uint8_t Protocol2Device::check_write(const Table&, const ItemSet&) const noexcept { return 0; }

void Protocol2Device::after_write(const Table&, const ItemSet&) noexcept {}

void Protocol2Device::reboot() noexcept { load_defaults(true); }

std::string Protocol2Device::restore_eeprom(std::span<const uint8_t> bytes) {
  if (bytes.size() != x430::kEepromEnd) {
    return std::to_string(bytes.size()) + " EEPROM bytes for " + std::string(spec_.name) + ", which has " +
           std::to_string(x430::kEepromEnd);
  }
  Table candidate = table_;
  std::copy(bytes.begin(), bytes.end(), candidate.begin());
  for (const P2RegisterSpec& r : spec_.registers) {
    if (r.address >= x430::kEepromEnd) {
      continue;
    }
    const int64_t value = value_in(candidate, r.address);
    if (r.access == Access::kRead ? value != r.default_raw : (value < r.min_raw || value > r.max_raw)) {
      return std::string(r.name) + " (" + std::to_string(r.address) + ") = " + std::to_string(value) +
             (r.access == Access::kRead ? " differs from the model's " + std::to_string(r.default_raw)
                                        : " is outside " + std::to_string(r.min_raw) + ".." + std::to_string(r.max_raw));
    }
  }
  std::copy(bytes.begin(), bytes.end(), table_.begin());
  reboot();
  return {};
}

std::string Protocol2Device::write_item(uint16_t address, int64_t value) {
  const int item = item_at(address);
  if (item < 0 || spec_.registers[static_cast<std::size_t>(item)].address != address) {
    return "no item of " + std::string(spec_.name) + " starts at address " + std::to_string(address);
  }
  const P2RegisterSpec& r = spec_.registers[static_cast<std::size_t>(item)];
  std::array<uint8_t, 4> bytes{};
  for (std::size_t b = 0; b < r.size; ++b) {
    bytes[b] = static_cast<uint8_t>(static_cast<uint64_t>(value) >> (8 * b));
  }
  const uint8_t error = write(address, bytes.data(), r.size, true, false);
  if (error != 0 || value_in(table_, address) != value) {
    return "the firmware refuses " + std::string(r.name) + " = " + std::to_string(value) + " (error " +
           std::to_string(error) + ")";
  }
  return {};
}

uint8_t Protocol2Device::write(uint16_t start, const uint8_t* data, std::size_t n, bool commit,
                               bool via_secondary) noexcept {
  if (n == 0) {
    return p2_error::kDataLength;
  }
  if (start + n > spec_.table_bytes) {
    return p2_error::kAccess;
  }
  // Every byte (through Indirect Data to its target) must belong to a writable item; EEPROM is
  // locked while the torque is on and through the Secondary ID.
  Table candidate;
  std::copy_n(table_.begin(), spec_.table_bytes, candidate.begin());
  ItemSet touched;
  std::array<uint8_t, kMaxItems> written{};
  for (std::size_t i = 0; i < n; ++i) {
    const uint16_t target = resolve(static_cast<uint16_t>(start + i));
    const int item = target < spec_.table_bytes ? owner_[target] : -1;
    if (item < 0) {
      return p2_error::kAccess;
    }
    const P2RegisterSpec& r = spec_.registers[static_cast<std::size_t>(item)];
    if (r.access != Access::kReadWrite || (r.area == Area::kEeprom && (torque_enabled() || via_secondary))) {
      return p2_error::kAccess;
    }
    candidate[target] = data[i];
    touched.set(static_cast<std::size_t>(item));
    ++written[static_cast<std::size_t>(item)];
  }
  // Items must be written whole, and each value must lie in its item's range.
  for (std::size_t item = 0; item < spec_.registers.size(); ++item) {
    if (touched.test(item) && written[item] < spec_.registers[item].size) {
      return p2_error::kDataLength;
    }
  }
  for (std::size_t item = 0; item < spec_.registers.size(); ++item) {
    if (!touched.test(item)) {
      continue;
    }
    const P2RegisterSpec& r = spec_.registers[item];
    const int64_t value = value_in(candidate, r.address);
    if (value < r.min_raw || value > r.max_raw) {
      return p2_error::kDataRange;
    }
  }
  const uint8_t error = check_write(candidate, touched);
  if (error != 0 || !commit) {
    return error;
  }
  Table before;
  std::copy_n(table_.begin(), spec_.table_bytes, before.begin());
  std::copy_n(candidate.begin(), spec_.table_bytes, table_.begin());
  after_write(before, touched);
  return 0;
}

void Protocol2Device::hold_reg_write(uint16_t start, const uint8_t* data, std::size_t n) noexcept {
  held_write_.hold(start, data, n);
  table_[x430::kRegisteredInstruction] = 1;
}

uint8_t Protocol2Device::apply_reg_write(bool via_secondary) noexcept {
  held_write_.held = false;
  table_[x430::kRegisteredInstruction] = 0;
  return write(held_write_.address, held_write_.data.data(), held_write_.size, true, via_secondary);
}

}  // namespace doppel::dynamixel
