#pragma once
// The measurement both bus_latency tools (bus_latency, p2_bus_latency) share: each Doppel
// transaction alternates with one bare pty echo round trip through the same client code, so machine
// load hits both alike, and the echo's median is the floor that the wire model's error is measured
// above. Also their common command line, Doppel arguments and result table.

#include <pthread.h>
#include <sched.h>
#include <sys/wait.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <string>
#include <vector>

#include "doppel_process.h"
#include "latency_stats.h"
#include "reference_client.h"
#include "tool_command_line.h"

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

// The command line both tools take: [--samples N] [--quick] [--rt].
struct LatencyOptions {
  int samples = 2000;     // Doppel transactions per instruction in fast mode
  bool realtime = false;  // --rt: SCHED_FIFO 50 for client, echo and Doppel's bus threads
};

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

// Parses the command line of `tool` (--quick means `quick_samples`) and, with --rt, puts this thread
// on SCHED_FIFO 50 (run_realtime()). nullopt, after saying why, on a bad command line, after --help's
// usage, or on a refused --rt: the tool then exits with 2.
inline std::optional<LatencyOptions> start_latency_tool(int argc, char** argv, const char* tool, int quick_samples) {
  LatencyOptions options;
  bool quick = false;
  CLI::App app("Per-instruction latency against doppel", tool);
  CLI::Option* samples = app.add_option("--samples", options.samples)->transform(positive_number<int>());
  app.add_flag("--quick", quick)->excludes(samples);
  app.add_flag("--rt", options.realtime);
  const std::string usage = std::string("usage: ") + tool + " [--samples N] [--quick] [--rt]\n";
  if (parse_command_line(app, argc, argv, usage.c_str())) {
    return std::nullopt;
  }
  if (quick) {
    options.samples = quick_samples;
  }
  if (options.realtime && !run_realtime(tool)) {
    return std::nullopt;
  }
  return options;
}

// Doppel's arguments for `robot` in timing `mode` ("fast" or "wire"), its bus threads at SCHED_FIFO 50
// when `realtime`.
inline std::vector<std::string> doppel_args(const char* robot, const char* mode, bool realtime) {
  std::vector<std::string> args{"--robot", robot, "--timing", mode};
  if (realtime) {
    args.insert(args.end(), {"--rt-priority", "50"});
  }
  return args;
}

// The header of the table print_latency_row() fills.
inline void print_latency_header() {
  std::printf("| instruction | timing | p50 us | p99 us | p99.9 us | echo p50 us | p50 / echo p50 | wire model us | timing error p50 us | timing error p99 us | failures |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|\n");
}

// One row: in wire mode with the model and the error against it, in fast mode with the ratio to the echo.
inline void print_latency_row(const char* name, bool wire, const InterleavedLatency& m, double wire_model_us) {
  const Percentiles& rt = m.round_trip_us;
  if (wire) {
    std::printf("| %s | wire | %.1f | %.1f | %.1f | %.1f | - | %.1f | %.1f | %.1f | %d |\n", name, rt.p50, rt.p99,
                rt.p999, m.echo_us.p50, wire_model_us, m.error_us.p50, m.error_us.p99, m.failures);
  } else {
    std::printf("| %s | fast | %.1f | %.1f | %.1f | %.1f | %.2f | - | - | - | %d |\n", name, rt.p50, rt.p99,
                rt.p999, m.echo_us.p50, rt.p50 / m.echo_us.p50, m.failures);
  }
}

// Stops `doppel`; false (after saying so) when it did not exit with status 0.
inline bool stop_cleanly(testing::DoppelProcess& doppel) {
  const int status = doppel.stop();
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    std::printf("doppel did not exit cleanly (status %d)\n", status);
    return false;
  }
  return true;
}

}  // namespace doppel::bench
