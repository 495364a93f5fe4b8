// bus_latency: round-trip latency of every Protocol 1.0 instruction through the real `doppel`
// executable, in fast and wire timing, beside the floor of a bare pty echo measured by the same
// client in the same run. In wire mode it also reports the error against the wire model computed
// here from the reference (10 bit times per byte, firmware time, Return Delay Time).
//
//   bus_latency [--samples N] [--quick]
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
#include "interleaved_latency.h"
#include "latency_stats.h"
#include "pty_echo.h"
#include "reference_client.h"

namespace {

using doppel::bench::Percentiles;
using doppel::bench::percentiles;
using namespace doppel::testing;  // the reference client's Bytes, SerialClient, p1_instruction, ...
using Clock = std::chrono::steady_clock;

constexpr uint32_t kBaud = 1000000;
constexpr double kByteUs = 10.0 * 1e6 / kBaud;
constexpr double kProcessingUs = 50.0;      // doppel's default firmware time
constexpr double kReturnDelayUs = 500.0;    // Return Delay Time default 250 x 2 µs

struct Case {
  const char* name;
  Bytes request;
  std::size_t reply_bytes;
  int replies;  // status packets in the reply (BULK READ: one per device, chained)
};

std::vector<Case> cases() {
  return {
      {"PING", p1_instruction(1, 0x01), 6, 1},
      {"READ 2 B (pos)", p1_instruction(1, 0x02, {36, 2}), 8, 1},
      {"READ 18 B (IMU)", p1_instruction(100, 0x02, {26, 18}), 24, 1},
      {"WRITE 2 B (goal)", p1_instruction(1, 0x03, {30, 0x00, 0x08}), 6, 1},
      {"REG_WRITE 2 B", p1_instruction(1, 0x04, {30, 0x00, 0x08}), 6, 1},
      {"ACTION (unicast)", p1_instruction(1, 0x05), 6, 1},
      {"BULK READ 3x2 B", p1_instruction(0xFE, 0x92, {0x00, 2, 1, 36, 2, 2, 36, 2, 3, 36}), 24, 3},
  };
}

// Wire model from the reference: the instruction crosses the wire, each status starts after the
// firmware time plus the Return Delay Time (after the previous status for a BULK READ chain).
double wire_model_us(const Case& c) {
  return static_cast<double>(c.request.size() + c.reply_bytes) * kByteUs +
         c.replies * (kProcessingUs + kReturnDelayUs);
}

std::vector<double> echo_samples;  // every echo of the run, for the floor's own tail

doppel::bench::InterleavedLatency measure(SerialClient& client, SerialClient& echo, const Case& c, int samples,
                                          bool wire) {
  return doppel::bench::measure_interleaved(echo, samples, wire ? wire_model_us(c) : 0.0, echo_samples,
                                            [&]() -> std::optional<double> {
                                              auto start = Clock::now();
                                              Bytes reply = client.transact(c.request, c.reply_bytes, 200);
                                              double us = doppel::bench::elapsed_us(start);
                                              auto statuses = doppel::testing::parse_p1_statuses(reply);
                                              if (reply.size() != c.reply_bytes || !statuses ||
                                                  statuses->size() != static_cast<std::size_t>(c.replies)) {
                                                return std::nullopt;
                                              }
                                              return us;
                                            });
}

}  // namespace

int main(int argc, char** argv) {
  // --rt: client, echo and Doppel's bus threads all run SCHED_FIFO (priority 50), as a tuned
  // control computer would; without it, all use normal scheduling.
  const std::optional<doppel::bench::LatencyOptions> options =
      doppel::bench::start_latency_tool(argc, argv, "bus_latency", 50);
  if (!options) {
    return 2;
  }
  const bool realtime = options->realtime;
  int failures = 0;
  std::string own_timing;
  doppel::bench::PtyEcho echo_server(realtime ? 50 : 0);
  SerialClient echo(echo_server.path(), kBaud);
  std::printf("Protocol 1.0 at %u bps, robot mx-test, %s scheduling; each Doppel sample alternates with a bare "
              "pty echo (8 B out, 8 B back) through the same client code.\n\n", kBaud, realtime ? "SCHED_FIFO" : "normal");
  doppel::bench::print_latency_header();
  for (const char* mode : {"fast", "wire"}) {
    bool wire = std::strcmp(mode, "wire") == 0;
    DoppelProcess doppel(doppel::bench::doppel_args("mx-test", mode, realtime));
    SerialClient client(doppel.link(), kBaud);
    for (const Case& c : cases()) {
      doppel::bench::InterleavedLatency m =
          measure(client, echo, c, wire ? std::max(options->samples / 2, 20) : options->samples, wire);
      failures += m.failures;
      doppel::bench::print_latency_row(c.name, wire, m, wire_model_us(c));
    }
    if (!doppel::bench::stop_cleanly(doppel)) {
      ++failures;
    }
    if (wire) {
      // Doppel's own timing: when it wrote each status versus when the wire model made it due.
      std::string output = doppel.output();
      std::size_t at = output.find("delivery time minus due time");
      own_timing = at == std::string::npos ? "not reported" : output.substr(at, output.find('\n', at) - at);
    }
  }
  Percentiles all_echoes = percentiles(echo_samples);
  std::printf("\nbare pty echo over all %zu samples of this run: p50 %.1f us, p99 %.1f us, p99.9 %.1f us\n",
              all_echoes.count, all_echoes.p50, all_echoes.p99, all_echoes.p999);
  std::printf("timing error = |round trip - echo p50 - wire model|: what Doppel adds or misses beyond the pty itself\n");
  std::printf("Doppel's own wire-mode %s (from its exit summary, 10 us bins)\n", own_timing.c_str());
  std::printf("failures (timeouts, corrupt replies, unclean exit): %d\n", failures);
  return failures == 0 ? 0 : 1;
}
