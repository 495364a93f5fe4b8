#include "body/kinematic_body.h"

namespace doppel::body {

std::size_t KinematicBody::add_servo(uint32_t, uint8_t, const ServoSetup& setup) {
  servos_.push_back(Servo{KinematicJoint(setup.no_load_speed_rad_s), setup.supply_voltage_v});
  return servos_.size() - 1;
}

void KinematicBody::reset() noexcept {
  for (Servo& servo : servos_) servo.joint = KinematicJoint(servo.joint.no_load_speed_rad_s());
}

std::size_t KinematicBody::add_imu(uint32_t, uint8_t) { return 0; }  // every IMU reads the same

std::size_t KinematicBody::add_foot(uint32_t, uint8_t) { return foot_boards_++; }

void KinematicBody::drive(std::size_t servo, const dynamixel::ServoCommand& command, double dt_s) noexcept {
  if (servo < servos_.size()) {
    servos_[servo].joint.step(command, dt_s);
  }
}

dynamixel::ServoFeedback KinematicBody::servo(std::size_t servo, int64_t sim_time_ns) const noexcept {
  dynamixel::ServoFeedback feedback;
  if (servo < servos_.size()) {
    feedback.position_rad = servos_[servo].joint.position_rad();
    feedback.velocity_rad_s = servos_[servo].joint.velocity_rad_s();
    feedback.voltage_v = servos_[servo].supply_voltage_v;
  }
  feedback.sim_time_ns = sim_time_ns;
  return feedback;
}

dynamixel::ImuFeedback KinematicBody::imu(std::size_t, int64_t sim_time_ns) const noexcept {
  dynamixel::ImuFeedback feedback;
  feedback.sim_time_ns = sim_time_ns;
  return feedback;
}

dynamixel::FootFeedback KinematicBody::foot(std::size_t, int64_t sim_time_ns) const noexcept {
  dynamixel::FootFeedback feedback;
  if (foot_boards_ > 0) {
    feedback.force_n.fill(mass_kg_ * kGravityM_S2 / (4.0 * static_cast<double>(foot_boards_)));
  }
  feedback.sim_time_ns = sim_time_ns;
  return feedback;
}

}  // namespace doppel::body
