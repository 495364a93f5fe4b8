#pragma once
// Sensor levels on the truth transport (--sensor-levels HZ, docs/multilevel.md "Sensor levels"):
// takes every robot's newest sensor-levels samples, which its bus threads publish at HZ of
// simulation time (body/sensor_levels.h), decodes them into one levels::SensorLevels message per
// robot and sends it as the robot's topic `sensor_levels`. It runs on the doppel-truth thread as one
// of its pollers (truth::TruthService::add_poller), not on a real-time thread: protobuf allocates
// here, never on the bus or simulation threads, and when this thread is slow it only skips samples.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "proto/sensor_levels.pb.h"

namespace doppel::truth {
class Transport;
}

namespace doppel::gateway {

class RobotRuntime;

inline constexpr const char kSensorLevelsTopic[] = "sensor_levels";

class SensorLevelsFeed {
 public:
  using Sink = std::function<void(std::size_t robot, const levels::SensorLevels& message)>;

  // `robots` (by the control API's index) outlive the feed.
  explicit SensorLevelsFeed(std::vector<RobotRuntime*> robots);

  // Hands every robot's message to `sink` when one of its buses published a new sample; the number
  // of messages. One thread at a time.
  std::size_t poll(const Sink& sink);
  // poll() into `transport`, serialised, on topic `sensor_levels` (a robot the transport does not
  // know yet is added first). The doppel-truth thread.
  std::size_t publish(truth::Transport& transport);
  uint64_t messages() const noexcept { return messages_; }

 private:
  std::vector<RobotRuntime*> robots_;
  levels::SensorLevels message_;  // reused: its fields keep their capacity
  std::string bytes_;
  uint64_t messages_ = 0;
};

}  // namespace doppel::gateway
