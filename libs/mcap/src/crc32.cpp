#include <zlib.h>

#include <algorithm>

#include "format.h"

namespace doppel::mcap::format {

uint32_t crc32(uint32_t crc, const void* data, std::size_t size) {
  // zlib's crc32 is the IEEE CRC-32 the spec names; its length argument is 32-bit.
  const auto* p = static_cast<const Bytef*>(data);
  uLong c = crc;
  while (size > 0) {
    const std::size_t n = std::min<std::size_t>(size, std::size_t{1} << 30);
    c = ::crc32(c, p, static_cast<uInt>(n));
    p += n;
    size -= n;
  }
  return static_cast<uint32_t>(c);
}

}  // namespace doppel::mcap::format
