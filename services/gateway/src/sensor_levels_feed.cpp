#include "sensor_levels_feed.h"

#include "robot_runtime.h"
#include "truth/transport.h"

namespace doppel::gateway {

SensorLevelsFeed::SensorLevelsFeed(std::vector<RobotRuntime*> robots) : robots_(std::move(robots)) {}

std::size_t SensorLevelsFeed::poll(const Sink& sink) {
  std::size_t handed = 0;
  for (std::size_t r = 0; r < robots_.size(); ++r) {
    if (!robots_[r]->sensor_levels(message_)) continue;
    sink(r, message_);
    ++handed;
    ++messages_;
  }
  return handed;
}

std::size_t SensorLevelsFeed::publish(truth::Transport& transport) {
  return poll([&](std::size_t robot, const levels::SensorLevels& message) {
    if (!transport.has_robot(robot)) transport.add_robot(robot);
    message.SerializeToString(&bytes_);
    transport.send(robot, kSensorLevelsTopic, bytes_);
  });
}

}  // namespace doppel::gateway
