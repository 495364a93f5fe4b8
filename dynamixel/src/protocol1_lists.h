#pragma once
// Private helpers shared by the two Protocol 1.0 firmwares (protocol1_device.cpp and the Protocol
// 1.0 front end of protocol2_device.cpp): finding a device's own entry in the broadcast lists of
// SYNC WRITE and BULK READ (reference §1.2). Not part of the public API.

#include <bitset>
#include <cstddef>
#include <cstdint>

#include "dynamixel/packet.h"

namespace doppel::dynamixel::detail {

// SYNC WRITE params are [start, length, then (ID, length data bytes) per device]. Returns the data
// bytes listed for `id`, or nullptr when the list is malformed (no device can find its block) or
// does not list `id`. rt-safe.
inline const uint8_t* p1_sync_write_data(const InstructionPacket& packet, uint8_t id) noexcept {
  const std::size_t n = packet.param_count;
  if (n < 2) {
    return nullptr;
  }
  const std::size_t length = packet.params[1];
  if (length == 0 || (n - 2) % (length + 1) != 0) {
    return nullptr;
  }
  for (std::size_t block = 2; block < n; block += length + 1) {
    if (packet.params[block] == id) {
      return &packet.params[block + 1];
    }
  }
  return nullptr;
}

// BULK READ params are [0x00, then (length, ID, address) per device]. Returns the block listed for
// `id` and sets `position` to the number of devices that answer before it; only an ID's first block
// counts, so a repeated ID takes no place in the reply chain. nullptr when the list is malformed
// or does not list `id`. rt-safe.
inline const uint8_t* p1_bulk_read_block(const InstructionPacket& packet, uint8_t id, uint16_t& position) noexcept {
  const std::size_t n = packet.param_count;
  if (n < 1 || (n - 1) % 3 != 0) {
    return nullptr;
  }
  std::bitset<256> seen;
  position = 0;
  for (std::size_t i = 1; i < n; i += 3) {
    const uint8_t listed_id = packet.params[i + 1];
    if (seen.test(listed_id)) {
      continue;
    }
    seen.set(listed_id);
    if (listed_id == id) {
      return &packet.params[i];
    }
    ++position;
  }
  return nullptr;
}

}  // namespace doppel::dynamixel::detail
