#include "reference_client_p2.h"

#include <algorithm>
#include <chrono>

namespace doppel::testing {
namespace {

// §2.3 transmit rule applied to the region after LEN.
Bytes stuff(const Bytes& region) {
  Bytes out;
  for (std::size_t i = 0; i < region.size(); ++i) {
    out.push_back(region[i]);
    const std::size_t n = out.size();
    // An FF FF FD that is not itself the tail of an already stuffed FF FF FD FD.
    if (n >= 3 && out[n - 3] == 0xFF && out[n - 2] == 0xFF && out[n - 1] == 0xFD) {
      out.push_back(0xFD);
    }
  }
  return out;
}

// §2.3 receive rule: delete the FD that follows every FF FF FD.
Bytes unstuff(const Bytes& region) {
  Bytes out;
  std::size_t i = 0;
  while (i < region.size()) {
    out.push_back(region[i]);
    const std::size_t n = out.size();
    if (n >= 3 && out[n - 3] == 0xFF && out[n - 2] == 0xFF && out[n - 1] == 0xFD && i + 1 < region.size() &&
        region[i + 1] == 0xFD) {
      ++i;  // skip the stuffing byte
    }
    ++i;
  }
  return out;
}

Bytes frame(uint8_t id, const Bytes& region) {
  const Bytes stuffed = stuff(region);
  Bytes packet = {0xFF, 0xFF, 0xFD, 0x00, id};
  const std::size_t length = stuffed.size() + 2;
  packet.push_back(static_cast<uint8_t>(length & 0xFF));
  packet.push_back(static_cast<uint8_t>(length >> 8));
  packet.insert(packet.end(), stuffed.begin(), stuffed.end());
  const uint16_t crc = p2_crc(packet.data(), packet.size());
  packet.push_back(static_cast<uint8_t>(crc & 0xFF));
  packet.push_back(static_cast<uint8_t>(crc >> 8));
  return packet;
}

}  // namespace

uint16_t p2_crc(const uint8_t* bytes, std::size_t n, uint16_t crc) {
  for (std::size_t i = 0; i < n; ++i) {
    crc = static_cast<uint16_t>(crc ^ (bytes[i] << 8));
    for (int bit = 0; bit < 8; ++bit) {
      crc = static_cast<uint16_t>((crc & 0x8000) != 0 ? (crc << 1) ^ 0x8005 : crc << 1);
    }
  }
  return crc;
}

Bytes le16(uint16_t value) { return {static_cast<uint8_t>(value & 0xFF), static_cast<uint8_t>(value >> 8)}; }

Bytes le32(int32_t value) {
  const auto v = static_cast<uint32_t>(value);
  return {static_cast<uint8_t>(v), static_cast<uint8_t>(v >> 8), static_cast<uint8_t>(v >> 16), static_cast<uint8_t>(v >> 24)};
}

int32_t le32_at(const Bytes& bytes, std::size_t offset) {
  return static_cast<int32_t>(static_cast<uint32_t>(bytes.at(offset)) | (static_cast<uint32_t>(bytes.at(offset + 1)) << 8) |
                              (static_cast<uint32_t>(bytes.at(offset + 2)) << 16) |
                              (static_cast<uint32_t>(bytes.at(offset + 3)) << 24));
}

Bytes p2_instruction(uint8_t id, uint8_t instruction, const Bytes& params) {
  Bytes region = {instruction};
  region.insert(region.end(), params.begin(), params.end());
  return frame(id, region);
}

Bytes p2_status(uint8_t id, uint8_t error, const Bytes& params) {
  Bytes region = {0x55, error};
  region.insert(region.end(), params.begin(), params.end());
  return frame(id, region);
}

std::optional<std::vector<P2Status>> parse_p2_statuses(const Bytes& bytes) {
  std::vector<P2Status> statuses;
  std::size_t i = 0;
  while (i < bytes.size()) {
    if (bytes.size() - i < 11 || bytes[i] != 0xFF || bytes[i + 1] != 0xFF || bytes[i + 2] != 0xFD || bytes[i + 3] != 0x00) {
      return std::nullopt;
    }
    const auto length = static_cast<std::size_t>(bytes[i + 5] | (bytes[i + 6] << 8));
    if (length < 4 || i + 7 + length > bytes.size() || bytes[i + 7] != 0x55) {
      return std::nullopt;
    }
    const std::size_t crc_at = i + 7 + length - 2;
    const uint16_t crc = p2_crc(&bytes[i], crc_at - i);
    if ((crc & 0xFF) != bytes[crc_at] || (crc >> 8) != bytes[crc_at + 1]) {
      return std::nullopt;
    }
    P2Status status;
    status.id = bytes[i + 4];
    status.error = bytes[i + 8];
    // Unstuff the region 0x55 ERR params, then drop 0x55 and ERR.
    const Bytes region = unstuff(Bytes(bytes.begin() + static_cast<long>(i) + 7, bytes.begin() + static_cast<long>(crc_at)));
    status.params.assign(region.begin() + 2, region.end());
    statuses.push_back(std::move(status));
    i += 7 + length;
  }
  return statuses;
}

Bytes receive_p2_statuses(SerialClient& client, std::size_t count, int timeout_ms) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  auto left_ms = [&] {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    return std::max<int>(0, static_cast<int>(left.count()));
  };
  Bytes out;
  for (std::size_t k = 0; k < count; ++k) {
    const Bytes header = client.receive(7, left_ms());
    out.insert(out.end(), header.begin(), header.end());
    if (header.size() < 7 || header[0] != 0xFF || header[1] != 0xFF || header[2] != 0xFD || header[3] != 0x00) {
      break;
    }
    const Bytes rest = client.receive(static_cast<std::size_t>(header[5] | (header[6] << 8)), left_ms());
    out.insert(out.end(), rest.begin(), rest.end());
  }
  return out;
}

Bytes transact_p2(SerialClient& client, const Bytes& request, std::size_t count, int timeout_ms) {
  client.send(request);
  return receive_p2_statuses(client, count, timeout_ms);
}

std::optional<std::vector<P2FastBlock>> parse_p2_fast_status(const Bytes& bytes, const std::vector<std::size_t>& lengths) {
  std::size_t expected_length = 1;
  for (std::size_t x : lengths) {
    expected_length += x + 4;
  }
  if (bytes.size() != 7 + expected_length || bytes[0] != 0xFF || bytes[1] != 0xFF || bytes[2] != 0xFD ||
      bytes[3] != 0x00 || bytes[4] != 0xFE || static_cast<std::size_t>(bytes[5] | (bytes[6] << 8)) != expected_length || bytes[7] != 0x55) {
    return std::nullopt;
  }
  std::vector<P2FastBlock> blocks;
  std::size_t i = 8;
  for (std::size_t x : lengths) {
    P2FastBlock block;
    block.error = bytes[i];
    block.id = bytes[i + 1];
    block.data.assign(bytes.begin() + static_cast<long>(i) + 2, bytes.begin() + static_cast<long>(i + 2 + x));
    const std::size_t crc_at = i + 2 + x;
    const uint16_t crc = p2_crc(bytes.data(), crc_at);  // running CRC from the first FF
    if ((crc & 0xFF) != bytes[crc_at] || (crc >> 8) != bytes[crc_at + 1]) {
      return std::nullopt;
    }
    blocks.push_back(std::move(block));
    i += x + 4;
  }
  return blocks;
}

}  // namespace doppel::testing
