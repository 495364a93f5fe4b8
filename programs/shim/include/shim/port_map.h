#pragma once
// What doppel-run tells its preload library: which device paths a program may hard-code
// (/dev/ttyUSB0, /dev/U2D2, ...) open which of Doppel's port links. The launcher writes the map into
// one environment variable, the library parses it once when it loads; both use this parser, which
// never allocates (the library parses before the program's main, maybe before malloc is usable)
// and never throws. Also the one place that knows the sysfs names of an FTDI latency timer.
//
// Format of kPortsVariable: "DEVICE=LINK[:DEVICE=LINK]...", both absolute paths, DEVICE without
// '=' or ':', LINK without ':' (as PATH, which cannot hold a ':' either); at most kMaxMappings
// entries of at most kMaxPathBytes - 1 bytes per path; a device mapped once.

#include <array>
#include <cstddef>
#include <string_view>

namespace doppel::shim {

inline constexpr const char* kPortsVariable = "DOPPEL_SHIM_PORTS";
inline constexpr std::size_t kMaxMappings = 32;
inline constexpr std::size_t kMaxPathBytes = 256;

struct Mapping {
  std::array<char, kMaxPathBytes> device{};  // absolute path the program opens, NUL-terminated
  std::array<char, kMaxPathBytes> link{};    // absolute path of Doppel's port link, NUL-terminated
};

class PortMap {
 public:
  // Replaces the map with `spec`. False on bad input; error() then says what and where (entry
  // number and text), and the map is empty. rt-safe (no allocation).
  bool parse(std::string_view spec) noexcept;

  std::size_t size() const noexcept { return size_; }
  const Mapping& operator[](std::size_t i) const noexcept { return mappings_[i]; }
  // The entry whose device is `path` exactly, or -1. rt-safe.
  int find_device(std::string_view path) const noexcept;
  // Sentence for the user after a failed parse(); "" after a good one.
  const char* error() const noexcept { return error_.data(); }

 private:
  bool fail(const char* format, std::size_t entry, std::string_view text) noexcept;

  std::array<Mapping, kMaxMappings> mappings_{};
  std::size_t size_ = 0;
  std::array<char, 512> error_{};
};

// The tty name in an FTDI latency-timer path as Linux's ftdi_sio publishes it
// ("/sys/bus/usb-serial/devices/ttyUSB0/latency_timer" or "/sys/class/tty/ttyUSB0/device/latency_timer"
// -> "ttyUSB0"); empty for any other path. rt-safe.
std::string_view latency_timer_tty(std::string_view path) noexcept;

// The last path component of `path` ("/dev/ttyUSB0" -> "ttyUSB0"). rt-safe.
std::string_view base_name(std::string_view path) noexcept;

}  // namespace doppel::shim
