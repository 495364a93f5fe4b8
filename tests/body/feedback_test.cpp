// The one conversion from the world's readouts to what the devices measure: every quantity the
// devices read arrives, unchanged in unit and sign.

#include "body/feedback.h"

#include <gtest/gtest.h>

namespace doppel::body {
namespace {

TEST(Feedback, ServoReadsItsMotor) {
  physics::MotorState motor;
  motor.position_rad = 0.5;
  motor.velocity_rad_s = -1.5;
  motor.torque_nm = -2.0;
  motor.torque_ratio = -0.4;
  motor.current_a = -1.1;
  motor.supply_current_a = 0.3;
  motor.temperature_c = 41.0;
  motor.voltage_v = 12.0;

  const dynamixel::ServoFeedback sut = servo_feedback(motor, true, 123);

  EXPECT_EQ(sut.position_rad, 0.5);
  EXPECT_EQ(sut.velocity_rad_s, -1.5);
  EXPECT_EQ(sut.torque_ratio, -0.4);
  EXPECT_EQ(sut.current_a, -1.1);  // the winding's, signed like the torque
  EXPECT_EQ(sut.torque_nm, -2.0);  // the sensor levels' truth
  EXPECT_EQ(sut.temperature_c, 41.0);
  EXPECT_EQ(sut.voltage_v, 12.0);
  EXPECT_TRUE(sut.overload);
  EXPECT_EQ(sut.sim_time_ns, 123);
}

TEST(Feedback, ImuAndFootReadTheirSensors) {
  physics::ImuState imu;
  imu.roll_rad = 0.1;
  imu.pitch_rad = 0.2;
  imu.yaw_rad = 0.3;
  imu.w_WS_S_rad_s = {1.0, 2.0, 3.0};
  imu.a_WS_S_m_s2 = {4.0, 5.0, 6.0};
  imu.sim_time_ns = 9;
  physics::FootState foot;
  foot.force_n = {1.0, 2.0, 3.0, 4.0};
  foot.sim_time_ns = 10;

  const dynamixel::ImuFeedback i = imu_feedback(imu);
  const dynamixel::FootFeedback f = foot_feedback(foot);

  EXPECT_EQ(i.roll_rad, 0.1);
  EXPECT_EQ(i.pitch_rad, 0.2);
  EXPECT_EQ(i.yaw_rad, 0.3);
  EXPECT_EQ(i.w_WS_S_rad_s, (std::array<double, 3>{1.0, 2.0, 3.0}));
  EXPECT_EQ(i.a_WS_S_m_s2, (std::array<double, 3>{4.0, 5.0, 6.0}));
  EXPECT_EQ(i.sim_time_ns, 9);
  EXPECT_EQ(f.force_n, (std::array<double, 4>{1.0, 2.0, 3.0, 4.0}));
  EXPECT_EQ(f.sim_time_ns, 10);
}

}  // namespace
}  // namespace doppel::body
