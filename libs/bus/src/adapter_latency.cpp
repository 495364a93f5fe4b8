#include "bus/adapter_latency.h"

#include <stdexcept>
#include <string>

namespace doppel::bus {

AdapterLatency::AdapterLatency(uint32_t latency_ms)
    : latency_ms_(latency_ms), period_ns_(static_cast<int64_t>(latency_ms) * 1'000'000) {
  if (latency_ms > kMaxLatencyMs) {
    throw std::invalid_argument("AdapterLatency: latency timer " + std::to_string(latency_ms) +
                                " ms is outside 0..255 ms (0 = no adapter)");
  }
}

}  // namespace doppel::bus
