#pragma once
// The MCAP wire format (https://mcap.dev/spec) shared by the writer and the reader: opcodes, the
// little-endian field encoders and a bounds-checked field decoder. Private to mcap/.

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <map>
#include <stdexcept>
#include <string>
#include <string_view>

namespace doppel::mcap::format {

// The 8 magic bytes that open and close every MCAP file (major version '0').
inline constexpr char kMagic[8] = {'\x89', 'M', 'C', 'A', 'P', '0', '\r', '\n'};
inline constexpr std::size_t kMagicBytes = 8;
// A record's opcode (1 byte) and content length (uint64).
inline constexpr std::size_t kRecordHeaderBytes = 9;
// The Footer record: opcode, length and its 20 content bytes.
inline constexpr std::size_t kFooterContentBytes = 8 + 8 + 4;
inline constexpr std::size_t kFooterRecordBytes = kRecordHeaderBytes + kFooterContentBytes;
// The Data End record: opcode, length and the data section CRC.
inline constexpr std::size_t kDataEndRecordBytes = kRecordHeaderBytes + 4;
// Message record fields before the payload: channel_id, sequence, log_time, publish_time.
inline constexpr std::size_t kMessagePrefixBytes = 2 + 4 + 8 + 8;

enum Op : uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kMessageIndex = 0x07,
  kChunkIndex = 0x08,
  kAttachment = 0x09,
  kAttachmentIndex = 0x0A,
  kStatistics = 0x0B,
  kMetadata = 0x0C,
  kMetadataIndex = 0x0D,
  kSummaryOffset = 0x0E,
  kDataEnd = 0x0F,
};

// CRC-32 (IEEE 802.3, the one the spec names), continued from `crc` (0 to start).
uint32_t crc32(uint32_t crc, const void* data, std::size_t size);

inline void put_u8(std::string& out, uint8_t v) { out.push_back(static_cast<char>(v)); }
inline void put_u16(std::string& out, uint16_t v) {
  for (int i = 0; i < 2; ++i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
}
inline void put_u32(std::string& out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
}
inline void put_u64(std::string& out, uint64_t v) {
  for (int i = 0; i < 8; ++i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
}
inline void set_u64(std::string& out, std::size_t at, uint64_t v) {
  for (int i = 0; i < 8; ++i) out[at + i] = static_cast<char>((v >> (8 * i)) & 0xFF);
}
inline void put_string(std::string& out, std::string_view s) {
  put_u32(out, static_cast<uint32_t>(s.size()));
  out.append(s);
}
inline void put_string_map(std::string& out, const std::map<std::string, std::string>& m) {
  std::string body;
  for (const auto& [k, v] : m) {
    put_string(body, k);
    put_string(body, v);
  }
  put_u32(out, static_cast<uint32_t>(body.size()));
  out.append(body);
}
// Starts a record: opcode and a length placeholder; returns where the length goes.
inline std::size_t begin_record(std::string& out, uint8_t op) {
  put_u8(out, op);
  const std::size_t at = out.size();
  put_u64(out, 0);
  return at;
}
// Fills in the length of the record begun at `length_at`.
inline void end_record(std::string& out, std::size_t length_at) { set_u64(out, length_at, out.size() - length_at - 8); }

// A field that does not fit in its record; `what` names the field.
struct Truncated : std::runtime_error {
  using std::runtime_error::runtime_error;
};

inline uint64_t get_le(const char* p, int bytes) {
  uint64_t v = 0;
  for (int i = bytes - 1; i >= 0; --i) v = (v << 8) | static_cast<uint8_t>(p[i]);
  return v;
}

// Reads the fields of one record's content in order; every read is checked against its end and
// throws Truncated naming the field.
class Fields {
 public:
  explicit Fields(std::string_view content) : data_(content) {}
  uint8_t u8(const char* what) { return static_cast<uint8_t>(get_le(take(1, what), 1)); }
  uint16_t u16(const char* what) { return static_cast<uint16_t>(get_le(take(2, what), 2)); }
  uint32_t u32(const char* what) { return static_cast<uint32_t>(get_le(take(4, what), 4)); }
  uint64_t u64(const char* what) { return get_le(take(8, what), 8); }
  std::string_view bytes(std::size_t n, const char* what) { return {take(n, what), n}; }
  std::string_view string(const char* what) { return bytes(u32(what), what); }
  std::map<std::string, std::string> string_map(const char* what) {
    Fields body(bytes(u32(what), what));
    std::map<std::string, std::string> m;
    while (body.left() > 0) {
      std::string key(body.string(what));
      m.emplace(std::move(key), std::string(body.string(what)));
    }
    return m;
  }
  std::map<uint16_t, uint64_t> u16_u64_map(const char* what) {
    Fields body(bytes(u32(what), what));
    std::map<uint16_t, uint64_t> m;
    while (body.left() > 0) {
      const uint16_t key = body.u16(what);
      m[key] = body.u64(what);
    }
    return m;
  }
  std::string_view rest() { return bytes(left(), "data"); }
  std::size_t left() const { return data_.size() - pos_; }
  std::size_t position() const { return pos_; }

 private:
  const char* take(std::size_t n, const char* what) {
    if (n > left()) throw Truncated(std::string(what) + " runs past the end of its record");
    const char* p = data_.data() + pos_;
    pos_ += n;
    return p;
  }
  std::string_view data_;
  std::size_t pos_ = 0;
};

}  // namespace doppel::mcap::format
