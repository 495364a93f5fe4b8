#pragma once
// The measurement both bus_latency tools share: each Doppel transaction alternates with one bare
// pty echo round trip through the same client code, so machine load hits both alike, and the
// echo's median is the floor that the wire model's error is measured above.

#include <pthread.h>
#include <sched.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <vector>

#include "latency_stats.h"
#include "reference_client.h"

namespace doppel::bench {

struct InterleavedLatency {
  Percentiles round_trip_us;  // Doppel transactions that succeeded
  Percentiles echo_us;        // the echoes taken between them
  Percentiles error_us;       // |round trip - echo p50 - wire model|, when a model was given
  int failures = 0;           // transactions without a correct reply
};

inline double elapsed_us(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - start).count();
}

// Runs `samples` pairs of (echo round trip, `transaction`). `transaction` returns its round trip in
// µs, or nullopt when the reply was wrong or missing. `wire_model_us` <= 0: no error figures.
// Every echo is also appended to `all_echoes_us`.
template <class Transaction>
InterleavedLatency measure_interleaved(testing::SerialClient& echo, int samples, double wire_model_us,
                                       std::vector<double>& all_echoes_us, Transaction&& transaction) {
  const testing::Bytes echo_bytes(8, 0x55);
  std::vector<double> round_trips;
  std::vector<double> echoes;
  InterleavedLatency out;
  for (int i = 0; i < samples; ++i) {
    auto echo_start = std::chrono::steady_clock::now();
    if (echo.transact(echo_bytes, echo_bytes.size(), 200).size() == echo_bytes.size()) {
      echoes.push_back(elapsed_us(echo_start));
      all_echoes_us.push_back(echoes.back());
    }
    if (std::optional<double> us = transaction()) {
      round_trips.push_back(*us);
    } else {
      ++out.failures;
    }
  }
  out.round_trip_us = percentiles(round_trips);
  out.echo_us = percentiles(echoes);
  if (wire_model_us > 0.0) {
    std::vector<double> errors;
    for (double us : round_trips) {
      errors.push_back(std::fabs(us - out.echo_us.p50 - wire_model_us));
    }
    out.error_us = percentiles(errors);
  }
  return out;
}

// --rt: this thread runs SCHED_FIFO 50, like the echo thread and Doppel's bus threads then. False
// (with a message naming `tool`) when the system refuses.
inline bool run_realtime(const char* tool) {
  sched_param param{};
  param.sched_priority = 50;
  if (pthread_setschedparam(pthread_self(), SCHED_FIFO, &param) != 0) {
    std::fprintf(stderr, "%s: SCHED_FIFO refused (needs root or CAP_SYS_NICE)\n", tool);
    return false;
  }
  return true;
}

}  // namespace doppel::bench
