// network_latency: what serving a bus over the network adds (hardware in the loop). One doppel runs
// two identical mx-test robots; a client on the first robot's link (local, as a driver on Doppel's
// machine) alternates with a client on a pty that socat bridges over loopback TCP to the second
// robot's link, which scripts/serve-network serves with ser2net (as a driver on the robot's own
// computer). Each sample pair shares the machine's load. Also measured: ser2net's default
// `chardelay` (waiting at least 1 ms for more bytes before it forwards them), which the script turns off.
//
//   network_latency [--samples N] [--quick]
#include <sys/wait.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "doppel_process.h"
#include "latency_stats.h"
#include "network_bridge.h"
#include "reference_client.h"
#include "tool_command_line.h"

namespace {

using doppel::bench::Percentiles;
using doppel::bench::percentiles;
using namespace doppel::testing;
using Clock = std::chrono::steady_clock;

constexpr uint32_t kBaud = 1000000;

struct Case {
  const char* name;
  Bytes request;
  std::size_t reply_bytes;
};

// The reply is right when it is exactly one well-formed status from the addressed servo.
std::optional<double> timed(SerialClient& client, const Case& c) {
  auto start = Clock::now();
  Bytes reply = client.transact(c.request, c.reply_bytes, 200);
  double us = std::chrono::duration<double, std::micro>(Clock::now() - start).count();
  auto statuses = parse_p1_statuses(reply);
  if (reply.size() != c.reply_bytes || !statuses || statuses->size() != 1 || (*statuses)[0].error != 0) {
    return std::nullopt;
  }
  return us;
}

struct Pair {
  Percentiles local;
  Percentiles network;
  int failures = 0;
};

Pair measure(SerialClient& local, SerialClient& network, const Case& c, int samples) {
  std::vector<double> local_us, network_us;
  Pair out;
  for (int i = 0; i < samples; ++i) {
    if (auto us = timed(local, c)) {
      local_us.push_back(*us);
    } else {
      ++out.failures;
    }
    if (auto us = timed(network, c)) {
      network_us.push_back(*us);
    } else {
      ++out.failures;
    }
  }
  out.local = percentiles(local_us);
  out.network = percentiles(network_us);
  return out;
}

// Waits until the bridged servo answers (socat connects and ser2net opens the pty meanwhile).
bool bridge_answers(SerialClient& network) {
  auto deadline = Clock::now() + std::chrono::seconds(10);
  while (Clock::now() < deadline) {
    if (network.transact(p1_instruction(1, 0x01), 6, 200).size() == 6) {
      return true;
    }
  }
  return false;
}

}  // namespace

int main(int argc, char** argv) {
  static const char* kUsage =
      "usage: network_latency [--samples N] [--quick]\n"
      "  --samples N  transactions per instruction and path in fast mode (default 2000; wire mode: half)\n"
      "  --quick      40 samples (a smoke run)\n";
  int samples = 2000;
  bool quick = false;
  CLI::App app("network_latency");
  app.add_option("--samples", samples)->check(CLI::Range(1, 1000000));
  app.add_flag("--quick", quick);
  if (auto exit_code = doppel::bench::parse_command_line(app, argc, argv, kUsage)) {
    return *exit_code;
  }
  if (quick) {
    samples = 40;
  }
  if (!find_program("ser2net") || !find_program("socat")) {
    std::printf("network_latency: ser2net or socat is not installed (scripts/setup installs them); skipped\n");
    return 77;  // ctest's SKIP_RETURN_CODE
  }
  const std::vector<Case> cases = {
      {"PING", p1_instruction(1, 0x01), 6},
      {"READ 2 B (pos)", p1_instruction(1, 0x02, {36, 2}), 8},
  };
  std::printf("Protocol 1.0 at %u bps, robot mx-test twice in one doppel; each local sample alternates with one "
              "through ser2net + socat over loopback TCP.\n\n",
              kBaud);
  std::printf("| instruction | timing | ser2net chardelay | local p50 us | local p99 us | local p99.9 us | network p50 us "
              "| network p99 us | network p99.9 us | added p50 us | added p99 us | failures |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  int failures = 0;
  for (const char* mode : {"fast", "wire"}) {
    const int n = std::string(mode) == "wire" ? std::max(samples / 2, 20) : samples;
    DoppelProcess doppel({"--robot", "mx-test", "--robot", "mx-test", "--timing", mode});
    doppel.wait_for_output("running until");
    const std::string pty = std::filesystem::path(doppel.link_dir()).parent_path().string() + "/robot-ttyUSB0";
    SerialClient local(doppel.link(), kBaud);
    for (bool chardelay : {false, true}) {
      std::vector<std::string> serve_args;
      if (chardelay) {
        serve_args.push_back("--chardelay");
      }
      NetworkBridge bridge(doppel.link_dir(), free_loopback_ports(2), kBaud, 1, pty, serve_args);
      SerialClient network(bridge.path(), kBaud);
      if (!bridge_answers(network)) {
        std::printf("the bridged servo never answered: %s\n", bridge.output().c_str());
        return 1;
      }
      for (const Case& c : cases) {
        Pair m = measure(local, network, c, n);
        failures += m.failures;
        std::printf("| %s | %s | %s | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %d |\n", c.name, mode,
                    chardelay ? "on (ser2net default)" : "off (serve-network)", m.local.p50, m.local.p99,
                    m.local.p999, m.network.p50, m.network.p99, m.network.p999, m.network.p50 - m.local.p50,
                    m.network.p99 - m.local.p99, m.failures);
      }
    }
    const int status = doppel.stop();
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
      std::printf("doppel did not exit cleanly (status %d)\n", status);
      ++failures;
    }
  }
  std::printf("\nadded = network - local at the same percentile; failures: timeouts or wrong replies (%d)\n", failures);
  return failures == 0 ? 0 : 1;
}
