#pragma once
// A contract::RobotHost that builds nothing: it records every call and request, serves robots as a
// list, and refuses what the test tells it to. Robot 0 stands for the robot doppel was started
// with; added robots get the next index (indices are not reused).

#include <atomic>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "contract/robot_host.h"

namespace doppel::handshake::testing {

class FakeRobotHost : public contract::RobotHost {
 public:
  FakeRobotHost() { served_.push_back(contract::RobotAdded{0, "fumanoid-2011", {{"bus", "ttyDXL0", "/links/ttyDXL0"}}}); }

  contract::AddResult add_robot(const contract::RobotRequest& request) override {
    std::lock_guard<std::mutex> lock(mutex_);
    ++add_calls;
    requests_.push_back(request);
    if (refuse_next_add) {
      contract::Refusal refusal = *refuse_next_add;
      refuse_next_add.reset();
      return refusal;
    }
    const uint32_t index = next_++;
    contract::RobotAdded added{index, request.robot.empty() ? "inline" : request.robot, {}};
    if (links) {
      added.links = links(index);
    } else {
      const std::string dir = "/links/robot" + std::to_string(index);
      added.links = {{"bus", "ttyDXL0", dir + "/ttyDXL0"}, {"camera", "head", "iceoryx:DoppelCamera/head" + std::to_string(index) + "/frames"}};
    }
    served_.push_back(added);
    return added;
  }

  std::optional<contract::Refusal> remove_robot(uint32_t robot) override {
    std::lock_guard<std::mutex> lock(mutex_);
    ++remove_calls;
    removed_.push_back(robot);
    for (auto it = served_.begin(); it != served_.end(); ++it) {
      if (it->robot == robot) {
        served_.erase(it);
        return std::nullopt;
      }
    }
    return contract::Refusal{"", "there is no robot " + std::to_string(robot)};
  }

  std::vector<contract::RobotAdded> robots() override {
    std::lock_guard<std::mutex> lock(mutex_);
    ++robots_calls;
    return served_;
  }

  std::vector<contract::RobotRequest> requests() {
    std::lock_guard<std::mutex> lock(mutex_);
    return requests_;
  }
  std::vector<uint32_t> removed() {
    std::lock_guard<std::mutex> lock(mutex_);
    return removed_;
  }

  std::atomic<int> add_calls{0};
  std::atomic<int> remove_calls{0};
  std::atomic<int> robots_calls{0};
  std::optional<contract::Refusal> refuse_next_add;       // set before the request, under no race
  std::function<std::vector<contract::Link>(uint32_t)> links;  // the links of an added robot; unset = made-up paths

 private:
  std::mutex mutex_;
  std::vector<contract::RobotRequest> requests_;
  std::vector<uint32_t> removed_;
  std::vector<contract::RobotAdded> served_;
  uint32_t next_ = 1;
};

}  // namespace doppel::handshake::testing
