#include "analyzer/instruction.h"

#include <array>
#include <cstdio>

#include "dynamixel/packet.h"
#include "dynamixel/protocol1.h"
#include "dynamixel/protocol2.h"

namespace doppel::analyzer {

namespace ins = dynamixel::instruction;

namespace {

template <class Parser>
Instruction decode_with(Parser& parser, uint32_t protocol, std::span<const uint8_t> bytes) {
  Instruction out;
  out.protocol = protocol;
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    if (parser.push(bytes[i]) == Parser::Result::kPacket) {
      if (i + 1 != bytes.size()) return out;  // more than one packet: not framed
      const auto& p = parser.packet();
      out.framed = true;
      out.id = p.id;
      out.code = p.instruction;
      out.params.assign(p.params.begin(), p.params.begin() + p.param_count);
    }
  }
  return out;
}

uint16_t le16(const std::vector<uint8_t>& p, std::size_t at) {
  return static_cast<uint16_t>(p[at] | (p[at + 1] << 8));
}

// One device's piece of a multi-device instruction's parameters: [begin, end) of params.
struct Piece {
  Addressed device;
  std::size_t begin = 0;
  std::size_t end = 0;
};

// Splits the parameters into the common prefix (returned as its length) and one piece per device.
// False when they do not parse.
bool pieces(const Instruction& in, std::size_t& prefix, std::vector<Piece>& out) {
  const auto& p = in.params;
  const std::size_t n = p.size();
  out.clear();
  auto fixed_list = [&](std::size_t head, std::size_t each, auto&& fill) {
    if (n < head || (n - head) % each != 0) return false;
    prefix = head;
    for (std::size_t at = head; at < n; at += each) {
      Piece piece;
      piece.begin = at;
      piece.end = at + each;
      fill(piece);
      out.push_back(piece);
    }
    return true;
  };
  if (in.protocol == 2) {
    switch (in.code) {
      case ins::kSyncRead:
      case ins::kFastSyncRead: {
        if (n < 4) return false;
        const uint16_t length = le16(p, 2);
        return fixed_list(4, 1, [&](Piece& piece) { piece.device = {p[piece.begin], length}; });
      }
      case ins::kSyncWrite: {
        if (n < 4) return false;
        const uint16_t length = le16(p, 2);
        return fixed_list(4, std::size_t{1} + length, [&](Piece& piece) { piece.device = {p[piece.begin], 0}; });
      }
      case ins::kBulkRead:
      case ins::kFastBulkRead:
        return fixed_list(0, 5, [&](Piece& piece) { piece.device = {p[piece.begin], le16(p, piece.begin + 3)}; });
      case ins::kBulkWrite: {
        prefix = 0;
        for (std::size_t at = 0; at < n;) {
          if (n - at < 5) return false;
          const std::size_t each = 5 + le16(p, at + 3);
          if (n - at < each) return false;
          out.push_back(Piece{{p[at], 0}, at, at + each});
          at += each;
        }
        return true;
      }
      default:
        return false;
    }
  }
  switch (in.code) {
    case ins::kSyncWrite: {
      if (n < 2) return false;
      const uint8_t length = p[1];
      return fixed_list(2, std::size_t{1} + length, [&](Piece& piece) { piece.device = {p[piece.begin], 0}; });
    }
    case ins::kBulkRead:  // 0x00, then LEN ID ADDR per device
      if (n < 1) return false;
      return fixed_list(1, 3, [&](Piece& piece) { piece.device = {p[piece.begin + 1], p[piece.begin]}; });
    case ins::kSyncRead:
    case kUsb2axSyncRead: {
      if (n < 2) return false;
      const uint8_t length = p[1];
      return fixed_list(2, 1, [&](Piece& piece) { piece.device = {p[piece.begin], length}; });
    }
    default:
      return false;
  }
}

std::string hex(const uint8_t* b, std::size_t n) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string s;
  s.reserve(2 * n);
  for (std::size_t i = 0; i < n; ++i) {
    s.push_back(kDigits[b[i] >> 4]);
    s.push_back(kDigits[b[i] & 15]);
  }
  return s;
}

}  // namespace

Instruction decode_instruction(uint32_t protocol, std::span<const uint8_t> bytes) {
  if (protocol == 2) {
    dynamixel::Protocol2Parser parser;
    return decode_with(parser, 2, bytes);
  }
  dynamixel::Protocol1Parser parser;
  return decode_with(parser, protocol, bytes);
}

std::string kind_name(uint32_t protocol, uint8_t code) {
  const char* name = nullptr;
  switch (code) {
    case ins::kPing: name = "PING"; break;
    case ins::kRead: name = "READ"; break;
    case ins::kWrite: name = "WRITE"; break;
    case ins::kRegWrite: name = "REG WRITE"; break;
    case ins::kAction: name = "ACTION"; break;
    case ins::kFactoryReset: name = "FACTORY RESET"; break;
    case ins::kReboot: name = "REBOOT"; break;
    case ins::kClear: name = "CLEAR"; break;
    case ins::kControlTableBackup: name = "CONTROL TABLE BACKUP"; break;
    case ins::kSyncRead: name = "SYNC READ"; break;
    case ins::kSyncWrite: name = "SYNC WRITE"; break;
    case ins::kFastSyncRead: name = "FAST SYNC READ"; break;
    case ins::kBulkRead: name = "BULK READ"; break;
    case ins::kBulkWrite: name = "BULK WRITE"; break;
    case ins::kFastBulkRead: name = "FAST BULK READ"; break;
    default: break;
  }
  if (protocol == 1 && code == kUsb2axSyncRead) name = "SYNC READ (USB2AX)";
  char buffer[48];
  if (name == nullptr) {
    std::snprintf(buffer, sizeof buffer, "P%u 0x%02X", protocol, code);
  } else {
    std::snprintf(buffer, sizeof buffer, "P%u %s", protocol, name);
  }
  return buffer;
}

bool is_multi_device(uint32_t protocol, uint8_t code) {
  if (protocol == 2) {
    return code == ins::kSyncRead || code == ins::kSyncWrite || code == ins::kFastSyncRead || code == ins::kBulkRead ||
           code == ins::kBulkWrite || code == ins::kFastBulkRead;
  }
  return code == ins::kSyncWrite || code == ins::kBulkRead || code == ins::kSyncRead || code == kUsb2axSyncRead;
}

bool is_read(uint32_t protocol, uint8_t code) {
  if (code == ins::kPing || code == ins::kRead || code == ins::kSyncRead || code == ins::kBulkRead) return true;
  if (protocol == 2) return code == ins::kFastSyncRead || code == ins::kFastBulkRead;
  return code == kUsb2axSyncRead;
}

bool is_fast_read(uint32_t protocol, uint8_t code) {
  return protocol == 2 && (code == ins::kFastSyncRead || code == ins::kFastBulkRead);
}

std::vector<Addressed> addressed_devices(const Instruction& instruction) {
  std::vector<Addressed> out;
  if (!instruction.framed || !is_multi_device(instruction.protocol, instruction.code)) return out;
  std::size_t prefix = 0;
  std::vector<Piece> list;
  if (!pieces(instruction, prefix, list)) return out;
  for (const Piece& piece : list) out.push_back(piece.device);
  return out;
}

std::string signature(const Instruction& in) {
  char head[32];
  std::snprintf(head, sizeof head, "P%u %02x %02x ", in.protocol, in.id, in.code);
  std::string s = head;
  if (!in.framed) return s + "unframed";
  const auto& p = in.params;
  const bool p2 = in.protocol == 2;
  if (in.code == ins::kWrite || in.code == ins::kRegWrite) {
    const std::size_t address_bytes = p2 ? 2 : 1;
    const std::size_t keep = std::min(address_bytes, p.size());
    return s + hex(p.data(), keep) + "+" + std::to_string(p.size() - keep);
  }
  if (in.code == ins::kSyncWrite || (p2 && in.code == ins::kBulkWrite)) {
    std::size_t prefix = 0;
    std::vector<Piece> list;
    if (!pieces(in, prefix, list)) return s + hex(p.data(), p.size());
    s += hex(p.data(), prefix);
    for (const Piece& piece : list) {
      // SYNC WRITE: the ID; BULK WRITE: ID, address and length.
      s += ":" + hex(p.data() + piece.begin, in.code == ins::kSyncWrite ? 1 : 5);
    }
    return s;
  }
  return s + hex(p.data(), p.size());
}

std::vector<uint8_t> encode_subset(const Instruction& in, const std::function<bool(uint8_t)>& keep) {
  std::vector<uint8_t> out;
  if (!in.framed || !is_multi_device(in.protocol, in.code)) return out;
  std::size_t prefix = 0;
  std::vector<Piece> list;
  if (!pieces(in, prefix, list)) return out;
  std::vector<uint8_t> params(in.params.begin(), in.params.begin() + static_cast<std::ptrdiff_t>(prefix));
  bool any = false;
  for (const Piece& piece : list) {
    if (!keep(piece.device.id)) continue;
    any = true;
    params.insert(params.end(), in.params.begin() + static_cast<std::ptrdiff_t>(piece.begin),
                  in.params.begin() + static_cast<std::ptrdiff_t>(piece.end));
  }
  if (!any) return out;
  // Stuffing can at most grow the parameters by a third; header, LEN and CRC come on top.
  out.resize(params.size() * 2 + 16);
  const std::size_t n =
      in.protocol == 2
          ? dynamixel::encode_protocol2_instruction(in.id, in.code, params.data(), params.size(), out.data(), out.size())
          : dynamixel::encode_protocol1_instruction(in.id, in.code, params.data(), params.size(), out.data(), out.size());
  out.resize(n);
  return out;
}

}  // namespace doppel::analyzer
