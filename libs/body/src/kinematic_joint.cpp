#include "body/kinematic_joint.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace doppel::body {

void KinematicJoint::step(const dynamixel::ServoCommand& command, double dt_s) noexcept {
  if (!command.torque_enabled || dt_s <= 0.0) {
    velocity_rad_s_ = 0.0;
    return;
  }
  double top_speed = no_load_speed_rad_s_;
  if (command.wheel_mode) {
    velocity_rad_s_ = std::clamp(command.moving_speed_rad_s, -top_speed, top_speed);
    position_rad_ = std::remainder(position_rad_ + velocity_rad_s_ * dt_s, 2.0 * std::numbers::pi);
    return;
  }
  if (command.moving_speed_rad_s > 0.0) {
    top_speed = std::min(top_speed, command.moving_speed_rad_s);
  }
  double error = command.goal_position_rad - position_rad_;
  double max_step = top_speed * dt_s;
  double step = std::clamp(error, -max_step, max_step);
  position_rad_ += step;
  velocity_rad_s_ = step / dt_s;
}

}  // namespace doppel::body
