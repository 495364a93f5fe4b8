// control_loop: a walking controller's 1 kHz bus cycle: every millisecond one SYNC WRITE of 21
// goal positions, then the 21 present positions, the IMU and both foot boards are read.
// - default: the thesis robot (fumanoid-2011, RX servos without BULK READ): 24 READs, one by one.
//   In the same run, the same client does 25 bare pty echo round trips per cycle: the floor that
//   any pty-based bus puts under a cycle of 25 sequential transactions.
// - --bulk: the same body with MX-64 servos (which have BULK READ): one BULK READ for all 24 devices.
// A cycle is missed when its transactions did not all complete correctly inside its 1 ms slot.
//
//   control_loop [--seconds S] [--timing fast|wire] [--bulk]
#include <sys/wait.h>
#include <time.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "base/monotonic_clock.h"

#include "doppel_process.h"
#include "latency_stats.h"
#include "pty_echo.h"
#include "tool_command_line.h"
#include "reference_client.h"

namespace {

using doppel::testing::Bytes;
using doppel::testing::DoppelProcess;
using doppel::testing::p1_instruction;
using doppel::testing::SerialClient;

constexpr int kServos = 21;
constexpr int64_t kPeriodNs = 1'000'000;

// fumanoid-2011's bus with its 21 RX servos replaced by MX-64s (same IDs), for --bulk.
std::string write_mx_robot(const std::string& dir) {
  std::string path = dir + "/fumanoid-mx64.textproto";
  std::ofstream out(path);
  out << "name: \"fumanoid-mx64\"\nbus {\n  baud_bps: 1000000\n  protocol: PROTOCOL_1\n";
  for (int id = 1; id <= kServos; ++id) {
    out << "  device { id: " << id << " model: \"MX-64\" }\n";
  }
  out << "  device { id: 100 model: \"FUMANOID-IMU\" }\n  device { id: 101 model: \"FUMANOID-FOOT\" }\n"
      << "  device { id: 102 model: \"FUMANOID-FOOT\" }\n}\n";
  return path;
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
  bool bulk = false;
  int reply_timeout_ms = 20;  // a driver's: a later answer is a failed read and a missed cycle
  CLI::App app("A driver's control loop against doppel", "control_loop");
  app.add_flag("--bulk", bulk);
  // The smoke test asks for a long one: it checks that every answer comes and is right, which a
  // loaded machine delays but does not change (the 20 ms is a timing figure, measured in runs).
  app.add_option("--reply-timeout-ms", reply_timeout_ms)->check(CLI::Range(1, 60000));
  app.add_option("--seconds", seconds)->transform(doppel::positive_number<double>());
  app.add_option("--timing", timing)->check(CLI::IsMember({"fast", "wire"}));
  if (auto exit_code = doppel::bench::parse_command_line(
          app, argc, argv, "usage: control_loop [--seconds S] [--timing fast|wire] [--bulk] [--reply-timeout-ms MS]\n")) {
    return *exit_code;
  }
  char dir_template[] = "/tmp/doppel-loop-XXXXXX";
  std::string dir = mkdtemp(dir_template);
  std::vector<std::string> args{"--timing", timing};
  if (bulk) {
    args.insert(args.end(), {"--robot", write_mx_robot(dir)});
  }
  DoppelProcess doppel(args);
  SerialClient client(doppel.link(), 1000000);
  doppel::bench::PtyEcho echo_server;
  SerialClient echo(echo_server.path(), 1000000);
  const Bytes echo_bytes(8, 0x55);
  std::vector<double> floor_us;
  // BULK READ blocks [length, ID, address]: 2 B of Present Position per servo, the IMU's 18 B, 10 B per foot.
  Bytes bulk_params{0x00};
  std::size_t bulk_reply_bytes = 0;
  for (uint8_t id = 1; id <= kServos; ++id) {
    bulk_params.insert(bulk_params.end(), {2, id, 36});
    bulk_reply_bytes += 8;
  }
  bulk_params.insert(bulk_params.end(), {18, 100, 26, 10, 101, 26, 10, 102, 26});
  bulk_reply_bytes += 24 + 16 + 16;

  // Torque on for every servo (broadcast WRITE, no status).
  client.send(p1_instruction(0xFE, 0x03, {24, 1}));

  // The floor, measured first in the same run: the same number of sequential transactions as a
  // cycle, on a bare pty echo.
  if (!bulk) {
    for (int cycle = 0; cycle < 1000; ++cycle) {
      int64_t floor_start = doppel::monotonic_now_ns();
      for (int t = 0; t < kServos + 4; ++t) {
        echo.transact(echo_bytes, echo_bytes.size(), 20);
      }
      floor_us.push_back(static_cast<double>(doppel::monotonic_now_ns() - floor_start) / 1000.0);
    }
  }

  const int64_t cycles = static_cast<int64_t>(seconds * 1000.0);
  int64_t missed = 0;
  int64_t errors = 0;
  std::vector<double> cycle_us;
  cycle_us.reserve(static_cast<std::size_t>(cycles));
  int64_t deadline = doppel::monotonic_now_ns() + kPeriodNs;
  for (int64_t cycle = 0; cycle < cycles; ++cycle) {
    int64_t start = doppel::monotonic_now_ns();
    // Goal positions follow a slow sine, as a gait would.
    uint16_t goal = static_cast<uint16_t>(512 + 100 * std::sin(static_cast<double>(cycle) * 0.002));
    Bytes sync{30, 2};
    for (uint8_t id = 1; id <= kServos; ++id) {
      sync.insert(sync.end(), {id, static_cast<uint8_t>(goal & 0xFF), static_cast<uint8_t>(goal >> 8)});
    }
    client.send(p1_instruction(0xFE, 0x83, sync));
    bool ok = true;
    if (bulk) {
      Bytes reply = client.transact(p1_instruction(0xFE, 0x92, bulk_params), bulk_reply_bytes, reply_timeout_ms);
      auto statuses = doppel::testing::parse_p1_statuses(reply);
      ok = statuses && statuses->size() == kServos + 3u;
    } else {
      for (uint8_t id = 1; id <= kServos; ++id) {
        ok = read_ok(client, id, 36, 2, reply_timeout_ms) && ok;
      }
      ok = read_ok(client, 100, 26, 18, reply_timeout_ms) && ok;
      ok = read_ok(client, 101, 26, 10, reply_timeout_ms) && ok;
      ok = read_ok(client, 102, 26, 10, reply_timeout_ms) && ok;
    }
    int64_t end = doppel::monotonic_now_ns();
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
  std::filesystem::remove_all(dir);
  auto p = doppel::bench::percentiles(cycle_us);
  std::printf("control_loop: timing %s, %lld cycles of 1 ms: SYNC WRITE 21 goals + %s each\n", timing.c_str(),
              static_cast<long long>(cycles), bulk ? "1 BULK READ of 24 devices (MX-64 servos)" : "24 READs (RX servos)");
  std::printf("bus work per cycle: p50 %.0f us  p99 %.0f us  p99.9 %.0f us  max %.0f us\n", p.p50, p.p99, p.p999, p.max);
  if (!bulk) {
    auto f = doppel::bench::percentiles(floor_us);
    std::printf("pty floor, 25 sequential bare echo round trips (1000 times, same run): p50 %.0f us  p99 %.0f us\n", f.p50,
                f.p99);
  }
  std::printf("missed cycles: %lld (%.3f %%), cycles with errors: %lld, doppel exit %s\n",
              static_cast<long long>(missed), 100.0 * static_cast<double>(missed) / static_cast<double>(cycles),
              static_cast<long long>(errors), WIFEXITED(status) && WEXITSTATUS(status) == 0 ? "clean" : "UNCLEAN");
  return errors == 0 && WIFEXITED(status) && WEXITSTATUS(status) == 0 ? 0 : 1;
}
