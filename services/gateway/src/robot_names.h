#pragma once
// The names doppel gives a robot's parts by its index, so that two robots of one robot file do
// not collide on one machine: robots after the first stream their cameras as "robot<r>-<camera>".

#include <cstddef>
#include <string>

namespace doppel::gateway {

inline std::string robot_camera_name(std::size_t robot, const std::string& camera) {
  return robot > 0 ? "robot" + std::to_string(robot) + "-" + camera : camera;
}

}  // namespace doppel::gateway
