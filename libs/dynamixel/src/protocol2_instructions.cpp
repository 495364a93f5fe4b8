// Protocol 2.0 instruction handling: addressing, Status Return Level, status packets, single-device instructions.
#include "dynamixel/protocol2_device.h"

#include "dynamixel/protocol2.h"

#include "protocol1_front_end.h"
#include "protocol2_params.h"

namespace doppel::dynamixel {

namespace {

constexpr uint8_t kSecondaryIdOff = 253;  // Secondary ID 253..255 = disabled

}  // namespace

bool Protocol2Device::answers(uint8_t instruction_code) const noexcept {
  const bool reads = instruction_code == instruction::kRead || instruction_code == instruction::kSyncRead ||
                     instruction_code == instruction::kFastSyncRead || instruction_code == instruction::kBulkRead ||
                     instruction_code == instruction::kFastBulkRead;
  return detail::status_returned(table_[x430::kStatusReturnLevel], instruction_code, reads);
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
    handle_protocol1(packet, response);  // Protocol Type 1
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
        const uint16_t length = detail::le16(p + 2);
        if (length == 0) {
          error = p2_error::kDataLength;
        } else if (!read(detail::le16(p), length, scratch_.data())) {
          error = p2_error::kAccess;  // outside the table: Access Error without data (§2.4)
        } else if (answer) {
          reply(0, scratch_.data(), length, response);
          return;
        }
      }
      break;
    }
    case instruction::kWrite:
      error = n < 3 ? p2_error::kDataLength : write(detail::le16(p), p + 2, n - 2, true, via_secondary);
      break;
    case instruction::kRegWrite:
      error = n < 3 ? p2_error::kDataLength : write(detail::le16(p), p + 2, n - 2, false, via_secondary);
      if (error == 0) {
        hold_reg_write(detail::le16(p), p + 2, n - 2);
      }
      break;
    case instruction::kAction:
      error = held_write_.held ? apply_reg_write(via_secondary) : p2_error::kInstruction;
      break;
    case instruction::kClear:
      error = maintenance_error(packet);
      if (error == 0) {
        error = clear_multi_turn();
      }
      break;
    case instruction::kFactoryReset:
    case instruction::kReboot:
    case instruction::kControlTableBackup:
      error = maintenance_error(packet);
      if (error != 0) {
        break;
      }
      if (answer) {
        reply(0, nullptr, 0, response);  // status with the old ID and rate, then the reset
      }
      run_maintenance(packet);
      return;
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

}  // namespace doppel::dynamixel
