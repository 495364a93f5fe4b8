#pragma once
// The `doppel-levels` thread (--sensor-levels HZ, docs/multilevel.md "Sensor levels"): takes every
// robot's newest sensor-levels samples, which its bus threads publish at HZ of simulation time
// (body/sensor_levels.h), decodes them into one levels::SensorLevels message per robot and hands it
// to a sink (the truth publisher's topic `sensor_levels`). Not real-time: protobuf allocates here,
// never on the bus or simulation threads, and a slow sink only makes it skip samples.

#include <atomic>
#include <chrono>
#include <cstddef>
#include <functional>
#include <thread>
#include <vector>

#include "proto/sensor_levels.pb.h"

namespace doppel::gateway {

class RobotRuntime;

class SensorLevelsFeed {
 public:
  using Sink = std::function<void(std::size_t robot, const levels::SensorLevels& message)>;

  // `robots` outlive the feed; `poll`: how often it looks for new samples (wall clock).
  SensorLevelsFeed(std::vector<RobotRuntime*> robots, Sink sink,
                   std::chrono::microseconds poll = std::chrono::milliseconds(2));
  ~SensorLevelsFeed();
  SensorLevelsFeed(const SensorLevelsFeed&) = delete;
  SensorLevelsFeed& operator=(const SensorLevelsFeed&) = delete;

  void start();
  void stop();  // idempotent
  // Runs one pass on the calling thread (what the thread does every `poll`); the number of messages
  // handed to the sink. Only while the thread does not run.
  std::size_t poll_once();
  uint64_t messages() const noexcept { return messages_.load(std::memory_order_relaxed); }

 private:
  std::vector<RobotRuntime*> robots_;
  Sink sink_;
  std::chrono::microseconds poll_;
  levels::SensorLevels message_;  // reused: its fields keep their capacity
  std::atomic<bool> stop_{false};
  std::atomic<uint64_t> messages_{0};
  std::thread thread_;
};

}  // namespace doppel::gateway
