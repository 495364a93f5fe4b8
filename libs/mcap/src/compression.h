#pragma once
// Chunk compression as the MCAP registry names it: "zstd" (a zstd frame), "lz4" (an LZ4 *frame*,
// not a raw block) and "" (stored). Private to mcap/.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include "mcap/mcap.h"

namespace doppel::mcap::compression {

// The chunk's `compression` field for `c`.
std::string_view name(Compression c);

// Compresses chunk records; keeps its contexts between chunks.
class Compressor {
 public:
  explicit Compressor(Compression c);
  ~Compressor();
  Compressor(const Compressor&) = delete;
  Compressor& operator=(const Compressor&) = delete;
  // `out` = `in` compressed (a copy for kNone). Throws std::runtime_error when the library fails.
  void compress(std::string_view in, std::string& out);

 private:
  Compression c_;
  struct Contexts;
  std::unique_ptr<Contexts> contexts_;
};

// The largest decompressed chunk the reader accepts (bytes): bounds what a corrupt size field or a
// compression bomb can make it allocate.
inline constexpr uint64_t kMaxUncompressedBytes = uint64_t{1} << 30;

// `out` = `in` decompressed with `compression` ("zstd", "lz4", ""), exactly `uncompressed_size`
// bytes. Output grows with what the stream really yields, never straight to a claimed size.
// Throws std::runtime_error saying what is wrong (unknown compression, corrupt stream, size
// mismatch, too large).
void decompress(std::string_view compression, std::string_view in, uint64_t uncompressed_size, std::string& out);

}  // namespace doppel::mcap::compression
