#include "sensor_levels_feed.h"

#include <pthread.h>

#include "robot_runtime.h"

namespace doppel::gateway {

SensorLevelsFeed::SensorLevelsFeed(std::vector<RobotRuntime*> robots, Sink sink, std::chrono::microseconds poll)
    : robots_(std::move(robots)), sink_(std::move(sink)), poll_(poll) {}

SensorLevelsFeed::~SensorLevelsFeed() { stop(); }

void SensorLevelsFeed::start() {
  if (thread_.joinable()) return;
  stop_ = false;
  thread_ = std::thread([this] {
    pthread_setname_np(pthread_self(), "doppel-levels");
    while (!stop_.load(std::memory_order_acquire)) {
      poll_once();
      std::this_thread::sleep_for(poll_);
    }
  });
}

void SensorLevelsFeed::stop() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

std::size_t SensorLevelsFeed::poll_once() {
  std::size_t handed = 0;
  for (std::size_t r = 0; r < robots_.size(); ++r) {
    if (!robots_[r]->sensor_levels(message_)) continue;
    sink_(r, message_);
    ++handed;
    messages_.fetch_add(1, std::memory_order_relaxed);
  }
  return handed;
}

}  // namespace doppel::gateway
