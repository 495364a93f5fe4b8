// p2_bitbots_cycle: the Bit-Bots bus measurement reproduced against the real `doppel` executable.
// 20 XM430-W350 at 4 Mbps with Return Delay Time 0; every control cycle sends a SYNC WRITE of
// Goal Position (4 B each) and a SYNC READ of Present Current + Velocity + Position (126, 10 B
// each), on one bus (20 servos) or on four buses (5 each, one client thread per bus, cycles
// aligned by a barrier as a control loop that waits for all buses). Real hardware reached 398 Hz
// on one bus and 1373 Hz on four. Clients are the reference client (not Doppel's codec).
//
// Timings: "wire, 0 us fw" is the wire-limited case (Doppel's firmware time set to 0, so only bytes
// at 10 bit times count); "wire, 50 us fw" is Doppel's default firmware time per status; "fast"
// answers as soon as possible. Before the rows of each bus count, the same client threads and
// barrier run against bare pty echoes: that floor is subtracted before comparing with the model.
//
// --rt runs the client threads and Doppel's bus threads SCHED_FIFO (priority 50), as a tuned
// control computer would (needs root or CAP_SYS_NICE).
//
// --buses N runs only the rows with N buses: 1 or 4, or 2 (not in the default run), which shows
// how the timing scales with the number of buses served in parallel.
//
//   p2_bitbots_cycle [--seconds S] [--quick] [--rt] [--buses N]
#include <pthread.h>
#include <sched.h>
#include <sys/wait.h>

#include <algorithm>
#include <atomic>
#include <barrier>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "doppel_process.h"
#include "latency_stats.h"
#include "pty_echo.h"
#include "reference_client.h"
#include "reference_client_p2.h"
#include "tool_command_line.h"

#ifndef DOPPEL_BENCH_DIR
#define DOPPEL_BENCH_DIR "bench"
#endif

namespace {

using doppel::bench::Percentiles;
using doppel::bench::percentiles;
using doppel::testing::Bytes;
using doppel::testing::DoppelProcess;
using doppel::testing::le16;
using doppel::testing::le32;
using doppel::testing::p2_instruction;
using doppel::testing::SerialClient;
using Clock = std::chrono::steady_clock;

constexpr uint32_t kBaud = 4000000;
constexpr double kByteUs = 10.0 * 1e6 / kBaud;
constexpr int kServos = 20;
constexpr uint16_t kGoalPosition = 116, kTorqueEnable = 64, kPresentCurrent = 126;
constexpr uint16_t kReadBytes = 10;
constexpr int kRtPriority = 50;

Bytes cat(Bytes a, const Bytes& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

// Bytes on one bus per cycle: SYNC WRITE (LEN = n*5 + 7), SYNC READ (LEN = n + 7), n statuses of
// 11 + 10 bytes (reference §2.4); each packet is LEN + 7 bytes.
std::size_t cycle_bytes(int n) { return static_cast<std::size_t>((n * 5 + 14) + (n + 14) + n * (11 + kReadBytes)); }

double theory_hz(int n, double firmware_us) { return 1e6 / (static_cast<double>(cycle_bytes(n)) * kByteUs + n * firmware_us); }

struct Config {
  int buses;
  const char* timing;  // doppel --timing
  double firmware_us;  // doppel --processing-us
  const char* label;
};

struct Result {
  uint64_t cycles = 0;
  uint64_t errors = 0;
  double seconds = 0.0;
  Percentiles cycle_us;
  int exit_failures = 0;
  int64_t doppel_late_p99_us = -1;  // Doppel's own delivery lateness, worst bus (from its exit summary)
};

// Doppel prints per bus at exit "delivery time minus due time: p50 <= A us, p99 <= B us, ...":
// the worst bus' p99 separates Doppel's timing from the pty's and the client's scheduling.
int64_t worst_p99_us(const std::string& output) {
  int64_t worst = -1;
  const std::string key = "p99 <= ";
  for (std::size_t at = output.find(key); at != std::string::npos; at = output.find(key, at + 1)) {
    worst = std::max<int64_t>(worst, std::atoll(output.c_str() + at + key.size()));
  }
  return worst;
}

bool set_fifo() {
  sched_param param{};
  param.sched_priority = kRtPriority;
  return pthread_setschedparam(pthread_self(), SCHED_FIFO, &param) == 0;
}

// Runs `bus_cycle(b)` (true = the cycle was right) on one client thread per bus, cycles aligned by
// a barrier as a control loop that waits for all buses, for `seconds`.
template <class BusCycle>
Result run_cycles(int buses, double seconds, bool realtime, BusCycle&& bus_cycle) {
  Result result;
  std::atomic<uint64_t> errors{0};
  std::atomic<bool> stop{false};
  std::vector<double> cycle_us;
  cycle_us.reserve(static_cast<std::size_t>(seconds * 20000) + 16);
  Clock::time_point start;
  Clock::time_point last;
  uint64_t cycles = 0;
  bool started = false;
  // The completion step runs once per cycle, after every bus has finished it.
  auto on_cycle = [&]() noexcept {
    const auto now = Clock::now();
    if (!started) {
      started = true;
      start = now;
    } else {
      ++cycles;
      cycle_us.push_back(std::chrono::duration<double, std::micro>(now - last).count());
    }
    last = now;
    if (std::chrono::duration<double>(now - start).count() >= seconds) stop = true;
  };
  std::barrier sync(buses, on_cycle);
  std::vector<std::thread> threads;
  for (int b = 0; b < buses; ++b) {
    threads.emplace_back([&, b] {
      if (realtime) set_fifo();
      for (;;) {
        sync.arrive_and_wait();
        if (stop) break;
        if (!bus_cycle(b)) errors.fetch_add(1);
      }
    });
  }
  for (auto& t : threads) t.join();
  result.cycles = cycles;
  result.errors = errors.load();
  result.seconds = std::chrono::duration<double>(last - start).count();
  result.cycle_us = percentiles(cycle_us);
  return result;
}

// The same cycle structure against bare pty echoes, one per bus (8 B out, 8 B back per cycle):
// what the pty, the client threads and their barrier cost on this machine with no bus behind them.
// Wire time overlaps none of it, so it is the floor to subtract from a wire-mode cycle.
Result echo_cycles(int buses, double seconds, bool realtime) {
  std::vector<std::unique_ptr<doppel::bench::PtyEcho>> echoes;
  std::vector<std::unique_ptr<SerialClient>> clients;
  for (int b = 0; b < buses; ++b) {
    echoes.push_back(std::make_unique<doppel::bench::PtyEcho>(realtime ? kRtPriority : 0));
    clients.push_back(std::make_unique<SerialClient>(echoes.back()->path(), kBaud));
  }
  const Bytes bytes(8, 0x55);
  return run_cycles(buses, seconds, realtime, [&](int b) {
    return clients[static_cast<std::size_t>(b)]->transact(bytes, bytes.size(), 100).size() == bytes.size();
  });
}

Result run(const Config& config, double seconds, bool realtime) {
  const int per_bus = kServos / config.buses;
  const std::string robot = std::string(DOPPEL_BENCH_DIR) + (config.buses == 1   ? "/p2_bitbots_1bus.textproto"
                                                                : config.buses == 2 ? "/p2_bitbots_2bus.textproto"
                                                                                    : "/p2_bitbots_4bus.textproto");
  char firmware[32];
  std::snprintf(firmware, sizeof firmware, "%g", config.firmware_us);
  std::vector<std::string> args{"--robot", robot, "--timing", config.timing, "--processing-us", firmware};
  if (realtime) args.insert(args.end(), {"--rt-priority", std::to_string(kRtPriority)});
  DoppelProcess doppel(args, "ttyDXL" + std::to_string(config.buses - 1));
  std::vector<std::unique_ptr<SerialClient>> clients;
  std::vector<Bytes> ids(static_cast<std::size_t>(config.buses));
  for (int b = 0; b < config.buses; ++b) {
    clients.push_back(std::make_unique<SerialClient>(doppel.link("ttyDXL" + std::to_string(b)), kBaud));
    for (int k = 0; k < per_bus; ++k) ids[static_cast<std::size_t>(b)].push_back(static_cast<uint8_t>(b * per_bus + k + 1));
    // Torque on for every servo of the bus (SYNC WRITE, no reply).
    Bytes torque = cat(le16(kTorqueEnable), le16(1));
    for (uint8_t id : ids[static_cast<std::size_t>(b)]) torque = cat(torque, {id, 1});
    clients.back()->send(p2_instruction(0xFE, 0x83, torque));
  }

  std::vector<Bytes> read_requests;
  for (const Bytes& bus_ids : ids) {
    read_requests.push_back(p2_instruction(0xFE, 0x82, cat(cat(le16(kPresentCurrent), le16(kReadBytes)), bus_ids)));
  }
  std::vector<uint32_t> step(static_cast<std::size_t>(config.buses), 0);
  Result result = run_cycles(config.buses, seconds, realtime, [&](int b) {
    const auto bus = static_cast<std::size_t>(b);
    SerialClient& client = *clients[bus];
    const Bytes& bus_ids = ids[bus];
    Bytes goals = cat(le16(kGoalPosition), le16(4));
    for (uint8_t id : bus_ids) goals = cat(cat(goals, {id}), le32(2048 + static_cast<int32_t>(step[bus] % 64)));
    ++step[bus];
    client.send(p2_instruction(0xFE, 0x83, goals));
    const Bytes reply = client.transact(read_requests[bus], bus_ids.size() * (11 + kReadBytes), 100);
    const auto statuses = doppel::testing::parse_p2_statuses(reply);
    bool ok = statuses && statuses->size() == bus_ids.size();
    for (std::size_t i = 0; ok && i < bus_ids.size(); ++i) {
      ok = (*statuses)[i].id == bus_ids[i] && (*statuses)[i].error == 0 && (*statuses)[i].params.size() == kReadBytes;
    }
    return ok;
  });
  const int status = doppel.stop();
  result.exit_failures = (WIFEXITED(status) && WEXITSTATUS(status) == 0) ? 0 : 1;
  result.doppel_late_p99_us = worst_p99_us(doppel.output());
  return result;
}

}  // namespace

int main(int argc, char** argv) {
  double seconds = 60.0;
  bool realtime = false;
  int only_buses = 0;
  bool quick = false;
  CLI::App app("The Bit-Bots control cycle against doppel", "p2_bitbots_cycle");
  CLI::Option* seconds_option = app.add_option("--seconds", seconds)->transform(doppel::positive_number<double>());
  app.add_flag("--quick", quick)->excludes(seconds_option);
  app.add_flag("--rt", realtime);
  app.add_option("--buses", only_buses)->check(CLI::IsMember({1, 2, 4}));
  if (auto exit_code = doppel::bench::parse_command_line(
          app, argc, argv, "usage: p2_bitbots_cycle [--seconds S] [--quick] [--rt] [--buses 1|2|4]\n")) {
    return *exit_code;
  }
  if (quick) {
    seconds = 0.3;
  }
  const Config configs[] = {
      {1, "wire", 0.0, "wire, 0 us fw"}, {1, "wire", 50.0, "wire, 50 us fw"}, {1, "fast", 50.0, "fast"},
      {4, "wire", 0.0, "wire, 0 us fw"}, {4, "wire", 50.0, "wire, 50 us fw"}, {4, "fast", 50.0, "fast"},
      {2, "wire", 0.0, "wire, 0 us fw"}, {2, "wire", 50.0, "wire, 50 us fw"}, {2, "fast", 50.0, "fast"},
  };
  if (realtime && !set_fifo()) {
    std::fprintf(stderr, "p2_bitbots_cycle: SCHED_FIFO refused (needs root or CAP_SYS_NICE)\n");
    return 2;
  }
  std::printf("Bit-Bots cycle: 20 XM430-W350, 4 Mbps, RDT 0, per cycle SYNC WRITE 4 B + SYNC READ 10 B; %.0f s per row, "
              "%s scheduling.\n", seconds, realtime ? "SCHED_FIFO" : "normal");
  std::printf("Real hardware (Bit-Bots): 398 Hz on one bus, 1373 Hz on four.\n\n");
  std::printf("| buses | timing | cycles | rate Hz | wire model Hz | rate / model | mean cycle - floor, us | model cycle us | net error | cycle p50 us | cycle p99 us | cycle max us | Doppel late p99 us | errors |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  uint64_t failures = 0;
  int floor_buses = 0;
  double floor_us = 0.0;
  for (const Config& c : configs) {
    // Two buses are not part of the Bit-Bots measurement: only on request (how timing scales).
    if (only_buses != 0 ? c.buses != only_buses : c.buses == 2) continue;
    if (c.buses != floor_buses) {
      const Result e = echo_cycles(c.buses, std::min(seconds, 10.0), realtime);
      floor_buses = c.buses;
      floor_us = e.cycles > 0 ? 1e6 * e.seconds / static_cast<double>(e.cycles) : 0.0;
      std::printf("| %d | pty echo floor | %llu | %.0f | - | - | %.1f (mean) | - | - | %.1f | %.1f | %.1f | - | %llu |\n",
                  c.buses, static_cast<unsigned long long>(e.cycles), floor_us > 0.0 ? 1e6 / floor_us : 0.0, floor_us,
                  e.cycle_us.p50, e.cycle_us.p99, e.cycle_us.max, static_cast<unsigned long long>(e.errors));
      failures += e.errors + (e.cycles == 0 ? 1 : 0);
    }
    const Result r = run(c, seconds, realtime);
    const double rate = r.seconds > 0.0 ? static_cast<double>(r.cycles) / r.seconds : 0.0;
    const bool wire = std::strcmp(c.timing, "wire") == 0;
    const double model = theory_hz(kServos / c.buses, c.firmware_us);
    if (wire) {
      const double net_us = (rate > 0.0 ? 1e6 / rate : 0.0) - floor_us;
      const double model_us = 1e6 / model;
      std::printf("| %d | %s | %llu | %.0f | %.0f | %.3f | %.1f | %.1f | %+.1f %% | %.1f | %.1f | %.1f | %lld | %llu |\n",
                  c.buses, c.label, static_cast<unsigned long long>(r.cycles), rate, model, rate / model, net_us,
                  model_us, 100.0 * (net_us - model_us) / model_us, r.cycle_us.p50, r.cycle_us.p99, r.cycle_us.max,
                  static_cast<long long>(r.doppel_late_p99_us), static_cast<unsigned long long>(r.errors));
    } else {
      std::printf("| %d | %s | %llu | %.0f | - | - | - | - | - | %.1f | %.1f | %.1f | - | %llu |\n", c.buses, c.label,
                  static_cast<unsigned long long>(r.cycles), rate, r.cycle_us.p50, r.cycle_us.p99, r.cycle_us.max,
                  static_cast<unsigned long long>(r.errors));
    }
    failures += r.errors + static_cast<uint64_t>(r.exit_failures) + (r.cycles == 0 ? 1 : 0);
  }
  std::printf("\nfloor = mean cycle of the same client threads and barrier against one bare pty echo per bus (8 B out,\n"
              "8 B back): the pty and scheduling cost of this machine, which no wire time overlaps.\n"
              "net error = (mean cycle - floor - model cycle) / model cycle: Doppel's timing beyond that floor.\n");
  std::printf("wire model: bytes per cycle on one bus x 2.5 us (+ firmware time per status): %zu B (1 bus), %zu B (4 buses)\n",
              cycle_bytes(20), cycle_bytes(5));
  std::printf("failures (error cycles, unclean exits, empty rows): %llu\n", static_cast<unsigned long long>(failures));
  return failures == 0 ? 0 : 1;
}
