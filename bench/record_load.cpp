// record_load: does recording (doppel --record) slow the bus or the simulation? Two doppel runs
// side by side (default robot, ODE, same timing), one recording to an MCAP file, one not; phases
// alternate between them, so both see the same machine load. In each phase the client reads
// servo 1's Present Position (READ 2 B) back to back, timing each round trip (every one of them is
// a recorded transaction in the recording run); missed 1 ms simulation ticks come from each run's
// /api/state at the phase's start and end. At the end the recording run's exit summary says how
// many bus events the recorder dropped and how large the file is.
//
//   record_load [--seconds S] [--rounds N] [--timing fast|wire] [--compression zstd|lz4|none] [--quick]
#include <httplib.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <regex>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "doppel_process.h"
#include "latency_stats.h"
#include "load_phase.h"
#include "reference_client.h"
#include "tool_command_line.h"

namespace {

using doppel::bench::add;
using doppel::bench::measure;
using doppel::bench::Phase;
using doppel::bench::print_row;

using doppel::testing::Bytes;
using doppel::testing::DoppelProcess;
using doppel::testing::SerialClient;
using Clock = std::chrono::steady_clock;

constexpr uint32_t kBaud = 1000000;

int control_port(const DoppelProcess& doppel) {
  const std::string output = doppel.wait_for_output("simulation control on http://127.0.0.1:");
  std::smatch match;
  if (!std::regex_search(output, match, std::regex(R"(simulation control on http://127\.0\.0\.1:(\d+)/)"))) {
    throw std::runtime_error("doppel serves no control API:\n" + output);
  }
  return std::stoi(match[1].str());
}

}  // namespace

int main(int argc, char** argv) {
  double seconds = 5.0;
  int rounds = 3;
  std::string timing = "wire";
  std::string compression = "zstd";
  bool quick = false;
  CLI::App app("Bus latency and missed simulation ticks with and without doppel --record, same run", "record_load");
  app.add_option("--seconds", seconds, "seconds per phase")->check(CLI::PositiveNumber);
  app.add_option("--rounds", rounds, "off/on pairs")->check(CLI::PositiveNumber);
  app.add_option("--timing", timing)->check(CLI::IsMember({"fast", "wire"}));
  app.add_option("--compression", compression)->check(CLI::IsMember({"zstd", "lz4", "none"}));
  app.add_flag("--quick", quick, "one round of 1 s phases");
  if (const std::optional<int> exit_code = doppel::bench::parse_command_line(
          app, argc, argv,
          "usage: record_load [--seconds S] [--rounds N] [--timing fast|wire] [--compression zstd|lz4|none] [--quick]\n")) {
    return *exit_code;
  }
  if (quick) {
    seconds = 1.0;
    rounds = 1;
  }
  const std::string file = std::filesystem::temp_directory_path() / ("record_load_" + std::to_string(getpid()) + ".mcap");
  // --no-token: both runs alike, and the phases read /api/state without a token (load_phase.h).
  DoppelProcess plain({"--viewer", "0", "--no-token", "--timing", timing});
  DoppelProcess recording({"--viewer", "0", "--no-token", "--timing", timing, "--record", file, "--record-compression", compression});
  const int plain_port = control_port(plain);
  const int recording_port = control_port(recording);
  SerialClient plain_client(plain.link(), kBaud);
  SerialClient recording_client(recording.link(), kBaud);
  std::printf("two doppel runs (fumanoid-2011, ODE, %s timing), one with --record (%s); READ 2 B of servo 1 back to back, "
              "%d x (%.1f s each: off, on)\n\n",
              timing.c_str(), compression.c_str(), rounds, seconds);
  std::printf("| recording | samples | p50 us | p99 us | p99.9 us | max us | failures | missed ticks | missed per s | sim / wall |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|\n");
  Phase off_total, on_total;
  for (int round = 0; round < rounds; ++round) {
    const Phase off = measure(plain_client, plain_port, seconds);
    print_row("off", off);
    add(off_total, off);
    const Phase on = measure(recording_client, recording_port, seconds);
    print_row("on", on);
    add(on_total, on);
  }
  print_row("**all off**", off_total);
  print_row("**all on**", on_total);
  plain.stop();
  recording.stop(2);
  const std::string output = recording.output();
  const std::size_t at = output.find("  recording ");
  std::printf("\n%s", at == std::string::npos ? "the recording run printed no recording summary\n" : output.substr(at).c_str());
  std::filesystem::remove(file);
  const bool ok = off_total.failures + on_total.failures == 0 && at != std::string::npos;
  return ok ? 0 : 1;
}
