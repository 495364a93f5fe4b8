#include "body/feedback.h"

namespace doppel::body {

dynamixel::ServoFeedback servo_feedback(const physics::MotorState& motor, bool overload, int64_t sim_time_ns) noexcept {
  dynamixel::ServoFeedback feedback;
  feedback.position_rad = motor.position_rad;
  feedback.velocity_rad_s = motor.velocity_rad_s;
  feedback.torque_ratio = motor.torque_ratio;
  feedback.voltage_v = motor.voltage_v;
  feedback.temperature_c = motor.temperature_c;
  feedback.current_a = motor.current_a;
  feedback.torque_nm = motor.torque_nm;
  feedback.overload = overload;
  feedback.sim_time_ns = sim_time_ns;
  return feedback;
}

dynamixel::ImuFeedback imu_feedback(const physics::ImuState& imu) noexcept {
  dynamixel::ImuFeedback feedback;
  feedback.roll_rad = imu.roll_rad;
  feedback.pitch_rad = imu.pitch_rad;
  feedback.yaw_rad = imu.yaw_rad;
  feedback.w_WS_S_rad_s = imu.w_WS_S_rad_s;
  feedback.a_WS_S_m_s2 = imu.a_WS_S_m_s2;
  feedback.sim_time_ns = imu.sim_time_ns;
  return feedback;
}

dynamixel::FootFeedback foot_feedback(const physics::FootState& foot) noexcept {
  return dynamixel::FootFeedback{foot.force_n, foot.sim_time_ns};
}

}  // namespace doppel::body
