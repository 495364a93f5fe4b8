#include "dynamixel/servo_controller.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "dynamixel/model_registry.h"

namespace doppel::dynamixel {
namespace {

constexpr double kDt = 0.001;
constexpr double kPi = 3.14159265358979323846;
// AX/RX position unit (reference §5: 1024 steps over 300 deg, 0.29 deg) and MX/X (4096 per turn).
constexpr double kRxUnit = 300.0 / 1024.0 * kPi / 180.0;
constexpr double kMxUnit = 2.0 * kPi / 4096.0;
// MX (Protocol 1.0 firmware) PID output: duty = 0.158 x P x error in rad, measured by Rhoban on
// MX-64/MX-106 with an oscilloscope (Rhoban/bam, bam/dynamixel/actuator.py, MXActuator error_gain).
// With the e-Manual's Kp = P / 8 output units per position unit, one output unit is this duty:
constexpr double kMxDutyPerRadAndP = 0.158;
constexpr double kMxDutyPerOutputUnit = 8.0 * kMxDutyPerRadAndP * kMxUnit;

ServoCommand compliance_command(double goal_rad) {
  ServoCommand c;
  c.torque_enabled = true;
  c.goal_position_rad = goal_rad;
  c.cw_compliance_margin_raw = 1;  // e-Manual defaults
  c.ccw_compliance_margin_raw = 1;
  c.cw_compliance_slope_raw = 32;
  c.ccw_compliance_slope_raw = 32;
  c.punch_raw = 32;
  return c;
}

TEST(ServoControllerTest, TorqueOffGivesNoDrive) {
  ServoController sut(servo_controller_config("RX-64"));
  ServoCommand command = compliance_command(1.0);
  command.torque_enabled = false;

  const ControllerOutput out = sut.update(command, 0.0, 0.0, kDt);

  EXPECT_EQ(out.pwm_ratio, 0.0);
}

TEST(ServoControllerTest, ComplianceMarginIsADeadBand) {
  ServoController sut(servo_controller_config("RX-64"));

  const ControllerOutput out = sut.update(compliance_command(0.9 * kRxUnit), 0.0, 0.0, kDt);

  EXPECT_EQ(out.pwm_ratio, 0.0);
}

TEST(ServoControllerTest, ComplianceStartsAtPunchAndReachesFullDriveAtMarginPlusSlope) {
  ServoController sut(servo_controller_config("RX-64"));
  const double punch = 32.0 / 1023.0;

  const double just_out = sut.update(compliance_command(1.0001 * kRxUnit), 0.0, 0.0, kDt).pwm_ratio;
  const double halfway = sut.update(compliance_command(17.0 * kRxUnit), 0.0, 0.0, kDt).pwm_ratio;
  const double full = sut.update(compliance_command(33.0 * kRxUnit), 0.0, 0.0, kDt).pwm_ratio;
  const double cw = sut.update(compliance_command(-33.0 * kRxUnit), 0.0, 0.0, kDt).pwm_ratio;

  EXPECT_NEAR(just_out, punch, 1e-4);
  EXPECT_NEAR(halfway, punch + (1.0 - punch) * 16.0 / 32.0, 1e-9);
  EXPECT_NEAR(full, 1.0, 1e-9);
  EXPECT_NEAR(cw, -1.0, 1e-9);
}

TEST(ServoControllerTest, ComplianceSlopeUsesTheRepresentativeSteps) {
  EXPECT_EQ(compliance_slope_step(0), 2);  // e-Manual table
  EXPECT_EQ(compliance_slope_step(3), 2);
  EXPECT_EQ(compliance_slope_step(4), 4);
  EXPECT_EQ(compliance_slope_step(31), 16);
  EXPECT_EQ(compliance_slope_step(32), 32);
  EXPECT_EQ(compliance_slope_step(63), 32);
  EXPECT_EQ(compliance_slope_step(127), 64);
  EXPECT_EQ(compliance_slope_step(128), 128);
  EXPECT_EQ(compliance_slope_step(254), 128);
}

TEST(ServoControllerTest, SetPointMovesAtMovingSpeed) {
  ServoController sut(servo_controller_config("RX-28"));
  ServoCommand command = compliance_command(1.0);
  command.moving_speed_rad_s = 2.0;

  ControllerOutput out;
  for (int i = 0; i < 100; ++i) {
    out = sut.update(command, 0.0, 0.0, kDt);
  }

  EXPECT_NEAR(out.setpoint_rad, 0.2, 1e-9);
  EXPECT_TRUE(out.moving);
}

TEST(ServoControllerTest, MovingSpeedZeroJumpsToTheGoal) {
  ServoController sut(servo_controller_config("RX-28"));

  const ControllerOutput out = sut.update(compliance_command(1.0), 0.0, 0.0, kDt);

  EXPECT_DOUBLE_EQ(out.setpoint_rad, 1.0);
}

TEST(ServoControllerTest, MxProportionalGainAsTheManualAndTheOscilloscopeGiveIt) {
  ServoController sut(servo_controller_config("MX-28"));
  ServoCommand command;
  command.torque_enabled = true;
  command.goal_position_rad = 100.0 * kMxUnit;
  command.pid = mx_pid_gains(32, 0, 0);  // Kp = 32 / 8 = 4 output units per position unit

  const ControllerOutput out = sut.update(command, 0.0, 0.0, kDt);

  // Rhoban's measurement: 0.158 x 32 x 0.1534 rad = 77.6 % duty for 100 units at P 32.
  EXPECT_NEAR(out.pwm_ratio, kMxDutyPerRadAndP * 32.0 * (100.0 * kMxUnit), 1e-9);
  EXPECT_NEAR(out.pwm_ratio, 4.0 * 100.0 * kMxDutyPerOutputUnit, 1e-9);
}

TEST(ServoControllerTest, MxIntegralGainAccumulatesTheError) {
  ServoController sut(servo_controller_config("MX-64"));
  ServoCommand command;
  command.torque_enabled = true;
  command.goal_position_rad = 10.0 * kMxUnit;
  command.pid = mx_pid_gains(0, 2, 0);  // Ki = 2 * 1000 / 2048

  ControllerOutput out;
  for (int i = 0; i < 100; ++i) {
    out = sut.update(command, 0.0, 0.0, kDt);
  }

  EXPECT_NEAR(out.pwm_ratio, (2.0 * 1000.0 / 2048.0) * 10.0 * 0.1 * kMxDutyPerOutputUnit, 1e-9);
}

TEST(ServoControllerTest, MxDerivativeGainDampsTheSpeed) {
  ServoController sut(servo_controller_config("MX-106"));
  ServoCommand command;
  command.torque_enabled = true;
  command.pid = mx_pid_gains(0, 0, 250);  // Kd = 1.0 output unit per position unit / s

  const ControllerOutput out = sut.update(command, 0.0, 0.5, kDt);  // 0.5 rad/s: 63 % duty, below full

  EXPECT_NEAR(out.pwm_ratio, -0.5 / kMxUnit * kMxDutyPerOutputUnit, 1e-9);
}

TEST(ServoControllerTest, WheelModeDutyFollowsMovingSpeed) {
  ServoController sut(servo_controller_config("RX-64"));
  ServoCommand command;
  command.torque_enabled = true;
  command.wheel_mode = true;
  command.moving_speed_rad_s = -0.5 * 1023.0 * 0.111 * 2.0 * kPi / 60.0;  // 50 % CW

  const ControllerOutput out = sut.update(command, 0.0, 0.0, kDt);

  EXPECT_NEAR(out.pwm_ratio, -0.5, 1e-9);
}

TEST(ServoControllerTest, StalledAtFullDriveRaisesOverloadAfterOverloadTime) {
  ServoController sut(servo_controller_config("RX-64"));
  const ServoCommand command = compliance_command(1.0);

  bool before = false, after = false;
  for (int i = 0; i < 1500; ++i) {
    const bool overload = sut.update(command, 0.0, 0.0, kDt).overload;
    if (i == 900) before = overload;
    if (i == 1100) after = overload;
  }

  EXPECT_FALSE(before);
  EXPECT_TRUE(after);
}

TEST(ServoControllerTest, CurrentControlComputesTheDutyFromTheMotorLine) {
  ServoControllerConfig config = servo_controller_config("MX-64");
  config.back_emf_v_s_rad = 2.0;
  config.resistance_ohm = 3.0;
  config.torque_constant_nm_a = 1.5;
  ServoController sut(config);
  ServoCommand command;
  command.torque_enabled = true;
  command.torque_control = true;
  command.goal_current_a = 2.0;

  const ControllerOutput out = sut.update(command, 0.0, 1.0, kDt, 12.0);

  // V = R i + ke w = 3 * 2 + 2 * 1 = 8 V of 12 V.
  EXPECT_NEAR(out.pwm_ratio, 8.0 / 12.0, 1e-12);
}

TEST(ServoControllerTest, ConfigCarriesTheRegistrysMotor) {
  const ServoSpec& spec = servo_spec("MX-64(2.0)");

  const ServoControllerConfig sut = servo_controller_config("MX-64(2.0)");

  EXPECT_EQ(sut.back_emf_v_s_rad, spec.motor->back_emf_v_s_rad);
  EXPECT_EQ(sut.resistance_ohm, spec.motor->resistance_ohm);
  EXPECT_EQ(sut.torque_constant_nm_a, spec.motor->torque_constant_nm_a);
  EXPECT_GT(sut.resistance_ohm, 0.0);
  EXPECT_EQ(sut.pwm_full_scale, 885.0);                                   // X / MX(2.0): PWM 885 = 100 %
  EXPECT_NEAR(sut.velocity_unit_rad_s, 0.229 * 2.0 * kPi / 60.0, 1e-12);  // Goal Velocity unit
  EXPECT_NEAR(servo_controller_config("MX-64").pwm_full_scale, 1.0 / kMxDutyPerOutputUnit, 1e-9);  // 515.8
  EXPECT_EQ(servo_controller_config("RX-64").law, ControlLaw::kCompliance);
}

TEST(ServoControllerTest, CurrentLimitBoundsThePositionDrive) {
  // Current-based position: the PID wants full duty, the goal current (1 A) allows only
  // V = R i + ke w = 3 V at rest.
  ServoControllerConfig config = servo_controller_config("XM430-W350");
  config.back_emf_v_s_rad = 2.0;
  config.resistance_ohm = 3.0;
  ServoController sut(config);
  ServoCommand command;
  command.torque_enabled = true;
  command.goal_position_rad = 1.0;
  command.pid = x_pid_gains(800, 0, 0);
  command.current_limit_a = 1.0;

  EXPECT_NEAR(sut.update(command, 0.0, 0.0, kDt, 12.0).pwm_ratio, 3.0 / 12.0, 1e-12);
  EXPECT_NEAR(sut.update(command, 0.0, 0.5, kDt, 12.0).pwm_ratio, 4.0 / 12.0, 1e-12);  // + ke w
}

TEST(ServoControllerTest, PwmModeIsTheGoalDuty) {
  ServoController sut(servo_controller_config("XL430-W250"));
  ServoCommand command;
  command.torque_enabled = true;
  command.pwm_control = true;
  command.goal_pwm_ratio = -0.3;

  EXPECT_NEAR(sut.update(command, 0.0, 2.0, kDt, 12.0).pwm_ratio, -0.3, 1e-12);
}

TEST(ServoControllerTest, VelocityPiOfTheManual) {
  // e-Manual velocity controller: PWM = KvP e + KvI sum(e), e in Goal Velocity units (0.229 rpm).
  ServoController sut(servo_controller_config("XM430-W350"));
  ServoCommand command;
  command.torque_enabled = true;
  command.wheel_mode = true;
  command.velocity_control = true;
  command.velocity_pi = x_velocity_pi_gains(128, 0);  // KvP = 1 PWM unit per velocity unit
  const double unit_rad_s = 0.229 * 2.0 * kPi / 60.0;
  command.moving_speed_rad_s = 100 * unit_rad_s;

  EXPECT_NEAR(sut.update(command, 0.0, 20 * unit_rad_s, kDt, 12.0).pwm_ratio, 80.0 / 885.0, 1e-9);

  command.velocity_pi = x_velocity_pi_gains(0, 65536 / 16);  // KvI = 1/16 PWM unit per unit and 1 ms cycle
  ServoController integrating(servo_controller_config("XM430-W350"));
  double pwm = 0.0;
  for (int i = 0; i < 10; ++i) pwm = integrating.update(command, 0.0, 20 * unit_rad_s, kDt, 12.0).pwm_ratio;
  EXPECT_NEAR(pwm, 10 * 80.0 / 16.0 / 885.0, 1e-9);  // ten cycles of an 80-unit error
}

TEST(ServoControllerTest, UnknownModelIsRejected) {
  EXPECT_THROW(servo_controller_config("FUMANOID-IMU"), std::invalid_argument);
}

}  // namespace
}  // namespace doppel::dynamixel
