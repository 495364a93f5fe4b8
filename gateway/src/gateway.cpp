#include "gateway/gateway.h"

#include <pthread.h>

#include <sstream>

#include "gateway/fixed_rate_clock.h"
#include "gateway/robot_config.h"
#include "robot_runtime.h"

namespace doppel::gateway {

inline constexpr int64_t kSimulationStepNs = 1'000'000;  // 1 kHz

std::string link_path(const std::string& link_dir, std::size_t robot, std::size_t bus) {
  std::string name = "ttyDXL" + std::to_string(bus);
  return robot == 0 ? link_dir + "/" + name : link_dir + "/robot" + std::to_string(robot) + "/" + name;
}

Gateway::Gateway(const Options& options) : options_(options) {
  std::string robots_dir = options.robots_dir.empty() ? default_robots_dir() : options.robots_dir;
  for (std::size_t r = 0; r < options.robots.size(); ++r) {
    robots_.push_back(std::make_unique<RobotRuntime>(load_robot(options.robots[r], robots_dir), r, options_));
  }
}

Gateway::~Gateway() { stop(); }

void Gateway::start() {
  if (running_.exchange(true)) {
    return;
  }
  stop_ = false;
  for (auto& robot : robots_) {
    robot->start(stop_, options_.rt_priority);
  }
  simulation_thread_ = std::thread([this] {
    pthread_setname_np(pthread_self(), "doppel-sim");
    simulate();
  });
}

void Gateway::stop() {
  running_ = false;
  stop_ = true;
  if (simulation_thread_.joinable()) {
    simulation_thread_.join();
  }
  for (auto& robot : robots_) {
    robot->join();
  }
}

void Gateway::simulate() noexcept {
  FixedRateClock clock(kSimulationStepNs);
  int64_t sim_time_ns = 0;
  const double dt_s = static_cast<double>(kSimulationStepNs) * 1e-9;
  while (running_.load(std::memory_order_relaxed)) {
    sim_time_ns += kSimulationStepNs;
    for (auto& robot : robots_) {
      robot->simulate(dt_s, sim_time_ns);
    }
    clock.wait_next();
  }
  missed_ticks_ = clock.missed_ticks();
}

std::string Gateway::describe() const {
  std::ostringstream out;
  for (const auto& robot : robots_) {
    out << robot->describe();
  }
  const char* timing = options_.timing == bus::TimingMode::kWire ? "wire" : "fast";
  out << "doppel: timing " << timing << ", firmware time " << options_.processing_us << " us, USB latency timer "
      << (options_.latency_timer_ms == 0 ? std::string("off") : std::to_string(options_.latency_timer_ms) + " ms")
      << "; running until SIGINT/SIGTERM\n";
  return out.str();
}

std::string Gateway::summary() const {
  std::ostringstream out;
  for (const auto& robot : robots_) {
    out << robot->summary();
  }
  out << "  simulation: " << missed_ticks_ << " missed 1 ms ticks\n";
  return out.str();
}

}  // namespace doppel::gateway
