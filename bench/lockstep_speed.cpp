// lockstep_speed: how much faster than real time a controller runs under lockstep (issue 15: a
// 1 kHz single-threaded controller on the default robot, >= 5x on one core; issue 26: >= 25x). The
// same controller (tests/lockstep/lockstep_controller.c, `single`: SYNC WRITE of 21 goals + one
// READ per 1 ms cycle, clock_nanosleep-paced) runs SECONDS of its own clock against a real-time
// doppel and against doppel --lockstep, one after the other; the figure is simulated seconds per
// wall second. Beside it, simulated seconds per CPU second of doppel and the controller together
// during the run (less sensitive to what else the machine runs) and the load average.
// With --baseline DIR (a directory holding another build's doppel and doppel-run, with its
// libdoppel_shim.so beside it) each repeat runs that build under lockstep too, alternating with
// this one, and the end gives both medians and their ratio.
// For "one core", run the tool under `taskset -c 0` (doppel and the controller inherit it).
//
//   lockstep_speed [--seconds S] [--repeat N] [--baseline DIR] [--lockstep-only]
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>
#include <vector>

#include "doppel_process.h"
#include "tool_command_line.h"

namespace {

using doppel::testing::DoppelProcess;

constexpr const char* kUsage =
    "usage: lockstep_speed [--seconds S] [--repeat N] [--baseline DIR] [--lockstep-only]\n"
    "  Runs the 1 kHz reference controller S simulated seconds (default 10) in real time and under\n"
    "  --lockstep, N times each (default 1), and prints simulated seconds per wall second and per CPU\n"
    "  second. --baseline DIR: also under lockstep with DIR/doppel and DIR/doppel-run, alternating.\n";

struct Build {
  std::string name;
  std::string doppel;      // "" = this build's
  std::string doppel_run;
};

struct Result {
  double wall_s = 0;
  double doppel_cpu_s = 0;      // doppel's threads while the controller ran
  double controller_cpu_s = 0;  // doppel-run's process (the controller) and the shell that started it
  double load = 0;              // 1-minute load average when the run started
  std::string output;
};

// CPU time of every thread of `pid` (ns, from schedstat: finer than /proc/PID/stat's ticks).
double cpu_s(pid_t pid) {
  int64_t total = 0;
  std::error_code error;
  for (const auto& task : std::filesystem::directory_iterator("/proc/" + std::to_string(pid) + "/task", error)) {
    std::ifstream schedstat(task.path() / "schedstat");
    int64_t on_cpu_ns = 0;
    if (schedstat >> on_cpu_ns) total += on_cpu_ns;
  }
  return static_cast<double>(total) * 1e-9;
}

double children_cpu_s() {
  rusage usage{};
  ::getrusage(RUSAGE_CHILDREN, &usage);
  return static_cast<double>(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
         static_cast<double>(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec) * 1e-6;
}

double load_average() {
  std::ifstream loadavg("/proc/loadavg");
  double load = 0;
  loadavg >> load;
  return load;
}

Result run(const Build& build, bool lockstep, double seconds) {
  if (!build.doppel.empty()) ::setenv("DOPPEL_EXECUTABLE", build.doppel.c_str(), 1);
  DoppelProcess doppel(lockstep ? std::vector<std::string>{"--lockstep"} : std::vector<std::string>{});
  ::unsetenv("DOPPEL_EXECUTABLE");
  doppel.wait_for_output("running until");
  const std::string command = build.doppel_run + (lockstep ? " --lockstep" : "") + " --link-dir " + doppel.link_dir() +
                              " -- " + LOCKSTEP_CONTROLLER + " single /dev/ttyUSB0 " + std::to_string(seconds);
  Result result;
  result.load = load_average();
  const double doppel_before = cpu_s(doppel.pid());
  const double children_before = children_cpu_s();
  const auto start = std::chrono::steady_clock::now();
  auto [code, output] = doppel::testing::run_command(command);
  result.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  result.controller_cpu_s = children_cpu_s() - children_before;
  result.doppel_cpu_s = cpu_s(doppel.pid()) - doppel_before;
  result.output = code == 0 ? output : "failed (" + std::to_string(code) + "): " + output;
  doppel.stop();
  return result;
}

std::string field(const std::string& output, const std::string& name) {
  std::smatch match;
  return std::regex_search(output, match, std::regex(name + "=([^\\s]*)")) ? match[1].str() : "?";
}

double median(std::vector<double> values) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 == 1 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("lockstep_speed", "lockstep_speed");
  double seconds = 10.0;
  int repeat = 1;
  std::string baseline;
  bool lockstep_only = false;
  app.add_option("--seconds", seconds)->transform(doppel::number_in<double>(0.5, 600.0));
  app.add_option("--repeat", repeat)->transform(doppel::number_in<int>(1, 100));
  app.add_option("--baseline", baseline)->check(CLI::ExistingDirectory);
  app.add_flag("--lockstep-only", lockstep_only);
  if (const auto exit_code = doppel::bench::parse_command_line(app, argc, argv, kUsage)) return *exit_code;
  const Build self{"lockstep", "", DOPPEL_RUN};
  std::vector<std::pair<Build, bool>> plan;  // (build, lockstep) in the order of one repeat
  if (!lockstep_only) plan.push_back({self, false});
  if (!baseline.empty()) {
    for (const char* file : {"doppel", "doppel-run", "libdoppel_shim.so"}) {
      if (!std::filesystem::exists(std::filesystem::path(baseline) / file)) {
        std::fprintf(stderr, "lockstep_speed: --baseline %s has no %s (a build's doppel, doppel-run and libdoppel_shim.so)\n",
                     baseline.c_str(), file);
        return 2;
      }
    }
    plan.push_back({Build{"baseline", baseline + "/doppel", baseline + "/doppel-run"}, true});
  }
  plan.push_back({self, true});
  std::vector<double> wall_rate[2], cpu_rate[2];  // [0] this build, [1] the baseline
  for (int i = 0; i < repeat; ++i) {
    for (const auto& [build, lockstep] : plan) {
      const Result r = run(build, lockstep, seconds);
      const double simulated_s = std::stod(field(r.output, "end_s") == "?" ? "0" : field(r.output, "end_s"));
      const double cpu = r.doppel_cpu_s + r.controller_cpu_s;
      std::printf("%-9s simulated %.3f s in %.3f s wall: %.2f simulated s per wall s; CPU %.3f s (doppel %.3f, "
                  "controller %.3f): %.2f simulated s per CPU s; load %.2f (cycles %s, replies %s, timeouts %s)\n",
                  lockstep ? build.name.c_str() : "real time", simulated_s, r.wall_s, simulated_s / r.wall_s, cpu,
                  r.doppel_cpu_s, r.controller_cpu_s, cpu > 0 ? simulated_s / cpu : 0.0, r.load,
                  field(r.output, "cycles").c_str(), field(r.output, "replies").c_str(),
                  field(r.output, "timeouts").c_str());
      std::fflush(stdout);
      if (lockstep) {
        const int which = build.doppel.empty() ? 0 : 1;
        wall_rate[which].push_back(simulated_s / r.wall_s);
        cpu_rate[which].push_back(cpu > 0 ? simulated_s / cpu : 0.0);
      }
    }
  }
  std::printf("median lockstep: %.2f simulated s per wall s, %.2f per CPU s\n", median(wall_rate[0]), median(cpu_rate[0]));
  if (!baseline.empty()) {
    std::printf("median baseline: %.2f simulated s per wall s, %.2f per CPU s; ratio lockstep/baseline %.2f (wall), %.2f (CPU)\n",
                median(wall_rate[1]), median(cpu_rate[1]), median(wall_rate[0]) / median(wall_rate[1]),
                median(cpu_rate[0]) / median(cpu_rate[1]));
  }
  return 0;
}
