// Arbitrary text as everything the preload library (shim/) parses: the port map of
// DOPPEL_SHIM_PORTS, a path it may redirect to a latency-timer file, and the text of that file.
// Must never crash; a parsed map holds only absolute, NUL-terminated, distinct devices and
// absolute links, and a refused one is empty with a sentence saying why.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string_view>

#include "base/latency_timer.h"
#include "shim/port_map.h"
#include "fuzz_check.h"


namespace {

doppel::shim::PortMap map;  // no per-input set-up: parse() replaces the whole map

bool terminated(const std::array<char, doppel::shim::kMaxPathBytes>& path) {
  return std::memchr(path.data(), '\0', path.size()) != nullptr;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  using doppel::shim::PortMap;

  if (map.parse(text)) {
    FUZZ_CHECK(map.size() >= 1 && map.size() <= doppel::shim::kMaxMappings);
    FUZZ_CHECK(std::strlen(map.error()) == 0);
    for (std::size_t i = 0; i < map.size(); ++i) {
      FUZZ_CHECK(terminated(map[i].device) && terminated(map[i].link));
      FUZZ_CHECK(map[i].device[0] == '/' && map[i].link[0] == '/');
      FUZZ_CHECK(map.find_device(map[i].device.data()) == static_cast<int>(i));
      FUZZ_CHECK(std::strchr(map[i].link.data(), ':') == nullptr);
    }
  } else {
    FUZZ_CHECK(map.size() == 0);
    FUZZ_CHECK(std::strlen(map.error()) > 0 && std::strlen(map.error()) < 512);
  }

  const std::string_view tty = doppel::shim::latency_timer_tty(text);
  FUZZ_CHECK(tty.find('/') == std::string_view::npos);
  FUZZ_CHECK(tty.empty() || (tty.data() >= text.data() && tty.data() + tty.size() <= text.data() + text.size()));

  if (const auto latency_ms = doppel::parse_latency_timer_ms(text)) {
    FUZZ_CHECK(*latency_ms >= 1 && *latency_ms <= 255);
    FUZZ_CHECK(text.find_first_not_of("+0123456789\n") == std::string_view::npos);
  }
  return 0;
}
