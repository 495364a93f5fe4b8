#pragma once
// The servo drive loop, in one place for the gateway and the tests: every firmware cycle the
// servo's motor controller (dynamixel/servo_controller.h) turns the control table's command and
// the motor's last measured angle and speed into an H-bridge duty for the motor in the world;
// after the world stepped, the motor's state becomes what the servo measures (body/feedback.h),
// with the controller's overload verdict. Not thread-safe: the simulation thread's.

#include <cstdint>

#include "dynamixel/device_io.h"
#include "dynamixel/servo_controller.h"
#include "physics/world.h"

namespace doppel::body {

class ServoDrive {
 public:
  ServoDrive(physics::MotorHandle motor, const dynamixel::ServoControllerConfig& config) noexcept
      : motor_(motor), controller_(config) {}

  // Before world.step(): one controller cycle of `dt_s` on `command`, its duty to the motor. rt-safe.
  void drive(physics::World& world, const dynamixel::ServoCommand& command, double dt_s) noexcept;
  // After world.step(): what the servo measures. rt-safe.
  dynamixel::ServoFeedback sense(const physics::World& world, int64_t sim_time_ns) const noexcept;

  // Power-on: the controller forgets its state, at the motor's present angle. rt-safe.
  void reset(const physics::World& world) noexcept;

  physics::MotorHandle motor() const noexcept { return motor_; }

 private:
  physics::MotorHandle motor_;
  dynamixel::ServoController controller_;
  bool overload_ = false;  // the controller's verdict of the last cycle
};

}  // namespace doppel::body
