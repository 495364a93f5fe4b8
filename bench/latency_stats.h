#pragma once
// Percentiles of measured durations, for the end-to-end bus benchmarks.

#include <algorithm>
#include <cstddef>
#include <vector>

namespace doppel::bench {

struct Percentiles {
  double p50 = 0.0;
  double p99 = 0.0;
  double p999 = 0.0;
  double max = 0.0;
  std::size_t count = 0;
};

// Nearest-rank percentiles of `samples` (any unit); sorts a copy.
inline Percentiles percentiles(std::vector<double> samples) {
  Percentiles out;
  out.count = samples.size();
  if (samples.empty()) {
    return out;
  }
  std::sort(samples.begin(), samples.end());
  auto rank = [&](double q) {
    std::size_t index = static_cast<std::size_t>(q * static_cast<double>(samples.size() - 1) + 0.5);
    return samples[std::min(index, samples.size() - 1)];
  };
  out.p50 = rank(0.50);
  out.p99 = rank(0.99);
  out.p999 = rank(0.999);
  out.max = samples.back();
  return out;
}

}  // namespace doppel::bench
