// reopen_race: the start-up of a driver that sets its rate by closing and reopening the port
// (DynamixelSDK's setBaudRate), repeated against the real `doppel` with busy processes beside it.
// A start-up fails when any of its PINGs goes unanswered; the tool also counts start-ups whose
// line rate, read back by the client on its own descriptor, was no longer the rate it set (someone
// else wrote the port's termios during the session).
//
//   reopen_race [--startups N] [--load P] [--pings K] [--timeout-ms T] [--timing wire|fast]
#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>

#include "doppel_process.h"
#include "reopen_stress.h"
#include "tool_command_line.h"

namespace {

using doppel::testing::BusyLoad;
using doppel::testing::DoppelProcess;

// Bus 0 at 1 Mbps, bus 1 at 57600 bps, an AX-12A with ID 1 on each.
std::string write_robot(const std::string& dir) {
  const std::string path = dir + "/reopen.textproto";
  std::ofstream out(path);
  out << "name: \"reopen\"\n"
         "bus { baud_bps: 1000000 protocol: PROTOCOL_1 supply_voltage_v: 12 device { id: 1 model: \"AX-12A\" } }\n"
         "bus { baud_bps: 57600 protocol: PROTOCOL_1 supply_voltage_v: 12 device { id: 1 model: \"AX-12A\" } }\n";
  return path;
}

struct Row {
  int failures = 0;   // start-ups with an unanswered PING
  int dead = 0;       // start-ups that lost every PING (the reopen race's signature)
  int clobbered = 0;  // start-ups whose line rate changed under the client
  int lost = 0;       // PINGs unanswered
};

Row run(const std::string& port, uint32_t first_bps, uint32_t second_bps, int startups, int pings, int timeout_ms) {
  Row row;
  for (int i = 0; i < startups; ++i) {
    const auto outcome = doppel::testing::reopen_startup(port, first_bps, second_bps, 1, pings, timeout_ms);
    row.lost += pings - outcome.answered;
    row.failures += outcome.answered < pings ? 1 : 0;
    row.dead += outcome.answered == 0 ? 1 : 0;
    row.clobbered += outcome.line_bps_after != second_bps ? 1 : 0;
    if (!outcome.first_failure.empty() && row.failures <= 5) {
      std::fprintf(stderr, "start-up %d (%u -> %u bps): %s\n", i + 1, first_bps, second_bps,
                   outcome.first_failure.c_str());
    }
  }
  return row;
}

}  // namespace

int main(int argc, char** argv) {
  int startups = 1000;
  int load = 2;
  int pings = 5;
  int timeout_ms = 1000;
  std::string timing = "wire";
  CLI::App app("Reopen race: open, close, reopen at another rate, PING", "reopen_race");
  app.add_option("--startups", startups)->check(CLI::PositiveNumber);
  app.add_option("--load", load)->check(CLI::NonNegativeNumber);
  app.add_option("--pings", pings)->check(CLI::PositiveNumber);
  app.add_option("--timeout-ms", timeout_ms)->check(CLI::PositiveNumber);
  app.add_option("--timing", timing)->check(CLI::IsMember({"fast", "wire"}));
  if (auto exit_code = doppel::bench::parse_command_line(
          app, argc, argv, "usage: reopen_race [--startups N] [--load P] [--pings K] [--timeout-ms T] [--timing wire|fast]\n")) {
    return *exit_code;
  }
  char dir_template[] = "/tmp/doppel-reopen-XXXXXX";
  const std::string dir = mkdtemp(dir_template);
  DoppelProcess doppel({"--robot", write_robot(dir), "--timing", timing}, "ttyDXL1");
  std::printf("timing %s, %d busy processes, %d start-ups per row, %d PINGs each, %d ms to answer each\n\n",
              timing.c_str(), load, startups, pings, timeout_ms);
  std::printf("| order | failed start-ups | of those, every PING lost | lost PINGs | rate changed under the client |\n"
              "|---|---|---|---|---|\n");
  int failures = 0;
  {
    BusyLoad busy(load);
    const Row up = run(doppel.link("ttyDXL0"), 57600, 1000000, startups, pings, timeout_ms);
    std::printf("| 57600 -> 1 Mbps | %d / %d | %d | %d / %d | %d |\n", up.failures, startups, up.dead, up.lost,
                startups * pings, up.clobbered);
    std::fflush(stdout);
    const Row down = run(doppel.link("ttyDXL1"), 1000000, 57600, startups, pings, timeout_ms);
    std::printf("| 1 Mbps -> 57600 | %d / %d | %d | %d / %d | %d |\n", down.failures, startups, down.dead, down.lost,
                startups * pings, down.clobbered);
    failures = up.failures + down.failures;
  }
  const int status = doppel.stop();
  // Doppel's own count of packets sent at a rate no device listens at (the race's symptom).
  static const std::regex not_understood(R"(not understood at the line's baud rate (\d+))");
  unsigned long long mismatches = 0;
  const std::string output = doppel.output();
  for (auto it = std::sregex_iterator(output.begin(), output.end(), not_understood); it != std::sregex_iterator(); ++it) {
    mismatches += std::stoull((*it)[1]);
  }
  std::printf("\ndoppel: %llu packets not understood at the line's baud rate\n", mismatches);
  std::filesystem::remove_all(dir);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || failures > 0) {
    std::fprintf(stderr, "doppel said:\n%s\n", doppel.output().c_str());
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) return 1;
  return failures == 0 ? 0 : 1;
}
