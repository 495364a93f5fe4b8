// lockstep_speed: how much faster than real time a controller runs under lockstep (issue 15: a
// 1 kHz single-threaded controller on the default robot, >= 5x on one core). The same controller
// (tests/lockstep/lockstep_controller.c, `single`: SYNC WRITE of 21 goals + one READ per 1 ms
// cycle, clock_nanosleep-paced) runs SECONDS of its own clock against a real-time doppel and
// against doppel --lockstep, one after the other; the figure is simulated seconds per wall second.
// For "one core", run the tool under `taskset -c 0` (doppel and the controller inherit it).
//
//   lockstep_speed [--seconds S] [--repeat N]
#include <chrono>
#include <cstdio>
#include <regex>
#include <string>

#include "doppel_process.h"
#include "tool_command_line.h"

namespace {

using doppel::testing::DoppelProcess;

constexpr const char* kUsage =
    "usage: lockstep_speed [--seconds S] [--repeat N]\n"
    "  Runs the 1 kHz reference controller S simulated seconds (default 10) in real time and under\n"
    "  --lockstep, N times each (default 1), and prints simulated seconds per wall second.\n";

struct Result {
  double wall_s = 0;
  std::string output;
};

Result run(bool lockstep, double seconds) {
  DoppelProcess doppel(lockstep ? std::vector<std::string>{"--lockstep"} : std::vector<std::string>{});
  doppel.wait_for_output("running until");
  const std::string command = std::string(DOPPEL_RUN) + (lockstep ? " --lockstep" : "") + " --link-dir " +
                              doppel.link_dir() + " -- " + LOCKSTEP_CONTROLLER + " single /dev/ttyUSB0 " +
                              std::to_string(seconds);
  const auto start = std::chrono::steady_clock::now();
  auto [code, output] = doppel::testing::run_command(command);
  Result result;
  result.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  result.output = code == 0 ? output : "failed (" + std::to_string(code) + "): " + output;
  doppel.stop();
  return result;
}

std::string field(const std::string& output, const std::string& name) {
  std::smatch match;
  return std::regex_search(output, match, std::regex(name + "=([^\\s]*)")) ? match[1].str() : "?";
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("lockstep_speed", "lockstep_speed");
  double seconds = 10.0;
  int repeat = 1;
  app.add_option("--seconds", seconds)->transform(doppel::number_in<double>(0.5, 600.0));
  app.add_option("--repeat", repeat)->transform(doppel::number_in<int>(1, 100));
  if (const auto exit_code = doppel::bench::parse_command_line(app, argc, argv, kUsage)) return *exit_code;
  for (int i = 0; i < repeat; ++i) {
    for (const bool lockstep : {false, true}) {
      const Result r = run(lockstep, seconds);
      const double simulated_s = std::stod(field(r.output, "end_s") == "?" ? "0" : field(r.output, "end_s"));
      std::printf("%-9s simulated %.3f s in %.3f s wall: %.2f simulated s per wall s (cycles %s, replies %s, timeouts %s)\n",
                  lockstep ? "lockstep" : "real time", simulated_s, r.wall_s, simulated_s / r.wall_s,
                  field(r.output, "cycles").c_str(), field(r.output, "replies").c_str(),
                  field(r.output, "timeouts").c_str());
      std::fflush(stdout);
    }
  }
  return 0;
}
