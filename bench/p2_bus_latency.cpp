// p2_bus_latency: round-trip latency of every Protocol 2.0 instruction that gets a reply, through
// the real `doppel` executable serving data/robots/fumanoid-x430 (4 Mbps, BOTHER), in fast and wire
// timing, beside a bare pty echo measured alternately by the same client. In wire mode it reports
// the error against the wire model computed here from the reference (10 bit times per byte,
// firmware time, Return Delay Time; FAST reads: one firmware time for the combined status).
// The Protocol 1.0 counterpart is bus_latency.
//
// --rt: client, echo and Doppel's bus threads run SCHED_FIFO (priority 50).
//
//   p2_bus_latency [--samples N] [--quick] [--rt]
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
#include "interleaved_latency.h"
#include "latency_stats.h"
#include "pty_echo.h"
#include "reference_client.h"
#include "reference_client_p2.h"

namespace {

using namespace doppel::testing;  // the reference client's Bytes, SerialClient, p2_instruction, le16, ...
using Clock = std::chrono::steady_clock;

constexpr uint32_t kBaud = 4000000;
constexpr double kByteUs = 10.0 * 1e6 / kBaud;
constexpr double kProcessingUs = 50.0;    // doppel's default firmware time
constexpr double kServoDelayUs = 500.0;   // XM430 Return Delay Time default 250 x 2 µs
constexpr double kBoardDelayUs = 0.0;     // Bit-Bots boards answer at once

struct Case {
  const char* name;
  int bus;                  // ttyDXL<bus> of fumanoid-x430
  Bytes request;
  std::size_t reply_bytes;
  int statuses;             // separate status packets (parsed one by one)
  int reply_slots;          // firmware time + RDT paid this many times
  double return_delay_us;   // per slot
  std::vector<std::size_t> fast_lengths;  // FAST reads: data bytes per block
  double idle_slots_us = 0.0;             // broadcast PING: 3 ms per unused ID below the first answer
  Bytes setup = {};                       // sent (and its 11-byte status read) before every sample
};

Bytes cat(Bytes a, const Bytes& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

std::vector<Case> cases() {
  const Bytes arms = {3, 4, 5, 6, 7, 8};
  const Bytes sync = cat(cat(le16(132), le16(4)), arms);
  Bytes bulk;
  for (uint8_t id : arms) bulk = cat(cat(cat(bulk, {id}), le16(132)), le16(4));
  const std::vector<std::size_t> six(6, 4);
  return {
      {"PING", 1, p2_instruction(3, 0x01), 14, 1, 1, kServoDelayUs, {}},
      {"PING broadcast (IDs 3..8)", 1, p2_instruction(0xFE, 0x01), 6 * 14, 6, 6, kServoDelayUs, {}, 2 * 3000.0},
      {"READ 4 B (position)", 1, p2_instruction(3, 0x02, cat(le16(132), le16(4))), 15, 1, 1, kServoDelayUs, {}},
      {"READ 40 B (IMU)", 0, p2_instruction(241, 0x02, cat(le16(36), le16(40))), 51, 1, 1, kBoardDelayUs, {}},
      {"WRITE 4 B (goal)", 1, p2_instruction(3, 0x03, cat(le16(116), le32(2048))), 11, 1, 1, kServoDelayUs, {}},
      {"REG WRITE 4 B", 1, p2_instruction(3, 0x04, cat(le16(116), le32(2048))), 11, 1, 1, kServoDelayUs, {}},
      {"ACTION (after a REG WRITE)", 1, p2_instruction(3, 0x05), 11, 1, 1, kServoDelayUs, {}, 0.0,
       p2_instruction(3, 0x04, cat(le16(116), le32(2048)))},
      {"FACTORY RESET (0x02)", 1, p2_instruction(4, 0x06, {0x02}), 11, 1, 1, kServoDelayUs, {}},
      {"REBOOT", 1, p2_instruction(3, 0x08), 11, 1, 1, kServoDelayUs, {}},
      {"CLEAR multi-turn", 1, p2_instruction(3, 0x10, {0x01, 0x44, 0x58, 0x4C, 0x22}), 11, 1, 1, kServoDelayUs, {}},
      {"CONTROL TABLE BACKUP", 1, p2_instruction(3, 0x20, {0x01, 0x43, 0x54, 0x52, 0x4C}), 11, 1, 1, kServoDelayUs, {}},
      {"SYNC READ 6x4 B", 1, p2_instruction(0xFE, 0x82, sync), 6 * 15, 6, 6, kServoDelayUs, {}},
      {"FAST SYNC READ 6x4 B", 1, p2_instruction(0xFE, 0x8A, sync), 8 + 6 * 8, 0, 1, kServoDelayUs, six},
      {"BULK READ 6x4 B", 1, p2_instruction(0xFE, 0x92, bulk), 6 * 15, 6, 6, kServoDelayUs, {}},
      {"FAST BULK READ 6x4 B", 1, p2_instruction(0xFE, 0x9A, bulk), 8 + 6 * 8, 0, 1, kServoDelayUs, six},
  };
}

double wire_model_us(const Case& c) {
  return static_cast<double>(c.request.size() + c.reply_bytes) * kByteUs + c.reply_slots * (kProcessingUs + c.return_delay_us) +
         c.idle_slots_us;
}

bool reply_ok(const Case& c, const Bytes& reply) {
  if (reply.size() != c.reply_bytes) return false;
  if (!c.fast_lengths.empty()) return doppel::testing::parse_p2_fast_status(reply, c.fast_lengths).has_value();
  const auto statuses = doppel::testing::parse_p2_statuses(reply);
  if (!statuses || statuses->size() != static_cast<std::size_t>(c.statuses)) return false;
  for (const auto& s : *statuses) {
    if ((s.error & 0x7F) != 0) return false;
  }
  return true;
}

std::vector<double> echo_samples;  // every echo of the run

doppel::bench::InterleavedLatency measure(SerialClient& client, SerialClient& echo, const Case& c, int samples,
                                          bool wire) {
  return doppel::bench::measure_interleaved(echo, samples, wire ? wire_model_us(c) : 0.0, echo_samples,
                                            [&]() -> std::optional<double> {
                                              if (!c.setup.empty()) client.transact(c.setup, 11, 200);
                                              const auto start = Clock::now();
                                              const Bytes reply = client.transact(c.request, c.reply_bytes, 200);
                                              const double us = doppel::bench::elapsed_us(start);
                                              if (!reply_ok(c, reply)) return std::nullopt;
                                              return us;
                                            });
}

}  // namespace

int main(int argc, char** argv) {
  const std::optional<doppel::bench::LatencyOptions> options =
      doppel::bench::start_latency_tool(argc, argv, "p2_bus_latency", 30);
  if (!options) {
    return 2;
  }
  const bool realtime = options->realtime;
  int failures = 0;
  doppel::bench::PtyEcho echo_server(realtime ? 50 : 0);
  SerialClient echo(echo_server.path(), kBaud);
  std::printf("Protocol 2.0 at %u bps (TCSETS2/BOTHER), robot fumanoid-x430 (XM430-W350 RDT 500 us, Bit-Bots IMU RDT 0), %s scheduling; "
              "each sample alternates with a bare pty echo (8 B out, 8 B back) through the same client code.\n\n", kBaud,
              realtime ? "SCHED_FIFO" : "normal");
  doppel::bench::print_latency_header();
  for (const char* mode : {"fast", "wire"}) {
    const bool wire = std::strcmp(mode, "wire") == 0;
    DoppelProcess doppel(doppel::bench::doppel_args("fumanoid-x430", mode, realtime), "ttyDXL3");
    SerialClient bus0(doppel.link("ttyDXL0"), kBaud);
    SerialClient bus1(doppel.link("ttyDXL1"), kBaud);
    for (const Case& c : cases()) {
      // Broadcast PING and 6-device chains pay 6 RDTs: fewer samples keep the run short.
      const int n = wire ? std::max(options->samples / (c.reply_slots > 1 ? 8 : 2), 10) : options->samples;
      const doppel::bench::InterleavedLatency m = measure(c.bus == 0 ? bus0 : bus1, echo, c, n, wire);
      failures += m.failures;
      doppel::bench::print_latency_row(c.name, wire, m, wire_model_us(c));
    }
    if (!doppel::bench::stop_cleanly(doppel)) {
      ++failures;
    }
  }
  std::printf("\ntiming error = |round trip - echo p50 - wire model|: what Doppel adds or misses beyond the pty itself\n");
  std::printf("failures (timeouts, corrupt replies, error statuses, unclean exit): %d\n", failures);
  return failures == 0 ? 0 : 1;
}
