// default_latency: wire timing as users run doppel. The bus benchmarks (bus_latency) measure a
// doppel without a body, camera or viewer; users run the default: `doppel --robot fumanoid-2011`
// with physics, the head camera streaming to a vision client and the web viewer open. This tool
// measures an independent client's READ 2 B of servo 1 in wire timing against the wire model, in
// configurations that add those one at a time, each sample alternating with a bare pty echo through
// the same client code, phases of the configurations alternating in rounds so that machine load
// hits them alike:
//   bare     --physics none, no camera, no viewer
//   physics  ODE (the default), no camera, no viewer
//   camera   physics + the head camera streaming to a subscriber (`doppel-camera stats`, as a
//            vision client takes every frame)
//   default  physics + camera + the viewer, its API polled at the page's rates (viewer_poller.h)
// With --doppel LABEL=PATH (repeatable) every configuration runs with each of those executables
// too, so that two builds compare in one run.
//
//   default_latency [--seconds S] [--rounds N] [--config NAME ...] [--doppel LABEL=PATH ...] [--quick]
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <optional>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "doppel_process.h"
#include "interleaved_latency.h"
#include "latency_stats.h"
#include "load_phase.h"
#include "pty_echo.h"
#include "reference_client.h"
#include "tool_command_line.h"
#include "viewer_poller.h"

namespace {

using doppel::bench::elapsed_us;
using doppel::bench::Percentiles;
using doppel::bench::percentiles;
using doppel::testing::Bytes;
using doppel::testing::DoppelProcess;
using doppel::testing::SerialClient;
using Clock = std::chrono::steady_clock;

constexpr uint32_t kBaud = 1000000;
constexpr double kByteUs = 10.0 * 1e6 / kBaud;
constexpr double kProcessingUs = 50.0;  // doppel's default firmware time
constexpr std::size_t kReadBytes = 8;   // READ 2 B: instruction 8 B, status 8 B

struct Config {
  std::string name;
  bool physics = false;
  bool camera = false;
  bool viewer = false;
};

const std::vector<Config>& all_configs() {
  static const std::vector<Config> configs{{"bare", false, false, false},
                                           {"physics", true, false, false},
                                           {"camera", true, true, false},
                                           {"default", true, true, true}};
  return configs;
}

struct Executable {
  std::string label;
  std::string path;  // "" = this build's doppel
};

// Everything one (executable, configuration) pair measured over all rounds.
struct Totals {
  std::vector<double> round_trips_us;
  std::vector<double> errors_us;
  std::vector<double> echoes_us;
  std::vector<std::string> lateness;  // doppel's own line, one per round
  std::vector<std::string> camera;    // the subscriber's rate, one per round
  double wire_model_us = 0.0;
  int failures = 0;
};

// `doppel-camera stats` for the phase: a subscriber that takes every frame as a vision client does.
class CameraSubscriber {
 public:
  CameraSubscriber(double seconds, const std::string& output_file) {
    const std::string seconds_arg = std::to_string(seconds);
    pid_ = fork();
    if (pid_ == 0) {
      const int out = ::open(output_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      dup2(out, 1);
      dup2(out, 2);
      execl(DOPPEL_CAMERA_EXECUTABLE, DOPPEL_CAMERA_EXECUTABLE, "stats", "--seconds", seconds_arg.c_str(),
            static_cast<char*>(nullptr));
      _exit(127);
    }
    output_file_ = output_file;
  }
  ~CameraSubscriber() {
    if (pid_ > 0) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
  }
  CameraSubscriber(const CameraSubscriber&) = delete;
  CameraSubscriber& operator=(const CameraSubscriber&) = delete;

  // Waits for the subscriber's exit; its report, or why there is none (then `failed`).
  std::string finish(bool& failed) {
    int status = 0;
    waitpid(pid_, &status, 0);
    pid_ = -1;
    std::ifstream in(output_file_);
    std::string line, all;
    while (std::getline(in, line)) all += (all.empty() ? "" : " / ") + line;
    failed = !WIFEXITED(status) || WEXITSTATUS(status) != 0;
    return failed ? "subscriber failed: " + all : all;
  }

 private:
  pid_t pid_ = -1;
  std::string output_file_;
};

std::string doppel_lateness(const std::string& output) {
  const std::size_t at = output.find("delivery time minus due time: ");
  if (at == std::string::npos) return "not reported";
  const std::size_t from = at + std::string("delivery time minus due time: ").size();
  return output.substr(from, output.find('\n', from) - from);
}

// Servo 1's Return Delay Time in µs (register 5, 2 µs per unit), read over the bus; nullopt when it does not answer.
std::optional<double> return_delay_us(SerialClient& client) {
  const Bytes reply = client.transact(doppel::testing::p1_instruction(1, 0x02, {5, 1}), 7, 1000);
  if (reply.size() != 7) return std::nullopt;
  return 2.0 * reply[5];
}

// One phase: `seconds` of READ 2 B, each after one echo round trip.
void measure_phase(const Config& config, const Executable& executable, double seconds, SerialClient& echo,
                   Totals& totals) {
  if (!executable.path.empty()) {
    setenv("DOPPEL_EXECUTABLE", executable.path.c_str(), 1);
  } else {
    unsetenv("DOPPEL_EXECUTABLE");
  }
  std::vector<std::string> args{"--robot", "fumanoid-2011", "--timing", "wire"};
  if (!config.physics) args.insert(args.end(), {"--physics", "none"});
  if (config.viewer) args.insert(args.end(), {"--viewer", "0", "--no-token"});
  DoppelProcess doppel(args, "ttyDXL0", config.camera);
  const std::string started = doppel.wait_for_output("running until");
  SerialClient client(doppel.link(), kBaud);
  const std::optional<double> rdt_us = return_delay_us(client);
  if (!rdt_us) {
    ++totals.failures;
    return;
  }
  totals.wire_model_us = 2.0 * kReadBytes * kByteUs + kProcessingUs + *rdt_us;

  std::optional<doppel::bench::Poller> poller;
  if (config.viewer) {
    std::smatch match;
    if (!std::regex_search(started, match, std::regex(R"(viewer on http://127\.0\.0\.1:(\d+)/)"))) {
      std::fprintf(stderr, "default_latency: doppel serves no viewer:\n%s", started.c_str());
      ++totals.failures;
      return;
    }
    const int port = std::stoi(match[1].str());
    const nlohmann::json cameras = doppel::bench::state(port)["robots"][0]["cameras"];
    poller.emplace(port, cameras.empty() ? "" : cameras[0]["name"].get<std::string>());
  }
  constexpr double kSubscribeS = 1.5;  // the subscriber finds the camera and frames flow
  std::optional<CameraSubscriber> subscriber;
  if (config.camera) {
    subscriber.emplace(seconds + kSubscribeS + 0.5, doppel.link_dir() + "/../camera_stats.txt");
    std::this_thread::sleep_for(std::chrono::duration<double>(kSubscribeS));
  }

  const Bytes request = doppel::testing::p1_instruction(1, 0x02, {36, 2});
  const Bytes echo_bytes(8, 0x55);
  std::vector<double> round_trips, echoes;
  const auto start = Clock::now();
  while (std::chrono::duration<double>(Clock::now() - start).count() < seconds) {
    const auto echo_start = Clock::now();
    if (echo.transact(echo_bytes, echo_bytes.size(), 200).size() == echo_bytes.size()) {
      echoes.push_back(elapsed_us(echo_start));
    }
    const auto t0 = Clock::now();
    const Bytes reply = client.transact(request, kReadBytes, 200);
    const double us = elapsed_us(t0);
    if (reply.size() == kReadBytes) {
      round_trips.push_back(us);
    } else {
      ++totals.failures;
    }
  }
  const double echo_p50 = percentiles(echoes).p50;
  for (double us : round_trips) totals.errors_us.push_back(std::fabs(us - echo_p50 - totals.wire_model_us));
  totals.round_trips_us.insert(totals.round_trips_us.end(), round_trips.begin(), round_trips.end());
  totals.echoes_us.insert(totals.echoes_us.end(), echoes.begin(), echoes.end());
  if (subscriber) {
    bool failed = false;
    totals.camera.push_back(subscriber->finish(failed));
    if (failed) ++totals.failures;  // the camera did not stream: not the configuration named
  }
  if (poller) {
    totals.failures += poller->failures.load();
    poller.reset();
  }
  if (!doppel::bench::stop_cleanly(doppel)) ++totals.failures;
  totals.lateness.push_back(doppel_lateness(doppel.output()));
}

}  // namespace

int main(int argc, char** argv) {
  double seconds = 3.0;
  int rounds = 3;
  bool quick = false;
  std::vector<std::string> config_names;
  std::vector<std::string> doppels;
  CLI::App app("Wire timing of doppel as users run it (physics, camera, viewer) beside the bare configuration",
               "default_latency");
  app.add_option("--seconds", seconds, "seconds per phase")->check(CLI::PositiveNumber);
  app.add_option("--rounds", rounds, "rounds of phases")->check(CLI::PositiveNumber);
  app.add_option("--config", config_names, "configurations to run (default: all)")
      ->check(CLI::IsMember({"bare", "physics", "camera", "default"}));
  app.add_option("--doppel", doppels, "LABEL=PATH: also run this doppel executable");
  app.add_flag("--quick", quick, "one round of 0.5 s phases");
  const char* usage =
      "usage: default_latency [--seconds S] [--rounds N] [--config bare|physics|camera|default ...]\n"
      "                       [--doppel LABEL=PATH ...] [--quick]\n";
  if (const std::optional<int> exit_code = doppel::bench::parse_command_line(app, argc, argv, usage)) {
    return *exit_code;
  }
  if (quick) {
    seconds = 0.5;
    rounds = 1;
  }
  std::vector<Config> configs;
  for (const Config& c : all_configs()) {
    if (config_names.empty() || std::find(config_names.begin(), config_names.end(), c.name) != config_names.end()) {
      configs.push_back(c);
    }
  }
  std::vector<Executable> executables;
  if (doppels.empty()) executables.push_back({"this build", ""});
  for (const std::string& d : doppels) {
    const std::size_t eq = d.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == d.size()) {
      std::fprintf(stderr, "default_latency: --doppel wants LABEL=PATH, not '%s'\n%s", d.c_str(), usage);
      return 2;
    }
    executables.push_back({d.substr(0, eq), d.substr(eq + 1)});
  }

  doppel::bench::PtyEcho echo_server;
  SerialClient echo(echo_server.path(), kBaud);
  std::map<std::pair<std::size_t, std::size_t>, Totals> totals;  // (executable, config)
  // Executables alternate within each configuration: the phases compared are next to each other.
  for (int round = 0; round < rounds; ++round) {
    for (std::size_t c = 0; c < configs.size(); ++c) {
      for (std::size_t e = 0; e < executables.size(); ++e) {
        measure_phase(configs[c], executables[e], seconds, echo, totals[{e, c}]);
      }
    }
  }

  std::printf("Protocol 1.0 at %u bps, doppel --robot fumanoid-2011 --timing wire, READ 2 B of servo 1 back to back; "
              "each sample after one bare pty echo (8 B out, 8 B back) through the same client code; %d round(s) of "
              "%.1f s per configuration, alternating.\n\n", kBaud, rounds, seconds);
  std::printf("| doppel | configuration | samples | p50 us | p99 us | echo p50 us | wire model us | timing error p50 us | "
              "p99 us | p99.9 us | max us | doppel's own lateness (per round) | failures |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  int failures = 0;
  std::vector<double> all_echoes;
  for (std::size_t e = 0; e < executables.size(); ++e) {
    for (std::size_t c = 0; c < configs.size(); ++c) {
      const Totals& t = totals[{e, c}];
      const Percentiles rt = percentiles(t.round_trips_us);
      const Percentiles error = percentiles(t.errors_us);
      std::string lateness;
      for (const std::string& l : t.lateness) lateness += (lateness.empty() ? "" : "; ") + l;
      std::printf("| %s | %s | %zu | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %s | %d |\n",
                  executables[e].label.c_str(), configs[c].name.c_str(), rt.count, rt.p50, rt.p99,
                  percentiles(t.echoes_us).p50, t.wire_model_us, error.p50, error.p99, error.p999, error.max,
                  lateness.c_str(), t.failures);
      failures += t.failures;
      all_echoes.insert(all_echoes.end(), t.echoes_us.begin(), t.echoes_us.end());
    }
  }
  const Percentiles floor = percentiles(all_echoes);
  std::printf("\nbare pty echo over all %zu samples of this run: p50 %.1f us, p99 %.1f us, p99.9 %.1f us\n", floor.count,
              floor.p50, floor.p99, floor.p999);
  std::printf("timing error = |round trip - echo p50 of the phase - wire model|; doppel's own lateness = its exit "
              "summary's delivery time minus due time (10 us bins)\n");
  for (std::size_t e = 0; e < executables.size(); ++e) {
    for (std::size_t c = 0; c < configs.size(); ++c) {
      for (const std::string& camera : totals[{e, c}].camera) {
        std::printf("camera subscriber (%s, %s): %s\n", executables[e].label.c_str(), configs[c].name.c_str(),
                    camera.c_str());
      }
    }
  }
  std::printf("failures (timeouts, corrupt replies, unclean exit, viewer requests, camera subscriber): %d\n", failures);
  return failures == 0 ? 0 : 1;
}
