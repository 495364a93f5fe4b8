#pragma once
// What the MCAP tests share: a scratch directory, the messages a test writes (so it can compare
// what it reads back) and byte encoders written from the spec's serialization section, apart from
// the library's own.

#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "mcap/mcap.h"

namespace doppel::mcap::test {

// A fresh directory under the system's temp dir, removed with everything in it at scope end.
class ScratchDir {
 public:
  ScratchDir() {
    std::string pattern = (std::filesystem::temp_directory_path() / "doppel-mcap-XXXXXX").string();
    path_ = ::mkdtemp(pattern.data());
  }
  ~ScratchDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  std::string file(const std::string& name) const { return (path_ / name).string(); }

 private:
  std::filesystem::path path_;
};

// One written message, as a test remembers it.
struct Written {
  uint16_t channel_id = 0;
  uint32_t sequence = 0;
  uint64_t log_time_ns = 0;
  uint64_t publish_time_ns = 0;
  std::vector<uint8_t> data;
  std::size_t order = 0;  // write order: the tie-break of equal log times
};

inline bool operator==(const Written& a, const Written& b) {
  return a.channel_id == b.channel_id && a.sequence == b.sequence && a.log_time_ns == b.log_time_ns &&
         a.publish_time_ns == b.publish_time_ns && a.data == b.data;
}

// `w` in log-time order, ties in write order (what Reader::for_each_message promises).
inline std::vector<Written> in_log_time_order(std::vector<Written> w) {
  std::stable_sort(w.begin(), w.end(), [](const Written& a, const Written& b) { return a.log_time_ns < b.log_time_ns; });
  return w;
}

// Everything `reader` yields for `options`.
inline std::vector<Written> read_all(const Reader& reader, const ReadOptions& options = {}) {
  std::vector<Written> out;
  reader.for_each_message(
      [&](const Message& m) {
        out.push_back({m.channel_id, m.sequence, m.log_time_ns, m.publish_time_ns,
                       std::vector<uint8_t>(m.data.begin(), m.data.end()), out.size()});
        return true;
      },
      options);
  return out;
}

inline std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

inline void write_file(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

// A test-name label for `c`.
inline std::string label(Compression c) {
  return c == Compression::kNone ? "none" : (c == Compression::kZstd ? "zstd" : "lz4");
}

// Little-endian fields and length-prefixed strings, from the spec's "Serialization" section.
inline std::string le(uint64_t v, int bytes) {
  std::string s;
  for (int i = 0; i < bytes; ++i) s.push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
  return s;
}
inline std::string str(const std::string& s) { return le(s.size(), 4) + s; }
inline std::string record(uint8_t op, const std::string& content) {
  return std::string(1, static_cast<char>(op)) + le(content.size(), 8) + content;
}

}  // namespace doppel::mcap::test
