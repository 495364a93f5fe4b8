// control_loop: a walking controller's 1 kHz bus cycle against the default robot (fumanoid-2011)
// in fast timing: every millisecond one SYNC WRITE of 21 goal positions, then a READ of each of
// the 21 present positions, the IMU and both foot boards. A cycle is missed when its transactions
// did not all complete correctly inside its 1 ms slot.
//
//   control_loop [--seconds S] [--timing fast|wire]
#include <sys/wait.h>
#include <time.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "doppel_process.h"
#include "latency_stats.h"
#include "reference_client.h"

namespace {

using doppel::testing::Bytes;
using doppel::testing::DoppelProcess;
using doppel::testing::p1_instruction;
using doppel::testing::SerialClient;

constexpr int kServos = 21;
constexpr int64_t kPeriodNs = 1'000'000;

int64_t now_ns() {
  timespec t{};
  clock_gettime(CLOCK_MONOTONIC, &t);
  return static_cast<int64_t>(t.tv_sec) * 1'000'000'000 + t.tv_nsec;
}

bool read_ok(SerialClient& client, uint8_t id, uint8_t address, uint8_t length, int timeout_ms) {
  Bytes reply = client.transact(p1_instruction(id, 0x02, {address, length}), 6u + length, timeout_ms);
  auto statuses = doppel::testing::parse_p1_statuses(reply);
  return statuses && statuses->size() == 1 && (*statuses)[0].id == id && (*statuses)[0].params.size() == length;
}

}  // namespace

int main(int argc, char** argv) {
  double seconds = 60.0;
  std::string timing = "fast";
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--seconds") == 0 && i + 1 < argc) {
      seconds = std::atof(argv[++i]);
    } else if (std::strcmp(argv[i], "--timing") == 0 && i + 1 < argc) {
      timing = argv[++i];
    } else {
      std::fprintf(stderr, "usage: control_loop [--seconds S] [--timing fast|wire]\n");
      return 2;
    }
  }
  DoppelProcess doppel({"--timing", timing});
  SerialClient client(doppel.link(), 1000000);

  // Torque on for every servo (broadcast WRITE, no status).
  client.send(p1_instruction(0xFE, 0x03, {24, 1}));

  const int64_t cycles = static_cast<int64_t>(seconds * 1000.0);
  int64_t missed = 0;
  int64_t errors = 0;
  std::vector<double> cycle_us;
  cycle_us.reserve(static_cast<std::size_t>(cycles));
  int64_t deadline = now_ns() + kPeriodNs;
  for (int64_t cycle = 0; cycle < cycles; ++cycle) {
    int64_t start = now_ns();
    // Goal positions follow a slow sine, as a gait would.
    uint16_t goal = static_cast<uint16_t>(512 + 100 * std::sin(static_cast<double>(cycle) * 0.002));
    Bytes sync{30, 2};
    for (uint8_t id = 1; id <= kServos; ++id) {
      sync.insert(sync.end(), {id, static_cast<uint8_t>(goal & 0xFF), static_cast<uint8_t>(goal >> 8)});
    }
    client.send(p1_instruction(0xFE, 0x83, sync));
    bool ok = true;
    for (uint8_t id = 1; id <= kServos; ++id) {
      ok = read_ok(client, id, 36, 2, 20) && ok;
    }
    ok = read_ok(client, 100, 26, 18, 20) && ok;
    ok = read_ok(client, 101, 26, 10, 20) && ok;
    ok = read_ok(client, 102, 26, 10, 20) && ok;
    int64_t end = now_ns();
    cycle_us.push_back(static_cast<double>(end - start) / 1000.0);
    errors += ok ? 0 : 1;
    if (!ok || end > deadline) {
      ++missed;
    }
    if (end < deadline) {
      timespec wake{static_cast<time_t>(deadline / 1'000'000'000), static_cast<long>(deadline % 1'000'000'000)};
      clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &wake, nullptr);
      deadline += kPeriodNs;
    } else {
      deadline = end + kPeriodNs;  // resynchronise after an overrun, as a real controller would
    }
  }
  int status = doppel.stop();
  auto p = doppel::bench::percentiles(cycle_us);
  std::printf("control_loop: timing %s, %lld cycles of 1 ms: SYNC WRITE 21 goals + 24 READs each\n", timing.c_str(),
              static_cast<long long>(cycles));
  std::printf("bus work per cycle: p50 %.0f us  p99 %.0f us  p99.9 %.0f us  max %.0f us\n", p.p50, p.p99, p.p999, p.max);
  std::printf("missed cycles: %lld (%.3f %%), cycles with errors: %lld, doppel exit %s\n",
              static_cast<long long>(missed), 100.0 * static_cast<double>(missed) / static_cast<double>(cycles),
              static_cast<long long>(errors), WIFEXITED(status) && WEXITSTATUS(status) == 0 ? "clean" : "UNCLEAN");
  return errors == 0 && WIFEXITED(status) && WEXITSTATUS(status) == 0 ? 0 : 1;
}
