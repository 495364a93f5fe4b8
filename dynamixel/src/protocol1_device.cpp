#include "dynamixel/protocol1_device.h"

#include <stdexcept>
#include <string>

#include "dynamixel/protocol1.h"

#include "protocol1_lists.h"

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
  }
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
  has_pending_ = false;
}

uint8_t Protocol1Device::check_write(const Table&, uint8_t, std::size_t) const noexcept { return 0; }

uint8_t Protocol1Device::write(uint8_t start, const uint8_t* data, std::size_t n, bool commit) noexcept {
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
  const uint8_t error = check_write(candidate, start, n);
  if (error != 0 || !commit) {
    return error;
  }
  for (std::size_t i = 0; i < n; ++i) {
    table_[start + i] = data[i];
  }
  return 0;
}

bool Protocol1Device::answers(uint8_t instruction_code) const noexcept {
  const uint8_t level = table_[p1::kStatusReturnLevel];
  switch (instruction_code) {
    case instruction::kPing:
      return true;
    case instruction::kRead:
    case instruction::kBulkRead:
      return level >= 1;
    default:
      return level >= 2;
  }
}

void Protocol1Device::reply(uint8_t reply_id, uint8_t error, const uint8_t* data, std::size_t n,
                            Response& response) noexcept {
  const uint8_t err = static_cast<uint8_t>((error | condition_bits()) & 0x7F);
  response.transmits = encode_protocol1_status(reply_id, err, data, n, response.status);
  response.timing = ReplyTiming::kAfterInstruction;
  response.chain_position = 0;
}

void Protocol1Device::handle(const InstructionPacket& packet, Response& response) noexcept {
  response.transmits = false;
  if (packet.protocol != Protocol::kV1) {
    return;
  }
  const uint8_t own_id = id();
  const bool broadcast = packet.id == kBroadcastId;
  const bool mine = packet.id == own_id;
  if (!broadcast && !mine) {
    return;
  }
  if (!packet.checksum_ok) {
    // Not executed. A unicast packet is answered with the Checksum bit (as its instruction's SRL
    // allows), except PING, which the RX-64 manual says is not answered.
    ++counters_.handled;
    ++counters_.bad_checksums;
    if (mine && packet.instruction != instruction::kPing && answers(packet.instruction)) {
      reply(own_id, p1_error::kChecksum, nullptr, 0, response);
    }
    return;
  }
  if (packet.instruction == instruction::kBulkRead && spec_.bulk_read && broadcast) {
    handle_bulk_read(packet, response);
    return;
  }
  ++counters_.handled;
  const uint8_t* params = packet.params.data();
  const std::size_t n = packet.param_count;
  // Answer policy is decided on arrival (SRL before this packet changes it), sender ID is the old one.
  const bool answer = mine && answers(packet.instruction);
  uint8_t error = 0;
  switch (packet.instruction) {
    case instruction::kPing:
      reply(own_id, 0, nullptr, 0, response);  // broadcast too: several devices collide (§1.3)
      return;
    case instruction::kRead: {
      if (broadcast) {
        return;
      }
      if (n != 2) {
        error = p1_error::kInstruction;
      } else if (params[1] == 0 || params[0] + params[1] > spec_.table_bytes) {
        error = p1_error::kRange;
      }
      if (error != 0) {
        ++counters_.errors;
      }
      if (answer) {
        reply(own_id, error, error == 0 ? &table_[params[0]] : nullptr, error == 0 ? params[1] : 0, response);
      }
      return;
    }
    case instruction::kWrite:
      error = n < 2 ? p1_error::kInstruction : write(params[0], params + 1, n - 1, true);
      break;
    case instruction::kRegWrite:
      error = n < 2 ? p1_error::kInstruction : write(params[0], params + 1, n - 1, false);
      if (error == 0) {
        has_pending_ = true;
        pending_address_ = params[0];
        pending_size_ = static_cast<uint8_t>(n - 1);
        for (std::size_t i = 0; i + 1 < n; ++i) {
          pending_data_[i] = params[1 + i];
        }
        table_[p1::kRegistered] = 1;
      }
      break;
    case instruction::kAction:
      if (!has_pending_) {
        error = p1_error::kInstruction;
      } else {
        error = write(pending_address_, pending_data_.data(), pending_size_, true);
        has_pending_ = false;
        table_[p1::kRegistered] = 0;
      }
      break;
    case instruction::kFactoryReset:
      // The status goes out with the old ID; then the device reboots with factory defaults.
      if (answer) {
        reply(own_id, 0, nullptr, 0, response);
      }
      load_defaults();
      after_factory_reset();
      return;
    case instruction::kSyncWrite:
      if (broadcast) {
        handle_sync_write(packet);
        return;
      }
      error = p1_error::kInstruction;  // SYNC WRITE is only defined for the broadcast ID
      break;
    default:
      // Unknown to this firmware (for AX/RX that includes BULK READ): silent when broadcast.
      error = p1_error::kInstruction;
      break;
  }
  if (error != 0) {
    ++counters_.errors;
  }
  if (answer) {
    reply(own_id, error, nullptr, 0, response);
  }
}

void Protocol1Device::handle_sync_write(const InstructionPacket& packet) noexcept {
  const uint8_t* data = detail::p1_sync_write_data(packet, id());
  if (data == nullptr) {
    return;
  }
  ++counters_.handled;
  if (write(packet.params[0], data, packet.params[1], true) != 0) {
    ++counters_.errors;
  }
}

void Protocol1Device::handle_bulk_read(const InstructionPacket& packet, Response& response) noexcept {
  const uint8_t own_id = id();
  uint16_t position = 0;
  const uint8_t* block = detail::p1_bulk_read_block(packet, own_id, position);
  if (block == nullptr) {
    return;
  }
  ++counters_.handled;
  if (!answers(instruction::kBulkRead)) {
    return;
  }
  const uint8_t length = block[0];
  const uint8_t start = block[2];
  const bool in_range = length != 0 && start + length <= spec_.table_bytes;
  if (!in_range) {
    ++counters_.errors;
  }
  reply(own_id, in_range ? 0 : p1_error::kRange, in_range ? &table_[start] : nullptr, in_range ? length : 0,
        response);
  response.timing = position == 0 ? ReplyTiming::kAfterInstruction : ReplyTiming::kAfterPrevious;
  response.chain_position = position;
}

}  // namespace doppel::dynamixel
