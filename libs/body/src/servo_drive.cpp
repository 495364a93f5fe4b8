#include "body/servo_drive.h"

#include "body/feedback.h"

namespace doppel::body {

void ServoDrive::drive(physics::World& world, const dynamixel::ServoCommand& command, double dt_s) noexcept {
  const physics::MotorState state = world.motor(motor_);
  const dynamixel::ControllerOutput out =
      controller_.update(command, state.position_rad, state.velocity_rad_s, dt_s, state.voltage_v);
  overload_ = out.overload;
  world.set_motor(motor_, physics::MotorCommand{command.torque_enabled, out.pwm_ratio, command.torque_limit_ratio});
}

void ServoDrive::reset(const physics::World& world) noexcept {
  controller_.reset(world.motor(motor_).position_rad);
  overload_ = false;
}

dynamixel::ServoFeedback ServoDrive::sense(const physics::World& world, int64_t sim_time_ns) const noexcept {
  return servo_feedback(world.motor(motor_), overload_, sim_time_ns);
}

}  // namespace doppel::body
