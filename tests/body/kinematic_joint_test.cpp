#include "body/kinematic_joint.h"

#include <gtest/gtest.h>

namespace doppel::body {
namespace {

constexpr double kDt = 0.001;

dynamixel::ServoCommand goal(double position_rad, double speed_rad_s = 0.0) {
  dynamixel::ServoCommand command;
  command.torque_enabled = true;
  command.goal_position_rad = position_rad;
  command.moving_speed_rad_s = speed_rad_s;
  return command;
}

TEST(KinematicJoint, MovesAtTheNoLoadSpeedWhenMovingSpeedIsZero) {
  KinematicJoint sut(6.0);
  for (int i = 0; i < 100; ++i) {
    sut.step(goal(1.0), kDt);
  }
  EXPECT_NEAR(sut.position_rad(), 0.6, 1e-9);
  EXPECT_NEAR(sut.velocity_rad_s(), 6.0, 1e-9);
}

TEST(KinematicJoint, MovingSpeedLimitsButNeverExceedsTheMotor) {
  KinematicJoint slow(6.0);
  KinematicJoint capped(6.0);
  for (int i = 0; i < 100; ++i) {
    slow.step(goal(1.0, 2.0), kDt);
    capped.step(goal(1.0, 50.0), kDt);
  }
  EXPECT_NEAR(slow.position_rad(), 0.2, 1e-9);
  EXPECT_NEAR(capped.position_rad(), 0.6, 1e-9);
}

TEST(KinematicJoint, StopsExactlyAtTheGoal) {
  KinematicJoint sut(6.0, 0.5);
  for (int i = 0; i < 1000; ++i) {
    sut.step(goal(-0.25), kDt);
  }
  EXPECT_DOUBLE_EQ(sut.position_rad(), -0.25);
  EXPECT_DOUBLE_EQ(sut.velocity_rad_s(), 0.0);
}

TEST(KinematicJoint, TorqueOffHoldsStill) {
  KinematicJoint sut(6.0, 0.3);
  dynamixel::ServoCommand command = goal(1.0);
  command.torque_enabled = false;
  sut.step(command, kDt);
  EXPECT_DOUBLE_EQ(sut.position_rad(), 0.3);
  EXPECT_DOUBLE_EQ(sut.velocity_rad_s(), 0.0);
}

TEST(KinematicJoint, WheelModeTurnsAtTheSignedSpeed) {
  KinematicJoint sut(6.0);
  dynamixel::ServoCommand command = goal(0.0, -2.0);
  command.wheel_mode = true;
  for (int i = 0; i < 100; ++i) {
    sut.step(command, kDt);
  }
  EXPECT_NEAR(sut.position_rad(), -0.2, 1e-9);
  EXPECT_NEAR(sut.velocity_rad_s(), -2.0, 1e-9);
}

}  // namespace
}  // namespace doppel::body
