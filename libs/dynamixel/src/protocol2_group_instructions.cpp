// SYNC and BULK READ / WRITE and the FAST reads: finding the device's block and its place in the reply chain.
#include <algorithm>
#include <bitset>

#include "dynamixel/protocol2_device.h"

#include "protocol2_params.h"

namespace doppel::dynamixel {

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
  const uint16_t length = detail::le16(p + 2);
  const auto devices = static_cast<uint32_t>(seen.count());
  chain_reply(position, fast, length * devices, devices, detail::le16(p), length, response);
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
    total += detail::le16(p + i + 3);
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
  chain_reply(position, fast, total, static_cast<uint32_t>(seen.count()), detail::le16(mine + 1), detail::le16(mine + 3), response);
}

void Protocol2Device::handle_sync_write(const InstructionPacket& packet) noexcept {
  const std::size_t n = packet.param_count;
  if (n < 4) {
    return;
  }
  const uint8_t* p = packet.params.data();
  const std::size_t length = detail::le16(p + 2);
  if (length == 0 || (n - 4) % (length + 1) != 0) {
    return;  // malformed: no device can find its block
  }
  const uint8_t own_id = id();
  for (std::size_t block = 4; block < n; block += length + 1) {
    if (p[block] == own_id) {
      ++counters_.handled;
      on_communication();
      if (write(detail::le16(p), p + block + 1, length, true, false) != 0) {
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
    const std::size_t length = detail::le16(p + i + 3);
    if (length == 0 || i + 5 + length > n) {
      return;  // the list is broken from here on
    }
    if (p[i] == own_id) {
      ++counters_.handled;
      on_communication();
      if (write(detail::le16(p + i + 1), p + i + 5, length, true, false) != 0) {
        ++counters_.errors;
      }
      return;
    }
    i += 5 + length;
  }
}

}  // namespace doppel::dynamixel
