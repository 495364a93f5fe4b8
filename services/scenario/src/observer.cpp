#include "observer.h"

#include <algorithm>
#include <cmath>
#include <random>

namespace doppel::scenario {

std::vector<Event> schedule(const Scenario& scenario, uint64_t seed) {
  std::mt19937_64 random(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const auto at = [&](double time_s, double spread_s) {
    const double t = time_s + (spread_s > 0.0 ? spread_s * unit(random) : 0.0);
    return static_cast<int64_t>(std::ceil(t * 1e9 / static_cast<double>(kStepNs) - 1e-9)) * kStepNs;
  };
  std::vector<Event> events;
  for (std::size_t i = 0; i < scenario.pushes.size(); ++i) {
    events.push_back({at(scenario.pushes[i].time_s, scenario.pushes[i].time_spread_s), true, i});
  }
  for (std::size_t i = 0; i < scenario.balls.size(); ++i) {
    events.push_back({at(scenario.balls[i].time_s, scenario.balls[i].time_spread_s), false, i});
  }
  std::stable_sort(events.begin(), events.end(), [](const Event& a, const Event& b) { return a.at_ns < b.at_ns; });
  return events;
}

}  // namespace doppel::scenario
