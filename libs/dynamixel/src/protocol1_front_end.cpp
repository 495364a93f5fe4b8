// One Protocol 1.0 firmware for the P1 devices and for X / MX(2.0) servos in Protocol Type 1.
#include "protocol1_front_end.h"

#include <bitset>

#include "dynamixel/control_table.h"
#include "dynamixel/protocol1.h"

namespace doppel::dynamixel::detail {

namespace {

// One-byte addresses reach 0..255; a status (LEN is one byte) carries at most 253 data bytes.
constexpr std::size_t kAddressEnd = 256;
constexpr std::size_t kMaxStatusData = 253;

void reply(const Protocol1RegisterFile& device, uint8_t reply_id, uint8_t error, const uint8_t* data, std::size_t n,
           Response& response) noexcept {
  const auto err = static_cast<uint8_t>((error | device.condition_bits()) & 0x7F);
  response.transmits = encode_protocol1_status(reply_id, err, data, n, response.status);
  response.timing = ReplyTiming::kAfterInstruction;
  response.chain_position = 0;
}

// The bytes a READ or BULK READ of `length` at `start` returns; nullptr for the Range bit.
const uint8_t* readable(Protocol1RegisterFile& device, uint8_t start, uint8_t length) noexcept {
  if (length == 0 || length > kMaxStatusData || start + std::size_t{length} > kAddressEnd) {
    return nullptr;
  }
  return device.read(start, length);
}

uint8_t write_within_reach(Protocol1RegisterFile& device, uint8_t start, const uint8_t* data, std::size_t n,
                           bool commit) noexcept {
  return start + n > kAddressEnd ? p1_error::kRange : device.write(start, data, n, commit);
}

// SYNC WRITE params are [start, length, then (ID, length data bytes) per device]; in a malformed
// list no device finds its block.
void handle_sync_write(Protocol1RegisterFile& device, DeviceCounters& counters, const InstructionPacket& packet) noexcept {
  const std::size_t n = packet.param_count;
  const std::size_t length = n < 2 ? 0 : packet.params[1];
  if (length == 0 || (n - 2) % (length + 1) != 0) {
    return;
  }
  for (std::size_t block = 2; block < n; block += length + 1) {
    if (packet.params[block] == device.id()) {
      ++counters.handled;
      device.on_communication();
      if (write_within_reach(device, packet.params[0], &packet.params[block + 1], length, true) != 0) {
        ++counters.errors;
      }
      return;
    }
  }
}

// BULK READ params are [0x00, then (length, ID, address) per device]. The devices listed before
// this one answer first; only an ID's first block counts, so a repeated ID takes no place in the chain.
void handle_bulk_read(Protocol1RegisterFile& device, DeviceCounters& counters, const InstructionPacket& packet,
                      Response& response) noexcept {
  const std::size_t n = packet.param_count;
  if (n < 1 || (n - 1) % 3 != 0) {
    return;
  }
  const uint8_t own_id = device.id();
  std::bitset<256> seen;
  uint16_t position = 0;
  std::size_t block = 1;
  for (; block < n; block += 3) {
    const uint8_t listed_id = packet.params[block + 1];
    if (listed_id == own_id) {
      break;
    }
    if (!seen.test(listed_id)) {
      seen.set(listed_id);
      ++position;
    }
  }
  if (block >= n) {
    return;
  }
  ++counters.handled;
  device.on_communication();
  if (!device.answers(instruction::kBulkRead)) {
    return;
  }
  const uint8_t length = packet.params[block];
  const uint8_t* data = readable(device, packet.params[block + 2], length);
  if (data == nullptr) {
    ++counters.errors;
  }
  reply(device, own_id, data != nullptr ? 0 : p1_error::kRange, data, data != nullptr ? length : 0, response);
  response.timing = position == 0 ? ReplyTiming::kAfterInstruction : ReplyTiming::kAfterPrevious;
  response.chain_position = position;
}

}  // namespace

void handle_protocol1(Protocol1RegisterFile& device, DeviceCounters& counters, const InstructionPacket& packet,
                      Response& response) noexcept {
  response.transmits = false;
  if (packet.protocol != Protocol::kV1) {
    return;
  }
  const uint8_t own_id = device.id();
  const bool broadcast = packet.id == kBroadcastId;
  const bool mine = packet.id == own_id;
  if (!broadcast && !mine) {
    return;  // an X servo's Secondary ID is a Protocol 2.0 feature (assumption)
  }
  if (!packet.checksum_ok) {
    // Not executed. A unicast packet is answered with the Checksum bit (as its instruction's SRL
    // allows), except PING, which the RX-64 manual says is not answered.
    ++counters.handled;
    ++counters.bad_checksums;
    if (mine && packet.instruction != instruction::kPing && device.answers(packet.instruction)) {
      reply(device, own_id, p1_error::kChecksum, nullptr, 0, response);
    }
    return;
  }
  if (broadcast && packet.instruction == instruction::kBulkRead && device.has_bulk_read()) {
    handle_bulk_read(device, counters, packet, response);
    return;
  }
  if (broadcast && packet.instruction == instruction::kSyncWrite) {
    handle_sync_write(device, counters, packet);
    return;
  }
  ++counters.handled;
  device.on_communication();
  const uint8_t* p = packet.params.data();
  const std::size_t n = packet.param_count;
  // Answer policy is decided on arrival (SRL before this packet changes it), sender ID is the old one.
  const bool answer = mine && device.answers(packet.instruction);
  uint8_t error = 0;
  switch (packet.instruction) {
    case instruction::kPing:
      reply(device, own_id, 0, nullptr, 0, response);  // broadcast too: several devices collide (§1.3)
      return;
    case instruction::kRead: {
      if (broadcast) {
        return;
      }
      const uint8_t* data = n == 2 ? readable(device, p[0], p[1]) : nullptr;
      if (data == nullptr) {
        error = n == 2 ? p1_error::kRange : p1_error::kInstruction;
      } else if (answer) {
        reply(device, own_id, 0, data, p[1], response);
        return;
      }
      break;
    }
    case instruction::kWrite:
    case instruction::kRegWrite: {
      const bool commit = packet.instruction == instruction::kWrite;
      error = n < 2 ? p1_error::kInstruction : write_within_reach(device, p[0], p + 1, n - 1, commit);
      if (error == 0 && !commit) {
        device.held_write().hold(p[0], p + 1, n - 1);
        device.set_registered(true);
      }
      break;
    }
    case instruction::kAction: {
      HeldWrite& held = device.held_write();
      if (!held.held) {
        error = p1_error::kInstruction;
        break;
      }
      held.held = false;
      device.set_registered(false);
      error = device.write(held.address, held.data.data(), held.size, true);
      break;
    }
    case instruction::kFactoryReset:
      // RESET has no option: everything to factory values. The status goes out first, with the old ID.
      if (answer) {
        reply(device, own_id, 0, nullptr, 0, response);
      }
      device.factory_reset();
      return;
    default:
      // Not a Protocol 1.0 instruction of this firmware (§1.2; for AX/RX that includes BULK READ),
      // or SYNC WRITE / BULK READ to a single ID: silent when broadcast.
      error = p1_error::kInstruction;
      break;
  }
  if (error != 0) {
    ++counters.errors;
  }
  if (answer) {
    reply(device, own_id, error, nullptr, 0, response);
  }
}

}  // namespace doppel::dynamixel::detail
