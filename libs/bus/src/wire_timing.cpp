#include "bus/wire_timing.h"

#include <algorithm>
#include <stdexcept>

namespace doppel::bus {

WireTiming::WireTiming(TimingMode mode, int64_t processing_ns) : mode_(mode), processing_ns_(processing_ns) {
  if (processing_ns < 0) throw std::invalid_argument("WireTiming: processing_ns must be >= 0");
}

WireSpan WireTiming::host_bytes(int64_t t_seen_ns, std::size_t n, uint32_t baud_bps) noexcept {
  if (mode_ == TimingMode::kFast) return WireSpan{t_seen_ns, t_seen_ns, 0};
  WireSpan span;
  span.start_ns = std::max(t_seen_ns, wire_free_at_ns_);
  span.baud_bps = baud_bps;
  span.end_ns = span.start_ns + wire_duration_ns(n, baud_bps);
  wire_free_at_ns_ = span.end_ns;
  return span;
}

void WireTiming::begin_reply(int64_t instruction_end_ns) noexcept {
  instruction_end_ns_ = instruction_end_ns;
  previous_status_end_ns_ = instruction_end_ns;
  have_previous_status_ = false;
}

WireSpan WireTiming::status(std::size_t n, uint32_t return_delay_us, bool after_previous, uint32_t baud_bps,
                            int64_t extra_delay_ns, bool continues_previous) noexcept {
  if (mode_ == TimingMode::kFast) return WireSpan{instruction_end_ns_, instruction_end_ns_, 0};
  const int64_t delay_ns = processing_ns_ + static_cast<int64_t>(return_delay_us) * 1000 + std::max<int64_t>(extra_delay_ns, 0);
  const int64_t origin_ns = (after_previous && have_previous_status_) ? previous_status_end_ns_ : instruction_end_ns_;
  WireSpan span;
  span.start_ns = (continues_previous && have_previous_status_) ? previous_status_end_ns_ : origin_ns + delay_ns;
  if (have_previous_status_) span.start_ns = std::max(span.start_ns, previous_status_end_ns_);
  span.baud_bps = baud_bps;
  span.end_ns = span.start_ns + wire_duration_ns(n, baud_bps);
  previous_status_end_ns_ = span.end_ns;
  have_previous_status_ = true;
  wire_free_at_ns_ = std::max(wire_free_at_ns_, span.end_ns);
  return span;
}

void WireTiming::reset() noexcept {
  wire_free_at_ns_ = INT64_MIN;
  have_previous_status_ = false;
}

}  // namespace doppel::bus
