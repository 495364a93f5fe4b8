#pragma once
// How much earlier than a due delivery a bus thread must ask to be woken. A timed wait ends late by
// whatever the machine needs to put the thread on a CPU again: a few µs on an idle bare-metal core,
// tens of µs on a virtual machine whose idle virtual CPU the host has to resume. A fixed busy-wait
// margin that is shorter than that makes every delivery late by the difference, so the thread
// measures how late its own timed wake-ups came and wakes that much earlier.

#include <algorithm>
#include <cstdint>

namespace doppel::bus {

class WakeLead {
 public:
  // `max_ns` bounds the lead (and with it the busy-wait it leads to) when wake-ups come very late.
  explicit WakeLead(int64_t max_ns) noexcept : max_ns_(std::max<int64_t>(max_ns, 0)) {}

  // A timed wait that was to end at `asked_ns` ended at `woke_ns`. The lead follows the upper
  // envelope of the lateness: half-way up to a later wake-up at once (one stall does not set it),
  // down by 1/16 of the gap per earlier one. rt-safe.
  void add(int64_t asked_ns, int64_t woke_ns) noexcept {
    const int64_t late_ns = std::clamp<int64_t>(woke_ns - asked_ns, 0, max_ns_);
    lead_ns_ += late_ns >= lead_ns_ ? (late_ns - lead_ns_ + 1) / 2 : -((lead_ns_ - late_ns) / 16);
  }

  int64_t ns() const noexcept { return lead_ns_; }

 private:
  int64_t max_ns_;
  int64_t lead_ns_ = 0;
};

}  // namespace doppel::bus
