#include "dynamixel/protocol2_device.h"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "dynamixel/protocol1.h"
#include "dynamixel/protocol2.h"

#include "protocol1_lists.h"

namespace doppel::dynamixel {

namespace {

constexpr uint8_t kClearMultiTurn = 0x01;
constexpr uint8_t kClearMagic[4] = {0x44, 0x58, 0x4C, 0x22};  // "DXL\""
constexpr uint8_t kBackupStore = 0x01;
constexpr uint8_t kBackupRestore = 0x02;
constexpr uint8_t kBackupMagic[4] = {0x43, 0x54, 0x52, 0x4C};  // "CTRL"
constexpr uint8_t kResetAll = 0xFF;
constexpr uint8_t kResetExceptId = 0x01;
constexpr uint8_t kResetExceptIdAndBaud = 0x02;
constexpr uint8_t kSecondaryIdOff = 253;  // Secondary ID 253..255 = disabled

uint16_t le16(const uint8_t* p) noexcept { return static_cast<uint16_t>(p[0] | (p[1] << 8)); }

bool magic_matches(const uint8_t* p, const uint8_t (&magic)[4]) noexcept {
  return std::equal(magic, magic + 4, p);
}

// Protocol 1.0 front end: the first byte past what a one-byte address can reach, and the most data
// a P1 status can carry (LEN is one byte).
constexpr std::size_t kP1AddressEnd = x430::kProtocol1LastAddress + 1;
constexpr std::size_t kP1MaxStatusData = 253;

// The Protocol 1.0 error bit (§1.4) for a Protocol 2.0 error number (§2.5), assumption: a Data
// Limit on Goal Position is the Angle Limit bit, every other refused value, length or address the
// Range bit.
uint8_t p1_bits(uint8_t p2_error_number, bool goal_position_written) noexcept {
  switch (p2_error_number) {
    case 0:
      return 0;
    case p2_error::kInstruction:
    case p2_error::kResultFail:
      return p1_error::kInstruction;
    case p2_error::kCrc:
      return p1_error::kChecksum;
    case p2_error::kDataLimit:
      return goal_position_written ? p1_error::kAngleLimit : p1_error::kRange;
    default:
      return p1_error::kRange;
  }
}

bool covers_goal_position(std::size_t start, std::size_t n) noexcept {
  return start < x430::kGoalPosition + 4u && x430::kGoalPosition < start + n;
}

}  // namespace

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
  has_pending_ = false;
}

uint16_t Protocol2Device::resolve(uint16_t address) const noexcept {
  if (address >= x430::kIndirectData1 && address < x430::kIndirectData1 + x430::kIndirectSlots) {
    return le16(&table_[x430::kIndirectAddress1 + 2 * (address - x430::kIndirectData1)]);
  }
  if (address >= x430::kIndirectData29 && address < x430::kIndirectData29 + x430::kIndirectSlots) {
    return le16(&table_[x430::kIndirectAddress29 + 2 * (address - x430::kIndirectData29)]);
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
  has_pending_ = true;
  pending_address_ = start;
  pending_size_ = static_cast<uint16_t>(n);
  std::copy_n(data, n, pending_data_.begin());
  table_[x430::kRegisteredInstruction] = 1;
}

uint8_t Protocol2Device::apply_reg_write(bool via_secondary) noexcept {
  has_pending_ = false;
  table_[x430::kRegisteredInstruction] = 0;
  return write(pending_address_, pending_data_.data(), pending_size_, true, via_secondary);
}

bool Protocol2Device::answers(uint8_t instruction_code) const noexcept {
  const uint8_t level = table_[x430::kStatusReturnLevel];
  switch (instruction_code) {
    case instruction::kPing:
      return true;
    case instruction::kRead:
    case instruction::kSyncRead:
    case instruction::kFastSyncRead:
    case instruction::kBulkRead:
    case instruction::kFastBulkRead:
      return level >= 1;
    default:
      return level >= 2;
  }
}

uint8_t Protocol2Device::error_byte(uint8_t error) const noexcept {
  return static_cast<uint8_t>((error & 0x7F) | (hardware_error() != 0 ? p2_error::kAlert : 0));
}

void Protocol2Device::reply(uint8_t error, const uint8_t* data, std::size_t n, Response& response) noexcept {
  // The status goes out with the ID the device had when the packet arrived (the caller replies
  // before anything that changes it, or passes through a WRITE whose new ID applies afterwards).
  response.transmits = encode_protocol2_status(reply_id_, error_byte(error), data, n, response.status);
  response.timing = ReplyTiming::kAfterInstruction;
  response.chain_position = 0;
}

void Protocol2Device::handle(const InstructionPacket& packet, Response& response) noexcept {
  response.transmits = false;
  // The protocol is fixed when the packet arrives: a write of Protocol Type is answered in the old one.
  if (packet.protocol != protocol()) {
    return;
  }
  if (packet.protocol == Protocol::kV1) {
    handle_protocol1(packet, response);
    return;
  }
  const uint8_t own_id = id();
  reply_id_ = own_id;
  const bool broadcast = packet.id == kBroadcastId;
  const bool mine = packet.id == own_id;
  const uint8_t secondary_id = table_[x430::kSecondaryId];
  const bool via_secondary = !mine && !broadcast && secondary_id < kSecondaryIdOff && packet.id == secondary_id;
  if (!broadcast && !mine && !via_secondary) {
    return;
  }
  if (!packet.checksum_ok) {
    // Not executed. A unicast packet is answered with CRC Error where the SRL allows (§2.5).
    ++counters_.handled;
    ++counters_.bad_checksums;
    if (mine && answers(packet.instruction)) {
      reply(p2_error::kCrc, nullptr, 0, response);
    }
    return;
  }
  const bool fast = packet.instruction == instruction::kFastSyncRead || packet.instruction == instruction::kFastBulkRead;
  switch (fast && !spec_.fast_read ? instruction::kStatus : packet.instruction) {  // no FAST: undefined
    case instruction::kSyncRead:
    case instruction::kFastSyncRead:
    case instruction::kBulkRead:
    case instruction::kFastBulkRead:
    case instruction::kSyncWrite:
    case instruction::kBulkWrite:
      if (broadcast) {
        if (packet.instruction == instruction::kSyncWrite) {
          handle_sync_write(packet);
        } else if (packet.instruction == instruction::kBulkWrite) {
          handle_bulk_write(packet);
        } else if (packet.instruction == instruction::kSyncRead || packet.instruction == instruction::kFastSyncRead) {
          handle_sync_read(packet, packet.instruction == instruction::kFastSyncRead, response);
        } else {
          handle_bulk_read(packet, packet.instruction == instruction::kFastBulkRead, response);
        }
        return;
      }
      // Defined for the broadcast ID only.
      ++counters_.handled;
      ++counters_.errors;
      if (mine && answers(packet.instruction)) {
        reply(p2_error::kInstruction, nullptr, 0, response);
      }
      return;
    default:
      break;
  }
  ++counters_.handled;
  on_communication();
  handle_unicast(packet, mine && answers(packet.instruction), via_secondary, response);
}

void Protocol2Device::handle_unicast(const InstructionPacket& packet, bool answer, bool via_secondary,
                                     Response& response) noexcept {
  const bool broadcast = packet.id == kBroadcastId;
  const uint8_t* p = packet.params.data();
  const std::size_t n = packet.param_count;
  uint8_t error = 0;
  switch (packet.instruction) {
    case instruction::kPing: {
      if (via_secondary) {
        return;
      }
      const uint8_t data[3] = {static_cast<uint8_t>(spec_.model_number & 0xFF),
                               static_cast<uint8_t>(spec_.model_number >> 8), table_[x430::kFirmwareVersion]};
      reply(0, data, sizeof data, response);
      if (broadcast) {
        response.timing = ReplyTiming::kIdOrder;  // every device answers, in ID order (§2.6)
      }
      return;
    }
    case instruction::kRead: {
      if (broadcast || via_secondary) {
        return;
      }
      if (n != 4) {
        error = p2_error::kDataLength;
      } else {
        const uint16_t length = le16(p + 2);
        if (length == 0) {
          error = p2_error::kDataLength;
        } else if (!read(le16(p), length, scratch_.data())) {
          error = p2_error::kAccess;  // outside the table: Access Error without data (§2.4)
        } else if (answer) {
          reply(0, scratch_.data(), length, response);
          return;
        }
      }
      break;
    }
    case instruction::kWrite:
      error = n < 3 ? p2_error::kDataLength : write(le16(p), p + 2, n - 2, true, via_secondary);
      break;
    case instruction::kRegWrite:
      error = n < 3 ? p2_error::kDataLength : write(le16(p), p + 2, n - 2, false, via_secondary);
      if (error == 0) {
        hold_reg_write(le16(p), p + 2, n - 2);
      }
      break;
    case instruction::kAction:
      if (!has_pending_) {
        error = p2_error::kInstruction;
      } else {
        error = apply_reg_write(via_secondary);
      }
      break;
    case instruction::kFactoryReset: {
      if (n != 1) {
        error = p2_error::kDataLength;
        break;
      }
      const uint8_t option = p[0];
      if (option != kResetAll && option != kResetExceptId && option != kResetExceptIdAndBaud) {
        error = p2_error::kDataRange;
        break;
      }
      if (broadcast && option == kResetAll) {
        return;  // ignored (fw >= 42): it would give every device ID 1
      }
      if (answer) {
        reply(0, nullptr, 0, response);  // status with the old ID and rate, then the reboot
      }
      const uint8_t old_id = table_[x430::kId];
      const uint8_t old_baud = table_[x430::kBaudRate];
      load_defaults(false);
      if (option != kResetAll) {
        table_[x430::kId] = old_id;
      }
      if (option == kResetExceptIdAndBaud) {
        table_[x430::kBaudRate] = old_baud;
      }
      reboot();
      return;
    }
    case instruction::kReboot:
      if (n != 0) {
        error = p2_error::kDataLength;
        break;
      }
      if (answer) {
        reply(0, nullptr, 0, response);
      }
      reboot();
      return;
    case instruction::kClear:
      if (n != 5) {
        error = p2_error::kDataLength;
      } else if (p[0] == kClearMultiTurn && magic_matches(p + 1, kClearMagic)) {
        error = clear_multi_turn();
      } else {
        error = p2_error::kDataRange;  // other options (0x02 clear errors) are DYNAMIXEL-Y only
      }
      break;
    case instruction::kControlTableBackup: {
      if (!spec_.table_backup) {
        error = p2_error::kInstruction;  // not in this model's firmware
        break;
      }
      if (n != 5) {
        error = p2_error::kDataLength;
        break;
      }
      if ((p[0] != kBackupStore && p[0] != kBackupRestore) || !magic_matches(p + 1, kBackupMagic)) {
        error = p2_error::kDataRange;
        break;
      }
      if (torque_enabled() || (p[0] == kBackupRestore && !has_backup_)) {
        error = p2_error::kResultFail;
        break;
      }
      if (answer) {
        reply(0, nullptr, 0, response);
      }
      backup(p[0]);
      return;
    }
    default:
      error = p2_error::kInstruction;
      break;
  }
  if (error != 0) {
    ++counters_.errors;
  }
  if (answer) {
    reply(error, nullptr, 0, response);
  }
}

uint8_t Protocol2Device::backup(uint8_t option) noexcept {
  if (option == kBackupStore) {
    std::copy_n(table_.begin(), backup_.size(), backup_.begin());
    has_backup_ = true;
    return 0;
  }
  for (const P2RegisterSpec& r : spec_.registers) {
    if (r.area == Area::kEeprom && r.access == Access::kReadWrite) {
      std::copy_n(backup_.begin() + r.address, r.size, table_.begin() + r.address);
    }
  }
  reboot();  // restoring reboots the device
  return 0;
}

void Protocol2Device::chain_reply(uint16_t position, bool fast, uint32_t total_data, uint32_t devices, uint16_t start,
                                  uint16_t length, Response& response) noexcept {
  const bool ok = length != 0 && read(start, length, scratch_.data());
  const uint8_t error = length == 0 ? p2_error::kDataLength : (ok ? 0 : p2_error::kAccess);
  if (error != 0) {
    ++counters_.errors;
  }
  if (fast) {
    // The block keeps its place in the combined packet even on error (its data reads 0).
    if (!ok) {
      std::fill_n(scratch_.begin(), std::min<std::size_t>(length, scratch_.size()), 0);
    }
    response.transmits = length <= scratch_.size() &&
                         encode_fast_block(position == 0, total_data, devices, error_byte(error), reply_id_,
                                           scratch_.data(), length, response.status);
    response.timing = ReplyTiming::kFastBlock;
  } else {
    reply(error, ok ? scratch_.data() : nullptr, ok ? length : 0, response);
    response.timing = position == 0 ? ReplyTiming::kAfterInstruction : ReplyTiming::kAfterPrevious;
  }
  response.chain_position = position;
}

void Protocol2Device::handle_sync_read(const InstructionPacket& packet, bool fast, Response& response) noexcept {
  const std::size_t n = packet.param_count;
  if (n < 5) {
    return;  // malformed: no device can find itself
  }
  const uint8_t* p = packet.params.data();
  const uint8_t own_id = id();
  std::bitset<256> seen;
  uint16_t position = 0;
  bool listed = false;
  for (std::size_t i = 4; i < n; ++i) {
    if (seen.test(p[i])) {
      continue;
    }
    seen.set(p[i]);
    if (p[i] == own_id && !listed) {
      listed = true;
    } else if (!listed) {
      ++position;
    }
  }
  if (!listed) {
    return;
  }
  ++counters_.handled;
  on_communication();
  if (!answers(packet.instruction)) {
    return;
  }
  const uint16_t length = le16(p + 2);
  const auto devices = static_cast<uint32_t>(seen.count());
  chain_reply(position, fast, length * devices, devices, le16(p), length, response);
}

void Protocol2Device::handle_bulk_read(const InstructionPacket& packet, bool fast, Response& response) noexcept {
  const std::size_t n = packet.param_count;
  if (n == 0 || n % 5 != 0) {
    return;
  }
  const uint8_t* p = packet.params.data();
  const uint8_t own_id = id();
  std::bitset<256> seen;
  uint16_t position = 0;
  const uint8_t* mine = nullptr;
  uint32_t total = 0;
  for (std::size_t i = 0; i < n; i += 5) {
    if (seen.test(p[i])) {
      continue;  // an ID may appear once: later blocks of it take no place
    }
    seen.set(p[i]);
    total += le16(p + i + 3);
    if (p[i] == own_id) {
      mine = p + i;
    } else if (mine == nullptr) {
      ++position;
    }
  }
  if (mine == nullptr) {
    return;
  }
  ++counters_.handled;
  on_communication();
  if (!answers(packet.instruction)) {
    return;
  }
  chain_reply(position, fast, total, static_cast<uint32_t>(seen.count()), le16(mine + 1), le16(mine + 3), response);
}

void Protocol2Device::handle_sync_write(const InstructionPacket& packet) noexcept {
  const std::size_t n = packet.param_count;
  if (n < 4) {
    return;
  }
  const uint8_t* p = packet.params.data();
  const std::size_t length = le16(p + 2);
  if (length == 0 || (n - 4) % (length + 1) != 0) {
    return;  // malformed: no device can find its block
  }
  const uint8_t own_id = id();
  for (std::size_t block = 4; block < n; block += length + 1) {
    if (p[block] == own_id) {
      ++counters_.handled;
      on_communication();
      if (write(le16(p), p + block + 1, length, true, false) != 0) {
        ++counters_.errors;
      }
      return;
    }
  }
}

void Protocol2Device::handle_bulk_write(const InstructionPacket& packet) noexcept {
  const std::size_t n = packet.param_count;
  const uint8_t* p = packet.params.data();
  const uint8_t own_id = id();
  std::size_t i = 0;
  while (i + 5 <= n) {
    const std::size_t length = le16(p + i + 3);
    if (length == 0 || i + 5 + length > n) {
      return;  // the list is broken from here on
    }
    if (p[i] == own_id) {
      ++counters_.handled;
      on_communication();
      if (write(le16(p + i + 1), p + i + 5, length, true, false) != 0) {
        ++counters_.errors;
      }
      return;
    }
    i += 5 + length;
  }
}

}  // namespace doppel::dynamixel

namespace doppel::dynamixel {

void Protocol2Device::reply_protocol1(uint8_t error_bits, const uint8_t* data, std::size_t n,
                                      Response& response) noexcept {
  // Hardware Error Status bits 0 (input voltage), 2 (overheating) and 5 (overload) sit where the P1
  // error byte has the same conditions (§1.4, §3.7); the encoder and shock bits have no P1 place.
  constexpr uint8_t kSharedBits = x430::kInputVoltageError | x430::kOverheatingError | x430::kOverloadError;
  const auto err = static_cast<uint8_t>((error_bits | (hardware_error() & kSharedBits)) & 0x7F);
  response.transmits = encode_protocol1_status(reply_id_, err, data, n, response.status);
  response.timing = ReplyTiming::kAfterInstruction;
  response.chain_position = 0;
}

void Protocol2Device::handle_protocol1(const InstructionPacket& packet, Response& response) noexcept {
  const uint8_t own_id = id();
  reply_id_ = own_id;
  const bool broadcast = packet.id == kBroadcastId;
  const bool mine = packet.id == own_id;
  if (!broadcast && !mine) {
    return;  // the Secondary ID is a Protocol 2.0 feature (assumption)
  }
  if (!packet.checksum_ok) {
    // As Doppel's Protocol 1.0 firmware: not executed; unicast answered with the Checksum bit,
    // except PING.
    ++counters_.handled;
    ++counters_.bad_checksums;
    if (mine && packet.instruction != instruction::kPing && answers(packet.instruction)) {
      reply_protocol1(p1_error::kChecksum, nullptr, 0, response);
    }
    return;
  }
  if (broadcast && packet.instruction == instruction::kBulkRead) {
    handle_protocol1_bulk_read(packet, response);
    return;
  }
  if (broadcast && packet.instruction == instruction::kSyncWrite) {
    handle_protocol1_sync_write(packet);
    return;
  }
  ++counters_.handled;
  on_communication();
  const uint8_t* p = packet.params.data();
  const std::size_t n = packet.param_count;
  const bool answer = mine && answers(packet.instruction);
  uint8_t bits = 0;
  switch (packet.instruction) {
    case instruction::kPing:
      reply_protocol1(0, nullptr, 0, response);  // broadcast too: several devices collide (§1.3)
      return;
    case instruction::kRead: {
      if (broadcast) {
        return;
      }
      if (n != 2) {
        bits = p1_error::kInstruction;
      } else if (p[1] == 0 || p[1] > kP1MaxStatusData || p[0] + std::size_t{p[1]} > kP1AddressEnd ||
                 !read(p[0], p[1], scratch_.data())) {
        bits = p1_error::kRange;
      } else if (answer) {
        reply_protocol1(0, scratch_.data(), p[1], response);
        return;
      }
      break;
    }
    case instruction::kWrite:
    case instruction::kRegWrite: {
      const bool commit = packet.instruction == instruction::kWrite;
      if (n < 2) {
        bits = p1_error::kInstruction;
      } else if (p[0] + (n - 1) > kP1AddressEnd) {
        bits = p1_error::kRange;
      } else {
        bits = p1_bits(write(p[0], p + 1, n - 1, commit, false), covers_goal_position(p[0], n - 1));
      }
      if (bits == 0 && !commit) {
        hold_reg_write(p[0], p + 1, n - 1);
      }
      break;
    }
    case instruction::kAction:
      if (!has_pending_) {
        bits = p1_error::kInstruction;
      } else {
        bits = p1_bits(apply_reg_write(false), covers_goal_position(pending_address_, pending_size_));
      }
      break;
    case instruction::kFactoryReset:
      // P1 RESET has no option: everything to factory values, Protocol Type 2 included; the status
      // goes out first, in Protocol 1.0 with the old ID.
      if (answer) {
        reply_protocol1(0, nullptr, 0, response);
      }
      load_defaults(false);
      reboot();
      return;
    default:
      // REBOOT, CLEAR, BACKUP, SYNC READ, the FAST reads, BULK WRITE are not Protocol 1.0
      // instructions (§1.2); SYNC WRITE / BULK READ only for the broadcast ID.
      bits = p1_error::kInstruction;
      break;
  }
  if (bits != 0) {
    ++counters_.errors;
  }
  if (answer) {
    reply_protocol1(bits, nullptr, 0, response);
  }
}

void Protocol2Device::handle_protocol1_sync_write(const InstructionPacket& packet) noexcept {
  const uint8_t* data = detail::p1_sync_write_data(packet, id());
  if (data == nullptr) {
    return;
  }
  ++counters_.handled;
  on_communication();
  const uint8_t start = packet.params[0];
  const uint8_t length = packet.params[1];
  if (start + std::size_t{length} > kP1AddressEnd || write(start, data, length, true, false) != 0) {
    ++counters_.errors;
  }
}

void Protocol2Device::handle_protocol1_bulk_read(const InstructionPacket& packet, Response& response) noexcept {
  uint16_t position = 0;
  const uint8_t* block = detail::p1_bulk_read_block(packet, id(), position);
  if (block == nullptr) {
    return;
  }
  ++counters_.handled;
  on_communication();
  if (!answers(instruction::kBulkRead)) {
    return;
  }
  const uint8_t length = block[0];
  const uint8_t start = block[2];
  const bool ok = length != 0 && length <= kP1MaxStatusData && start + std::size_t{length} <= kP1AddressEnd &&
                  read(start, length, scratch_.data());
  if (!ok) {
    ++counters_.errors;
  }
  reply_protocol1(ok ? 0 : p1_error::kRange, ok ? scratch_.data() : nullptr, ok ? length : 0, response);
  response.timing = position == 0 ? ReplyTiming::kAfterInstruction : ReplyTiming::kAfterPrevious;
  response.chain_position = position;
}

}  // namespace doppel::dynamixel
