// The body of a robot without a simulated one: kinematic joints, level IMUs, the weight spread over
// the load cells, no motor currents.

#include "body/kinematic_body.h"

#include <gtest/gtest.h>

namespace doppel::body {
namespace {

dynamixel::ServoCommand goal(double position_rad) {
  dynamixel::ServoCommand command;
  command.torque_enabled = true;
  command.goal_position_rad = position_rad;
  return command;
}

TEST(KinematicBody, ServosMoveAtTheirNoLoadSpeedAndReadTheirSupply) {
  KinematicBody sut;
  const std::size_t slow = sut.add_servo(0, 1, ServoSetup{{}, 2.0, 12.0});
  const std::size_t fast = sut.add_servo(1, 2, ServoSetup{{}, 6.0, 14.8});

  for (int i = 0; i < 100; ++i) {
    sut.drive(slow, goal(1.0), 0.001);
    sut.drive(fast, goal(-1.0), 0.001);
  }

  const dynamixel::ServoFeedback a = sut.servo(slow, 100'000'000);
  const dynamixel::ServoFeedback b = sut.servo(fast, 100'000'000);
  EXPECT_NEAR(a.position_rad, 0.2, 1e-9);
  EXPECT_NEAR(a.velocity_rad_s, 2.0, 1e-9);
  EXPECT_NEAR(b.position_rad, -0.6, 1e-9);
  EXPECT_EQ(a.voltage_v, 12.0);
  EXPECT_EQ(b.voltage_v, 14.8);
  EXPECT_EQ(a.current_a, 0.0);
  EXPECT_FALSE(a.overload);
  EXPECT_EQ(a.sim_time_ns, 100'000'000);
  EXPECT_EQ(sut.servo_supply_current_a(), 0.0);
}

TEST(KinematicBody, TheWeightSpreadsOverEveryCellOfEveryFootBoard) {
  KinematicBody sut(5.0);
  const std::size_t left = sut.add_foot(2, 102);
  const std::size_t right = sut.add_foot(3, 101);

  const dynamixel::FootFeedback l = sut.foot(left, 7);
  const dynamixel::FootFeedback r = sut.foot(right, 7);

  for (double cell_n : l.force_n) EXPECT_NEAR(cell_n, 5.0 * 9.80665 / 8.0, 1e-9);
  for (double cell_n : r.force_n) EXPECT_NEAR(cell_n, 5.0 * 9.80665 / 8.0, 1e-9);
  EXPECT_EQ(l.sim_time_ns, 7);
}

TEST(KinematicBody, ImusAreLevelAndAtRest) {
  KinematicBody sut;
  const std::size_t imu = sut.add_imu(0, 241);

  const dynamixel::ImuFeedback reading = sut.imu(imu, 3);

  EXPECT_EQ(reading.roll_rad, 0.0);
  EXPECT_EQ(reading.pitch_rad, 0.0);
  EXPECT_EQ(reading.a_WS_S_m_s2[2], 9.80665);  // gravity's specific force, up
  EXPECT_EQ(reading.w_WS_S_rad_s[0], 0.0);
  EXPECT_EQ(reading.sim_time_ns, 3);
}

}  // namespace
}  // namespace doppel::body
