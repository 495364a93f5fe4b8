// doppel: serves the Dynamixel buses of simulated robots on pseudo-terminals until SIGINT/SIGTERM,
// or runs a scenario (doppel scenario run FILE, scenario/).
#include <signal.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <iostream>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string_view>
#include <thread>

#include "base/stop_signals.h"
#include "gateway/gateway.h"
#include "gateway/options.h"
#include "gateway/robot_config.h"
#include "scenario/run.h"

namespace {

const char* signal_name(int signal_number) { return signal_number == SIGINT ? "SIGINT" : "SIGTERM"; }

}  // namespace

int main(int argc, char** argv) {
  using namespace doppel::gateway;
  if (argc > 1 && std::string_view(argv[1]) == "scenario") {  // doppel scenario run FILE (docs/scenarios.md)
    return doppel::scenario::scenario_main(argc - 1, argv + 1, std::cout, std::cerr);
  }
  Options options;
  try {
    options = parse_options(argc, argv);
  } catch (const std::invalid_argument& e) {
    std::cerr << "doppel: " << e.what() << "\n";
    return 2;
  }
  if (options.help) {
    std::cout << usage();
    return 0;
  }
  if (options.buses.robots_dir.empty()) {
    options.buses.robots_dir = default_robots_dir();
  }
  if (options.buses.list_robots) {
    // One line a robot: its name, then its description, or why its file cannot be used.
    for (const std::string& name : list_robots(options.buses.robots_dir)) {
      std::string about;
      try {
        about = load_robot(name, options.buses.robots_dir).description;
      } catch (const std::exception& e) {
        about = std::string("(cannot be loaded: ") + e.what() + ")";
      }
      std::cout << name << std::string(name.size() < 16 ? 16 - name.size() : 1, ' ') << about << "\n";
    }
    return 0;
  }

  // Block the stop signals before any thread starts, so every thread inherits the mask and only
  // the signal thread below receives them. While the robot files load (no side effects yet) a
  // signal ends doppel at once; while ports and links are set up, doppel stops (removing them)
  // instead of starting to serve. Either way it is a requested stop: exit code 0.
  const sigset_t stop_signals = doppel::block_stop_signals();
  enum Phase { kLoading, kSettingUp, kServing };
  static std::mutex phase_mutex;  // held by the signal thread from reading kLoading until it exits
  static Phase phase = kLoading;
  static std::atomic<int> received{0};
  std::thread([stop_signals] {
    int signal_number = 0;
    sigwait(&stop_signals, &signal_number);
    std::lock_guard<std::mutex> lock(phase_mutex);
    if (phase != kServing) {
      std::cerr << "doppel: " << signal_name(signal_number) << " while starting up; stopping\n" << std::flush;
      if (phase == kLoading) {
        std::_Exit(0);
      }
    }
    received.store(signal_number);
    received.notify_all();
  }).detach();

  try {
    std::vector<RobotConfig> robots = load_robots(options);
    const SessionConfig session = options.world.session.empty() ? SessionConfig{} : load_session(options.world.session);
    {
      std::lock_guard<std::mutex> lock(phase_mutex);
      phase = kSettingUp;
    }
    Gateway gateway(options, std::move(robots), session);
    bool stopped_while_setting_up = false;
    {
      std::lock_guard<std::mutex> lock(phase_mutex);
      stopped_while_setting_up = received.load() != 0;  // the signal thread said so already
      phase = kServing;
    }
    if (stopped_while_setting_up) {
      return 0;
    }
    gateway.start();
    std::cout << gateway.describe() << std::flush;
    received.wait(0);
    std::cout << "doppel: " << signal_name(received.load()) << ", stopping\n" << std::flush;
    gateway.stop();
    std::cout << gateway.summary() << std::flush;
  } catch (const std::exception& e) {
    std::cerr << "doppel: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
