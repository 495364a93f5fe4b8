// doppel: serves the Dynamixel buses of simulated robots on pseudo-terminals until SIGINT/SIGTERM.
#include <pthread.h>
#include <signal.h>

#include <cstdio>
#include <exception>
#include <iostream>
#include <stdexcept>

#include "gateway/gateway.h"
#include "gateway/options.h"
#include "gateway/robot_config.h"

int main(int argc, char** argv) {
  using namespace doppel::gateway;
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
  if (options.robots_dir.empty()) {
    options.robots_dir = default_robots_dir();
  }
  if (options.list_robots) {
    for (const std::string& name : list_robots(options.robots_dir)) {
      std::cout << name << "\n";
    }
    return 0;
  }

  // Block the stop signals before any thread starts, so every thread inherits the mask and only
  // sigwait() below receives them.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);
  signal(SIGPIPE, SIG_IGN);

  try {
    Gateway gateway(options);
    gateway.start();
    std::cout << gateway.describe() << std::flush;
    int received = 0;
    sigwait(&stop_signals, &received);
    std::cout << "doppel: " << (received == SIGINT ? "SIGINT" : "SIGTERM") << ", stopping\n" << std::flush;
    gateway.stop();
    std::cout << gateway.summary() << std::flush;
  } catch (const std::exception& e) {
    std::cerr << "doppel: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
