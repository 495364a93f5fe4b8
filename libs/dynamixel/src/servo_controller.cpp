#include "dynamixel/servo_controller.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "dynamixel/model_registry.h"

namespace doppel::dynamixel {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kRpm = 2.0 * kPi / 60.0;
constexpr double kStallTravel_rad = 0.05;       // a saturated joint that moves less than this is stalled
constexpr double kMovingSpeed_rad_s = 0.02;     // Moving stays 1 while the joint turns faster
constexpr double kFirmwareCyclesPerS = 1000.0;  // X velocity loop rate (assumption: 1 ms, as the MX I gain's 1000)

double sign(double x) { return x > 0.0 ? 1.0 : (x < 0.0 ? -1.0 : 0.0); }

// Adds error x dt to an integrator, capped so that the I term alone stays within full duty
// (anti-windup), and cleared while there is no I gain.
void integrate_capped(double& integral, double error, double dt_s, double ki, double full_scale) noexcept {
  integral += error * dt_s;
  integral = ki > 0.0 ? std::clamp(integral, -full_scale / ki, full_scale / ki) : 0.0;
}

}  // namespace

ServoControllerConfig servo_controller_config(const ServoSpec& servo) noexcept {
  ServoControllerConfig c;
  c.law = servo.law;
  c.units_per_rad = servo.units_per_rad();
  c.velocity_unit_rad_s = servo.speed_unit_rpm * kRpm;
  c.wheel_full_speed_rad_s = 1023.0 * c.velocity_unit_rad_s;
  c.pwm_full_scale = servo.pwm_full_scale;
  if (servo.motor != nullptr) {
    c.back_emf_v_s_rad = servo.motor->back_emf_v_s_rad;
    c.resistance_ohm = servo.motor->resistance_ohm;
    c.torque_constant_nm_a = servo.motor->torque_constant_nm_a;
  }
  return c;
}

ServoControllerConfig servo_controller_config(std::string_view model) {
  return servo_controller_config(servo_spec(model));
}

PidGains mx_pid_gains(uint8_t p_raw, uint8_t i_raw, uint8_t d_raw) noexcept {
  return PidGains{p_raw / 8.0, i_raw * 1000.0 / 2048.0, d_raw * 4.0 / 1000.0};
}

PidGains x_pid_gains(uint16_t p_raw, uint16_t i_raw, uint16_t d_raw) noexcept {
  return PidGains{p_raw / 128.0, i_raw / 65536.0, d_raw / 16.0};
}

PidGains x_velocity_pi_gains(uint16_t p_raw, uint16_t i_raw) noexcept {
  return PidGains{p_raw / 128.0, i_raw / 65536.0 * kFirmwareCyclesPerS, 0.0};
}

int compliance_slope_step(uint8_t slope_raw) noexcept {
  int step = 2;
  while (step < 128 && slope_raw >= 2 * step) {
    step *= 2;
  }
  return step;
}

ServoController::ServoController(const ServoControllerConfig& config) noexcept : config_(config) {}

void ServoController::reset(double position_rad) noexcept {
  setpoint_rad_ = position_rad;
  setpoint_velocity_rad_s_ = 0.0;
  integral_units_s_ = 0.0;
  velocity_integral_units_ = 0.0;
  saturated_s_ = 0.0;
}

ControllerOutput ServoController::update(const ServoCommand& command, double position_rad, double velocity_rad_s,
                                         double dt_s, double supply_v) noexcept {
  const PidGains& gains = command.pid;
  ControllerOutput out;
  if (!command.torque_enabled) {
    // H-bridge off; the profile restarts from wherever the joint is when torque returns.
    active_ = false;
    reset(position_rad);
    out.setpoint_rad = position_rad;
    out.moving = std::abs(velocity_rad_s) > kMovingSpeed_rad_s;
    return out;
  }
  if (!active_) {
    active_ = true;
    reset(position_rad);
  }

  const ServoControllerConfig& c = config_;
  const bool motor_known = c.back_emf_v_s_rad > 0.0 && c.resistance_ohm > 0.0 && supply_v > 0.0;
  double pwm = 0.0;
  if (command.torque_control) {
    // Current control: the duty whose voltage V = ke w + R i drives the goal current at the present speed.
    if (motor_known) {
      pwm = (command.goal_current_a * c.resistance_ohm + c.back_emf_v_s_rad * velocity_rad_s) / supply_v;
    }
    setpoint_rad_ = position_rad;
  } else if (command.pwm_control) {
    pwm = command.goal_pwm_ratio;
    setpoint_rad_ = position_rad;
  } else if (command.wheel_mode && command.velocity_control) {
    // Velocity PI on the speed error in Goal Velocity units; the integral is capped at full duty.
    const double error_units = (command.moving_speed_rad_s - velocity_rad_s) / c.velocity_unit_rad_s;
    const PidGains& pi = command.velocity_pi;
    integrate_capped(velocity_integral_units_, error_units, dt_s, pi.ki, c.pwm_full_scale);
    pwm = (pi.kp * error_units + pi.ki * velocity_integral_units_) / c.pwm_full_scale;
    setpoint_rad_ = position_rad;
  } else if (command.wheel_mode) {
    pwm = command.moving_speed_rad_s / config_.wheel_full_speed_rad_s;
    setpoint_rad_ = position_rad;
  } else {
    // Profile: the set-point runs toward the goal at Moving Speed (0 = no limit), and with a Goal
    // Acceleration it speeds up and slows down at that rate.
    const double goal = command.goal_position_rad;
    const double to_go = goal - setpoint_rad_;
    const double max_speed = command.moving_speed_rad_s > 0.0 ? command.moving_speed_rad_s : std::numeric_limits<double>::infinity();
    const double accel = command.goal_acceleration_rad_s2;
    if (accel > 0.0) {
      const double wanted = sign(to_go) * std::min(max_speed, std::sqrt(2.0 * accel * std::abs(to_go)));
      const double dv = std::clamp(wanted - setpoint_velocity_rad_s_, -accel * dt_s, accel * dt_s);
      setpoint_velocity_rad_s_ += dv;
    } else {
      setpoint_velocity_rad_s_ = sign(to_go) * max_speed;
    }
    if (!std::isfinite(setpoint_velocity_rad_s_)) {
      setpoint_rad_ = goal;  // no speed limit: the set-point jumps
      setpoint_velocity_rad_s_ = 0.0;
    } else {
      const double travel = setpoint_velocity_rad_s_ * dt_s;
      if (sign(travel) == sign(to_go) && std::abs(travel) >= std::abs(to_go)) {
        setpoint_rad_ = goal;
        setpoint_velocity_rad_s_ = 0.0;
      } else {
        setpoint_rad_ += travel;
      }
    }

    const double error_units = (setpoint_rad_ - position_rad) * config_.units_per_rad;
    if (config_.law == ControlLaw::kCompliance) {
      const bool ccw = error_units > 0.0;
      const double margin = ccw ? command.ccw_compliance_margin_raw : command.cw_compliance_margin_raw;
      const double slope = compliance_slope_step(ccw ? command.ccw_compliance_slope_raw : command.cw_compliance_slope_raw);
      const double beyond = std::abs(error_units) - margin;
      if (beyond > 0.0) {
        const double punch = std::clamp(command.punch_raw / 1023.0, 0.0, 1.0);
        pwm = sign(error_units) * std::min(1.0, punch + (1.0 - punch) * beyond / slope);
      }
    } else {
      const double error_rate_units_s = (setpoint_velocity_rad_s_ - velocity_rad_s) * config_.units_per_rad;
      integrate_capped(integral_units_s_, error_units, dt_s, gains.ki, config_.pwm_full_scale);
      const double u = gains.kp * error_units + gains.ki * integral_units_s_ + gains.kd * error_rate_units_s;
      pwm = u / config_.pwm_full_scale;
    }
    out.moving = std::abs(goal - setpoint_rad_) > 0.0 || std::abs(velocity_rad_s) > kMovingSpeed_rad_s;
  }
  if (command.current_limit_a > 0.0 && motor_known) {
    // Current limit: the duty window that keeps |i| = |V - ke w| / R within the limit.
    const double back_emf_v = c.back_emf_v_s_rad * velocity_rad_s;
    const double headroom_v = command.current_limit_a * c.resistance_ohm;
    pwm = std::clamp(pwm, (back_emf_v - headroom_v) / supply_v, (back_emf_v + headroom_v) / supply_v);
  }
  pwm = std::clamp(pwm, -1.0, 1.0);

  // Overload: the drive stays at the Torque Limit and the joint makes no headway (judged by its
  // position, which a jittering contact cannot fool the way a speed sample can).
  const double limit = std::clamp(command.torque_limit_ratio, 0.0, 1.0);
  const bool saturated = std::abs(pwm) >= limit - 1e-9 && std::abs(pwm) > 0.0;
  if (!saturated || std::abs(position_rad - stall_position_rad_) > kStallTravel_rad) {
    saturated_s_ = 0.0;
    stall_position_rad_ = position_rad;
  } else {
    saturated_s_ += dt_s;
  }
  out.overload = saturated_s_ >= config_.overload_time_s;

  out.pwm_ratio = pwm;
  out.setpoint_rad = setpoint_rad_;
  return out;
}

}  // namespace doppel::dynamixel
