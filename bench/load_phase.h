#pragma once
// One measuring phase of the load benchmarks (viewer_load, record_load): a client reads servo 1's
// Present Position (READ 2 B) back to back against a running doppel, timing each round trip, and the
// simulation's missed 1 ms ticks and simulated time come from its /api/state before and after.
// Shared so that both tools measure and print exactly the same way.

#include <httplib.h>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <vector>

#include <nlohmann/json.hpp>

#include "latency_stats.h"
#include "reference_client.h"

namespace doppel::bench {

using PhaseClock = std::chrono::steady_clock;

struct Phase {
  std::vector<double> latencies_us;
  int failures = 0;
  uint64_t missed_ticks = 0;
  double sim_s = 0.0;
  double wall_s = 0.0;
};

inline nlohmann::json state(int port) {
  httplib::Client client("127.0.0.1", port);
  client.set_read_timeout(std::chrono::seconds(10));
  const httplib::Result result = client.Get("/api/state");
  if (!result || result->status != 200) throw std::runtime_error("GET /api/state failed");
  return nlohmann::json::parse(result->body);
}

inline Phase measure(doppel::testing::SerialClient& client, int port, double seconds) {
  Phase phase;
  const nlohmann::json before = state(port);
  const doppel::testing::Bytes request = doppel::testing::p1_instruction(1, 0x02, {36, 2});
  const auto start = PhaseClock::now();
  while (std::chrono::duration<double>(PhaseClock::now() - start).count() < seconds) {
    const auto t0 = PhaseClock::now();
    // 2 s: a late answer is a long round trip, counted as one; only none at all is a failure (a
    // shorter wait would also leave the late status behind as the next request's "answer").
    const doppel::testing::Bytes reply = client.transact(request, 8, 2000);
    const double us = std::chrono::duration<double, std::micro>(PhaseClock::now() - t0).count();
    if (reply.size() == 8) {
      phase.latencies_us.push_back(us);
    } else {
      ++phase.failures;
    }
  }
  phase.wall_s = std::chrono::duration<double>(PhaseClock::now() - start).count();
  const nlohmann::json after = state(port);
  phase.missed_ticks = after["missed_ticks"].get<uint64_t>() - before["missed_ticks"].get<uint64_t>();
  phase.sim_s = after["sim_time_s"].get<double>() - before["sim_time_s"].get<double>();
  return phase;
}


inline void print_row(const char* name, const Phase& p) {
  const Percentiles q = percentiles(p.latencies_us);
  std::printf("| %s | %zu | %.1f | %.1f | %.1f | %.1f | %d | %llu | %.2f | %.3f |\n", name, q.count, q.p50, q.p99, q.p999,
              q.max, p.failures, static_cast<unsigned long long>(p.missed_ticks),
              static_cast<double>(p.missed_ticks) / p.wall_s, p.sim_s / p.wall_s);
}

inline void add(Phase& total, const Phase& p) {
  total.latencies_us.insert(total.latencies_us.end(), p.latencies_us.begin(), p.latencies_us.end());
  total.failures += p.failures;
  total.missed_ticks += p.missed_ticks;
  total.sim_s += p.sim_s;
  total.wall_s += p.wall_s;
}

}  // namespace doppel::bench
