#pragma once
// The text of an FTDI latency-timer file, shared by the file Doppel keeps beside each link
// (bus/latency_timer_files.h) and the preload library that lets a driver reach it under the sysfs
// name (shim/). Read as Linux's ftdi_sio `latency_timer_store` reads the real file: kstrtou8 in
// base 10 (an optional '+', decimal digits, one optional trailing newline); Doppel also requires
// the FTDI range 1..255 ms (FTDI AN232B-04 §3.3: "from 1ms to 255ms").

#include <cstdint>
#include <optional>
#include <string_view>

namespace doppel {

inline constexpr uint32_t kMinLatencyTimerMs = 1;
inline constexpr uint32_t kMaxLatencyTimerMs = 255;

// The latency in ms that `text` holds, or nullopt when it is not one number in 1..255 (empty,
// spaces, signs other than a leading '+', more than one trailing newline, out of range). rt-safe.
inline std::optional<uint32_t> parse_latency_timer_ms(std::string_view text) noexcept {
  if (!text.empty() && text.back() == '\n') text.remove_suffix(1);
  if (!text.empty() && text.front() == '+') text.remove_prefix(1);
  if (text.empty()) return std::nullopt;
  uint32_t value = 0;
  for (const char c : text) {
    if (c < '0' || c > '9') return std::nullopt;
    value = value * 10 + static_cast<uint32_t>(c - '0');
    if (value > kMaxLatencyTimerMs) return std::nullopt;
  }
  if (value < kMinLatencyTimerMs) return std::nullopt;
  return value;
}

}  // namespace doppel
