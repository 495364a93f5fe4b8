#pragma once
// Private helper of the Protocol 2.0 device's source files: the little-endian 16-bit fields of
// instruction parameters and Indirect Address items (reference §2.4, §3.7). Not part of the public API.

#include <cstdint>

namespace doppel::dynamixel::detail {

constexpr uint16_t le16(const uint8_t* p) noexcept { return static_cast<uint16_t>(p[0] | (p[1] << 8)); }

}  // namespace doppel::dynamixel::detail
