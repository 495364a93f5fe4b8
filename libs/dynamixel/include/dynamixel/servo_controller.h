#pragma once
// The motor controller inside a servo's firmware: from the control-table command (ServoCommand)
// and the measured angle and speed it computes the H-bridge duty (PWM, -1..1) that the motor gets;
// the physics turns that into a voltage (duty x supply) and a torque. AX/RX servos use compliance
// margin, slope and punch; MX and X servos a PID on the position error; X velocity mode a PI on
// the speed error; torque / current modes the duty that makes the motor current (V = ke w + R i)
// follow the goal current. The Overload condition is the controller's. A goal is approached at
// the Moving Speed (and MX Goal Acceleration) through a moving set-point, as the firmware's
// profile does. It is not the motor (physics/dc_motor.h) and not the control table (servo
// models in this folder). std only.

#include <cstdint>
#include <string_view>

#include "dynamixel/device_io.h"
#include "dynamixel/models.h"

namespace doppel::dynamixel {

struct ServoControllerConfig {
  ControlLaw law = ControlLaw::kCompliance;
  double units_per_rad = 1023.0 / (300.0 * 3.14159265358979323846 / 180.0);  // position register units per rad
  double wheel_full_speed_rad_s = 11.89;  // wheel-mode Moving Speed that means full duty (1023 units)
  double velocity_unit_rad_s = 0.111 * 3.14159265358979323846 / 30.0;  // speed register unit, rad/s (velocity-mode error unit)
  double pwm_full_scale = 1023.0;         // controller output that means full duty (MX 515.8, X 885)
  double overload_time_s = 1.0;           // saturated and stalled this long -> overload (assumption)
  // The motor (MotorSpec), output-shaft referred: current control computes the duty from
  // V = ke w + R i. 0 = unknown: then current control gives no drive.
  double back_emf_v_s_rad = 0.0;
  double resistance_ohm = 0.0;
  double torque_constant_nm_a = 0.0;
};

// The controller of a servo: its firmware's law and units and its motor's constants. rt-safe.
ServoControllerConfig servo_controller_config(const ServoSpec& servo) noexcept;
// The same for a servo model of the registry (model_registry.h). Throws std::invalid_argument for
// a name that is not a servo model. Setup only.
ServoControllerConfig servo_controller_config(std::string_view model);

// MX (Protocol 1.0 firmware): Kp = P / 8, Ki = I * 1000 / 2048, Kd = D * 4 / 1000 (e-Manual), in
// output units of which 515.8 are full duty (Rhoban's measurement, model_registry.cpp mx_servo).
PidGains mx_pid_gains(uint8_t p_raw, uint8_t i_raw, uint8_t d_raw) noexcept;
// X series and MX(2.0) position gains: Kp = P / 128, Ki = I / 65536, Kd = D / 16 (e-Manual).
PidGains x_pid_gains(uint16_t p_raw, uint16_t i_raw, uint16_t d_raw) noexcept;
// X series and MX(2.0) velocity gains (registers 78, 76): KvP = P / 128 PWM units per velocity
// unit, KvI = I / 65536 per velocity unit and firmware cycle (e-Manual: "the constant includes the
// sampling time"); Doppel assumes a 1 ms cycle, so ki = I / 65536 x 1000 per velocity unit x s.
PidGains x_velocity_pi_gains(uint16_t p_raw, uint16_t i_raw) noexcept;

// The compliance slope's representative value (e-Manual: 0-3 -> 2, 4-7 -> 4, ..., 128-254 -> 128).
int compliance_slope_step(uint8_t slope_raw) noexcept;

struct ControllerOutput {
  double pwm_ratio = 0.0;     // duty, -1..1, + = CCW
  double setpoint_rad = 0.0;  // where the profile is now
  bool moving = false;        // the set-point has not reached the goal, or the joint still moves
  bool overload = false;      // drive saturated for overload_time_s while the joint moved < 0.05 rad
};

class ServoController {
 public:
  explicit ServoController(const ServoControllerConfig& config) noexcept;

  // One firmware cycle of `dt_s` seconds. Angles as in device_io.h (0 = centre, + = CCW).
  // supply_v is needed for current control and current limits only. rt-safe.
  ControllerOutput update(const ServoCommand& command, double position_rad, double velocity_rad_s, double dt_s,
                          double supply_v = 0.0) noexcept;

  // Forgets the profile and the integrator; the set-point starts at `position_rad`. rt-safe.
  void reset(double position_rad) noexcept;

 private:
  ServoControllerConfig config_;
  double setpoint_rad_ = 0.0;
  double setpoint_velocity_rad_s_ = 0.0;
  double integral_units_s_ = 0.0;
  double velocity_integral_units_ = 0.0;  // velocity-mode integral, velocity units x s
  double saturated_s_ = 0.0;
  double stall_position_rad_ = 0.0;
  bool active_ = false;
};

}  // namespace doppel::dynamixel
