#pragma once
// A joint moved without dynamics: until the physics engine drives the servos, a joint turns toward
// its goal at the commanded Moving Speed, or at the motor's no-load speed when the command sets no
// limit, so that Present Position, Present Speed and the Moving flag behave plausibly.
// No gravity and no load: with torque off the joint simply stays where it is.

#include "dynamixel/device_io.h"

namespace doppel::body {

class KinematicJoint {
 public:
  explicit KinematicJoint(double no_load_speed_rad_s, double initial_position_rad = 0.0) noexcept
      : no_load_speed_rad_s_(no_load_speed_rad_s), position_rad_(initial_position_rad) {}

  // Advances the joint by dt_s under `command`. rt-safe.
  void step(const dynamixel::ServoCommand& command, double dt_s) noexcept;

  double position_rad() const noexcept { return position_rad_; }
  double no_load_speed_rad_s() const noexcept { return no_load_speed_rad_s_; }
  double velocity_rad_s() const noexcept { return velocity_rad_s_; }

 private:
  double no_load_speed_rad_s_;  // the motor's top speed at the supply voltage
  double position_rad_;         // joint angle, 0 = centre of the servo's range
  double velocity_rad_s_ = 0.0; // speed over the last step
};

}  // namespace doppel::body
