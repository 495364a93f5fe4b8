#pragma once
// The timing of a driver's fixed-period cycle in the robots' 60 s end-to-end runs (DARwIn-OP, OP3,
// Wolfgang): every cycle's duration, the errors and the cycles that took longer than the period,
// and one line of percentiles for the log. Timing is printed, not asserted (the machine is shared);
// the tests assert the errors.

#include <algorithm>
#include <cstddef>
#include <cstdio>
#include <string>
#include <vector>

namespace doppel::testing {

class CycleStats {
 public:
  explicit CycleStats(double period_ms, std::size_t expected_cycles = 0) : period_ms_(period_ms) {
    cycle_ms_.reserve(expected_cycles);
  }

  // One cycle that took `ms`; `ok` false counts it as an error.
  void add(double ms, bool ok = true) {
    cycle_ms_.push_back(ms);
    if (ms > period_ms_) ++over_period_;
    if (!ok) ++errors_;
  }
  // An error outside a timed cycle (the driver's start, a line left with bytes on it).
  void add_error() { ++errors_; }

  long cycles() const { return static_cast<long>(cycle_ms_.size()); }
  long errors() const { return errors_; }
  long over_period() const { return over_period_; }

  // The p-quantile (0..1) of the cycle durations: the element at p x (n - 1) of the sorted list;
  // 0 without cycles.
  double percentile(double p) const {
    if (cycle_ms_.empty()) return 0.0;
    std::vector<double> sorted = cycle_ms_;
    std::sort(sorted.begin(), sorted.end());
    return sorted[static_cast<std::size_t>(p * static_cast<double>(sorted.size() - 1))];
  }

  // "7500 cycles, 0 errors, 12 over 8 ms; p50 1.23, p99 4.56, max 7.89 ms"
  std::string summary() const {
    char line[160];
    std::snprintf(line, sizeof line, "%ld cycles, %ld errors, %ld over %g ms; p50 %.2f, p99 %.2f, max %.2f ms",
                  cycles(), errors_, over_period_, period_ms_, percentile(0.5), percentile(0.99), percentile(1.0));
    return line;
  }

 private:
  double period_ms_;
  std::vector<double> cycle_ms_;
  long errors_ = 0;
  long over_period_ = 0;
};

}  // namespace doppel::testing
