#include "dynamixel/protocol2_servo.h"
#include "dynamixel/servo_controller.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "servo_feedback.h"

namespace doppel::dynamixel {

namespace {

using detail::clamp_round;
using detail::floor_div;

constexpr double kTwoPi = 2.0 * std::numbers::pi;
constexpr double kUnitsPerRad = kX430PulsesPerRev / kTwoPi;
constexpr double kVelocityUnitRadS = kX430VelocityUnitRpm * kTwoPi / 60.0;
constexpr double kAccelerationUnitRadS2 = kX430AccelerationUnitRpm2 * kTwoPi / 3600.0;
constexpr int64_t kExtendedLimit = 1048575;  // Goal Position in modes 4 and 5, pulses
constexpr uint8_t kDriveReverse = x430::kDriveReverse;
constexpr uint8_t kDriveTimeBased = x430::kDriveTimeBased;
constexpr uint8_t kDriveTorqueOnByGoal = x430::kDriveTorqueOnByGoal;
constexpr uint8_t kStartupTorqueOn = 0x01;

bool is_position_mode(uint8_t mode) noexcept {
  return mode == x430::kPositionMode || mode == x430::kExtendedPositionMode || mode == x430::kCurrentBasedPositionMode;
}

}  // namespace

Protocol2Servo::Protocol2Servo(const P2ModelSpec& spec, uint8_t id, uint8_t baud_raw, uint8_t return_delay_raw,
                               double initial_position_rad)
    : Protocol2Device(spec, id, baud_raw, return_delay_raw) {
  if (spec.kind != P2DeviceKind::kServo) {
    throw std::invalid_argument(std::string(spec.name) + " is not a servo model");
  }
  if (!std::isfinite(initial_position_rad)) {
    throw std::invalid_argument(std::string(spec.name) + ": initial position must be finite");
  }
  last_position_rad_ = initial_position_rad;
  power_on();
}

bool Protocol2Servo::position_mode() const noexcept { return is_position_mode(operating_mode()); }

int64_t Protocol2Servo::present_raw_from_rad(double position_rad) const noexcept {
  const int64_t counts = clamp_round(position_rad * kUnitsPerRad, -(int64_t{1} << 40), int64_t{1} << 40);
  return direction() * counts + turn_offset_raw_ + register_value(x430::kHomingOffset);
}

double Protocol2Servo::rad_from_present_raw(int64_t present_raw) const noexcept {
  const int64_t counts = present_raw - register_value(x430::kHomingOffset) - turn_offset_raw_;
  return static_cast<double>(direction() * counts) / kUnitsPerRad;
}

void Protocol2Servo::fold_position() noexcept {
  const int64_t counts = clamp_round(last_position_rad_ * kUnitsPerRad, -(int64_t{1} << 40), int64_t{1} << 40);
  const int64_t actual = direction() * counts + turn_offset_raw_;
  turn_offset_raw_ -= floor_div(actual, 4096) * 4096;
}

void Protocol2Servo::power_on() noexcept {
  turn_offset_raw_ = 2048;
  fold_position();
  ServoFeedback at_rest;
  at_rest.position_rad = last_position_rad_;
  at_rest.voltage_v = spec().servo.motor->rated_voltage_v;
  at_rest.sim_time_ns = now_ns_;
  apply(at_rest);
  set_register(x430::kGoalPosition, register_value(x430::kPresentPosition));
  set_register(x430::kPositionTrajectory, register_value(x430::kPresentPosition));
  goal_from_feedback_ = true;
  last_communication_ns_ = now_ns_;
  if ((register_value(x430::kStartupConfiguration) & kStartupTorqueOn) != 0) {
    set_register(x430::kTorqueEnable, 1);
  }
}

void Protocol2Servo::reboot() noexcept {
  Protocol2Device::reboot();  // RAM defaults: torque off, Hardware Error Status cleared
  power_on();
}

uint8_t Protocol2Servo::clear_multi_turn() noexcept {
  if (register_value(x430::kMoving) != 0) {
    return p2_error::kResultFail;
  }
  fold_position();
  return 0;
}

uint8_t Protocol2Servo::check_write(const Table& candidate, const ItemSet& touched) const noexcept {
  const auto mode = static_cast<uint8_t>(value_in(candidate, x430::kOperatingMode));
  if (touches(touched, x430::kOperatingMode) && (mode > 31 || ((spec().operating_modes >> mode) & 1u) == 0)) {
    return p2_error::kDataRange;
  }
  if (touches(touched, x430::kDriveMode) && (value_in(candidate, x430::kDriveMode) & ~spec().drive_mode_bits) != 0) {
    return p2_error::kDataRange;
  }
  const bool goal_written = touches(touched, x430::kGoalPosition) || touches(touched, x430::kGoalVelocity) ||
                            touches(touched, x430::kGoalPwm) || touches(touched, x430::kGoalCurrent);
  if (goal_written && watchdog_tripped()) {
    return p2_error::kDataRange;  // Goal items are read-only after a Bus Watchdog error
  }
  if (touches(touched, x430::kGoalPosition) && mode == x430::kPositionMode) {
    const int64_t goal = value_in(candidate, x430::kGoalPosition);
    if (goal < value_in(candidate, x430::kMinPositionLimit) || goal > value_in(candidate, x430::kMaxPositionLimit)) {
      return p2_error::kDataLimit;
    }
  }
  if (touches(touched, x430::kGoalVelocity) &&
      std::abs(value_in(candidate, x430::kGoalVelocity)) > value_in(candidate, x430::kVelocityLimit)) {
    return p2_error::kDataLimit;
  }
  if (spec().has_current && touches(touched, x430::kGoalCurrent) &&
      std::abs(value_in(candidate, x430::kGoalCurrent)) > value_in(candidate, x430::kCurrentLimit)) {
    return p2_error::kDataLimit;
  }
  if (touches(touched, x430::kGoalPwm) &&
      std::abs(value_in(candidate, x430::kGoalPwm)) > value_in(candidate, x430::kPwmLimit)) {
    return p2_error::kDataLimit;
  }
  return 0;
}

void Protocol2Servo::after_write(const Table& before, const ItemSet& touched) noexcept {
  const uint8_t mode = operating_mode();
  if (touches(touched, x430::kOperatingMode) && before[x430::kOperatingMode] != mode) {
    // S4: a mode change resets the profile and the goal limits of the new mode.
    set_register(x430::kProfileVelocity, 0);
    set_register(x430::kProfileAcceleration, 0);
    set_register(x430::kGoalPwm, register_value(x430::kPwmLimit));
    if (spec().has_current) {
      set_register(x430::kGoalCurrent, register_value(x430::kCurrentLimit));
    }
    if (mode == x430::kPositionMode) {
      fold_position();
    }
  }
  if (touches(touched, x430::kDriveMode) && ((before[x430::kDriveMode] ^ raw_table()[x430::kDriveMode]) & kDriveReverse)) {
    fold_position();
  }
  const bool goal_written = touches(touched, x430::kGoalPosition) || touches(touched, x430::kGoalVelocity) ||
                            touches(touched, x430::kGoalPwm) || touches(touched, x430::kGoalCurrent);
  if (goal_written) {
    goal_from_feedback_ = false;
  }
  if (goal_written && (raw_table()[x430::kDriveMode] & kDriveTorqueOnByGoal) != 0 && hardware_error() == 0) {
    set_register(x430::kTorqueEnable, 1);
  }
  if (touches(touched, x430::kTorqueEnable) || goal_written) {
    if (torque_enabled() && before[x430::kTorqueEnable] == 0) {
      if (hardware_error() != 0) {
        set_register(x430::kTorqueEnable, 0);  // only REBOOT re-enables the torque after a shutdown
      } else {
        last_communication_ns_ = now_ns_;
        if (mode == x430::kPositionMode) {
          fold_position();  // Present Position is re-based to one turn in position mode
        }
      }
    }
  }
  if (touches(touched, x430::kBusWatchdog)) {
    last_communication_ns_ = now_ns_;
  }
  // Homing Offset, Drive Mode and re-basing change Present Position at once, not at the next sample.
  set_register(x430::kPresentPosition, std::clamp<int64_t>(present_raw_from_rad(last_position_rad_), INT32_MIN, INT32_MAX));
  if (touches(touched, x430::kGoalPosition) && (raw_table()[x430::kDriveMode] & kDriveTimeBased) != 0) {
    const int64_t period_ms = register_value(x430::kProfileVelocity);
    const double distance_rad = std::abs(rad_from_present_raw(register_value(x430::kGoalPosition)) - last_position_rad_);
    time_based_speed_rad_s_ = period_ms > 0 ? distance_rad / (static_cast<double>(period_ms) / 1000.0) : 0.0;
  }
}

ServoCommand Protocol2Servo::command() const noexcept {
  const ServoSpec& s = spec().servo;
  const uint8_t mode = operating_mode();
  const double dir = direction();
  ServoCommand c;
  c.torque_enabled = torque_enabled() && hardware_error() == 0;
  c.wheel_mode = mode == x430::kVelocityMode;
  c.multi_turn = mode == x430::kExtendedPositionMode || mode == x430::kCurrentBasedPositionMode;

  if (mode == x430::kPositionMode) {
    c.min_position_rad = rad_from_present_raw(register_value(x430::kMinPositionLimit));
    c.max_position_rad = rad_from_present_raw(register_value(x430::kMaxPositionLimit));
  } else {
    c.min_position_rad = rad_from_present_raw(-kExtendedLimit);
    c.max_position_rad = rad_from_present_raw(kExtendedLimit);
  }
  if (c.min_position_rad > c.max_position_rad) {
    std::swap(c.min_position_rad, c.max_position_rad);
  }
  c.goal_position_rad =
      std::clamp(rad_from_present_raw(register_value(x430::kGoalPosition)), c.min_position_rad, c.max_position_rad);

  const double velocity_limit_rad_s = static_cast<double>(register_value(x430::kVelocityLimit)) * kVelocityUnitRadS;
  if (mode == x430::kVelocityMode) {
    c.moving_speed_rad_s = std::clamp(dir * static_cast<double>(register_value(x430::kGoalVelocity)) * kVelocityUnitRadS,
                                      -velocity_limit_rad_s, velocity_limit_rad_s);
  } else if ((raw_table()[x430::kDriveMode] & kDriveTimeBased) != 0 && register_value(x430::kProfileVelocity) != 0) {
    c.moving_speed_rad_s = std::min(time_based_speed_rad_s_, velocity_limit_rad_s);
  } else {
    const int64_t profile = register_value(x430::kProfileVelocity);
    const double profile_rad_s = static_cast<double>(profile) * kVelocityUnitRadS;
    c.moving_speed_rad_s = profile == 0 ? velocity_limit_rad_s : std::min(profile_rad_s, velocity_limit_rad_s);
  }
  if ((raw_table()[x430::kDriveMode] & kDriveTimeBased) == 0) {
    c.goal_acceleration_rad_s2 = static_cast<double>(register_value(x430::kProfileAcceleration)) * kAccelerationUnitRadS2;
  }

  c.torque_limit_ratio = std::clamp(static_cast<double>(register_value(x430::kPwmLimit)) / kX430PwmFull, 0.0, 1.0);
  if (spec().has_current) {
    const double stall_current_a = s.motor->stall_current_a;
    const double current_limit_a = static_cast<double>(register_value(x430::kCurrentLimit)) * spec().current_unit_a;
    c.torque_limit_ratio = std::min(c.torque_limit_ratio, current_limit_a / stall_current_a);
    const double goal_current_a = static_cast<double>(register_value(x430::kGoalCurrent)) * spec().current_unit_a;
    if (mode == x430::kCurrentBasedPositionMode) {
      c.torque_limit_ratio = std::min(c.torque_limit_ratio, std::abs(goal_current_a) / stall_current_a);
      c.current_limit_a = std::abs(goal_current_a);
    } else if (mode == x430::kCurrentMode) {
      c.torque_control = true;
      c.goal_current_a = dir * goal_current_a;
    }
  }
  if (mode == x430::kPwmMode) {
    c.pwm_control = true;
    c.goal_pwm_ratio = std::clamp(dir * static_cast<double>(register_value(x430::kGoalPwm)) / kX430PwmFull, -1.0, 1.0);
  }
  if (mode == x430::kVelocityMode) {
    c.velocity_control = true;
    c.velocity_pi = x_velocity_pi_gains(static_cast<uint16_t>(register_value(x430::kVelocityPGain)),
                                        static_cast<uint16_t>(register_value(x430::kVelocityIGain)));
  }
  c.torque_limit_ratio = std::clamp(c.torque_limit_ratio, 0.0, 1.0);
  c.pid = x_pid_gains(static_cast<uint16_t>(register_value(x430::kPositionPGain)),
                      static_cast<uint16_t>(register_value(x430::kPositionIGain)),
                      static_cast<uint16_t>(register_value(x430::kPositionDGain)));

  if (watchdog_tripped()) {
    // Bus Watchdog error: the servo stops where it was, profiles as 0.
    c.goal_position_rad = std::clamp(watchdog_hold_rad_, c.min_position_rad, c.max_position_rad);
    c.goal_acceleration_rad_s2 = 0.0;
    if (c.wheel_mode) {
      c.moving_speed_rad_s = 0.0;
    }
    c.goal_current_a = 0.0;
    c.goal_pwm_ratio = 0.0;
  }
  return c;
}

void Protocol2Servo::apply(const ServoFeedback& feedback) noexcept {
  now_ns_ = feedback.sim_time_ns;
  if (std::isfinite(feedback.position_rad)) {
    last_position_rad_ = feedback.position_rad;
  }
  const double dir = direction();
  const int64_t present = std::clamp<int64_t>(present_raw_from_rad(last_position_rad_), INT32_MIN, INT32_MAX);
  set_register(x430::kPresentPosition, present);
  if (goal_from_feedback_ && std::isfinite(feedback.position_rad)) {
    set_register(x430::kGoalPosition, present);
    set_register(x430::kPositionTrajectory, present);
    goal_from_feedback_ = false;
  }
  const double velocity = std::isfinite(feedback.velocity_rad_s) ? feedback.velocity_rad_s : 0.0;
  const int64_t velocity_raw = clamp_round(dir * velocity / kVelocityUnitRadS, INT32_MIN, INT32_MAX);
  set_register(x430::kPresentVelocity, velocity_raw);
  const double ratio = std::isfinite(feedback.torque_ratio) ? std::clamp(feedback.torque_ratio, -1.0, 1.0) : 0.0;
  if (spec().has_current) {
    const double current_a = std::isfinite(feedback.current_a) ? feedback.current_a : 0.0;
    set_register(x430::kPresentCurrent, clamp_round(dir * current_a / spec().current_unit_a, -32768, 32767));
  } else {
    set_register(x430::kPresentLoad, clamp_round(dir * ratio * 1000.0, -1000, 1000));
  }
  set_register(x430::kPresentPwm, clamp_round(dir * ratio * kX430PwmFull, -885, 885));
  const int64_t voltage_raw = clamp_round(feedback.voltage_v / kX430VoltageUnitV, 0, 0xFFFF);
  const int64_t temperature_raw = clamp_round(feedback.temperature_c, 0, 255);
  set_register(x430::kPresentInputVoltage, voltage_raw);
  set_register(x430::kPresentTemperature, temperature_raw);
  const int64_t ms = feedback.sim_time_ns / 1'000'000;
  set_register(x430::kRealtimeTick, ((ms % 32768) + 32768) % 32768);

  // Moving and Moving Status (reference §3.7).
  const bool torque_on = torque_enabled();
  const uint8_t mode = operating_mode();
  const int64_t goal = register_value(x430::kGoalPosition);
  const bool moving = std::abs(velocity_raw) > register_value(x430::kMovingThreshold);
  set_register(x430::kMoving, moving ? 1 : 0);
  const int64_t profile_velocity = register_value(x430::kProfileVelocity);
  const int64_t profile_acceleration = register_value(x430::kProfileAcceleration);
  uint8_t status = 0;
  if (profile_velocity != 0 && profile_acceleration == 0) {
    status |= x430::kProfileRectangular;
  } else if (profile_velocity != 0) {
    // Trapezoidal when the move is long enough to reach Profile Velocity (v^2 / a in pulses).
    const double v_pulse_s = static_cast<double>(profile_velocity) * kVelocityUnitRadS * kUnitsPerRad;
    const double a_pulse_s2 = static_cast<double>(profile_acceleration) * kAccelerationUnitRadS2 * kUnitsPerRad;
    const double distance = std::abs(static_cast<double>(goal - present));
    status |= distance >= v_pulse_s * v_pulse_s / a_pulse_s2 ? x430::kProfileTrapezoidal : x430::kProfileTriangular;
  }
  bool in_position = false;
  if (is_position_mode(mode)) {
    in_position = std::abs(goal - present) <= kInPositionWindowRaw;
    if (in_position) {
      status |= x430::kInPosition;
    }
  }
  const bool profile_ongoing =
      torque_on && (is_position_mode(mode) ? !in_position
                                           : mode == x430::kVelocityMode &&
                                                 std::abs(velocity_raw - register_value(x430::kGoalVelocity)) >
                                                     register_value(x430::kMovingThreshold));
  if (profile_ongoing) {
    status |= x430::kProfileOngoing;
  }
  set_register(x430::kMovingStatus, status);
  set_register(x430::kPositionTrajectory, is_position_mode(mode) && torque_on ? goal : present);
  int64_t trajectory_velocity = 0;
  if (profile_ongoing && is_position_mode(mode)) {
    const int64_t limit = register_value(x430::kVelocityLimit);
    const int64_t speed = profile_velocity == 0 ? limit : std::min(profile_velocity, limit);
    trajectory_velocity = goal > present ? speed : -speed;
  } else if (profile_ongoing) {
    trajectory_velocity = register_value(x430::kGoalVelocity);
  }
  set_register(x430::kVelocityTrajectory, trajectory_velocity);

  // Hardware errors: the bits enabled in Shutdown latch, switch the torque off and set Alert.
  const detail::ServoConditions found =
      detail::servo_conditions(temperature_raw, register_value(x430::kTemperatureLimit), voltage_raw,
                               register_value(x430::kMinVoltageLimit), register_value(x430::kMaxVoltageLimit),
                               torque_on, feedback.overload);
  const auto conditions = static_cast<uint8_t>((found.overheating ? x430::kOverheatingError : 0) |
                                               (found.input_voltage ? x430::kInputVoltageError : 0) |
                                               (found.overload ? x430::kOverloadError : 0));
  const auto latched = static_cast<uint8_t>(hardware_error() | (conditions & register_value(x430::kShutdown)));
  set_register(x430::kHardwareErrorStatus, latched);
  if (latched != 0) {
    set_register(x430::kTorqueEnable, 0);
  }

  // Bus Watchdog: armed with torque on; no packet for Bus Watchdog x 20 ms stops the servo.
  const int64_t watchdog = register_value(x430::kBusWatchdog);
  if (torque_enabled() && watchdog >= 1 && watchdog <= 127 &&
      now_ns_ - last_communication_ns_ > watchdog * kX430WatchdogUnitNs) {
    set_register(x430::kBusWatchdog, kWatchdogTripped);
    watchdog_hold_rad_ = last_position_rad_;
  }
}

}  // namespace doppel::dynamixel
