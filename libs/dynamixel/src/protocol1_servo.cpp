#include "dynamixel/protocol1_servo.h"
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
constexpr uint16_t kDirectionBit = 0x400;  // Present Speed/Load, wheel Moving Speed, Goal Torque: 1 = CW
constexpr uint16_t kMagnitudeMask = 0x3FF;
constexpr int32_t kMultiTurnLimit = 28672;  // MX multi-turn Goal/Present Position range, +-7 turns
constexpr double kMxCurrentUnitA = 0.0045;  // MX-64/106 Current and Goal Torque: 4.5 mA per unit
constexpr int32_t kMxCurrentZero = 2048;
constexpr double kMxAccelerationUnitRadS2 = 8.583 * std::numbers::pi / 180.0;
constexpr double kLoadFull = 1023.0;        // Present Load / Torque Limit full scale (~0.1 % per unit)

// Magnitude in bits 0..9, bit 10 set for CW (negative) values (reference §3.4).
uint16_t direction_magnitude(double magnitude_units, bool cw) noexcept {
  const auto mag = static_cast<uint16_t>(clamp_round(magnitude_units, 0, kMagnitudeMask));
  return static_cast<uint16_t>(mag | (cw && mag != 0 ? kDirectionBit : 0));
}

double signed_from_direction(uint16_t raw) noexcept {
  const double mag = raw & kMagnitudeMask;
  return (raw & kDirectionBit) != 0 ? -mag : mag;
}

}  // namespace

Protocol1Servo::Protocol1Servo(const ModelSpec& spec, uint8_t id, uint8_t baud_raw, uint8_t return_delay_raw,
                               double initial_position_rad)
    : Protocol1Device(spec, id, baud_raw, return_delay_raw) {
  if (spec.kind != DeviceKind::kServo || spec.servo.family == ServoFamily::kNone) {
    throw std::invalid_argument(std::string(spec.name) + " is not a servo model");
  }
  if (!std::isfinite(initial_position_rad)) {
    throw std::invalid_argument(std::string(spec.name) + ": initial position must be finite");
  }
  power_on(initial_position_rad);
}

bool Protocol1Servo::has_register(uint8_t address) const noexcept {
  const RegisterSpec* r = find_register(spec().registers, address);
  return r != nullptr && r->address == address;
}

ServoMode Protocol1Servo::mode_for(uint16_t cw_limit_raw, uint16_t ccw_limit_raw) const noexcept {
  if (cw_limit_raw == 0 && ccw_limit_raw == 0) {
    return ServoMode::kWheel;
  }
  if (is_mx() && cw_limit_raw == 4095 && ccw_limit_raw == 4095) {
    return ServoMode::kMultiTurn;
  }
  return ServoMode::kJoint;
}

ServoMode Protocol1Servo::mode() const noexcept {
  return mode_for(register_raw(p1::kCwAngleLimit), register_raw(p1::kCcwAngleLimit));
}

double Protocol1Servo::position_rad_from_raw(int32_t raw) const noexcept {
  const ServoSpec& s = spec().servo;
  return (raw - static_cast<int32_t>(s.position_center_raw)) / s.units_per_rad();
}

int32_t Protocol1Servo::position_raw_from_rad(double position_rad) const noexcept {
  const ServoSpec& s = spec().servo;
  return static_cast<int32_t>(
      clamp_round(s.position_center_raw + position_rad * s.units_per_rad(), -(int64_t{1} << 30), int64_t{1} << 30));
}

double Protocol1Servo::speed_rad_s_from_raw(uint16_t magnitude_raw) const noexcept {
  return (magnitude_raw & kMagnitudeMask) * spec().servo.speed_unit_rpm * kTwoPi / 60.0;
}

void Protocol1Servo::power_on(double position_rad) noexcept {
  load_defaults(true);
  conditions_ = 0;
  ServoFeedback at_rest;
  at_rest.position_rad = std::isfinite(position_rad) ? position_rad : 0.0;
  at_rest.voltage_v = spec().servo.motor->rated_voltage_v;
  apply(at_rest);
  conditions_ = 0;
  set_register(p1::kGoalPosition, register_raw(p1::kPresentPosition));
  set_register(p1::kTorqueLimit, register_raw(p1::kMaxTorque));
}

void Protocol1Servo::after_factory_reset() noexcept { power_on(last_position_rad_); }

void Protocol1Servo::after_write(uint8_t start, std::size_t n) noexcept {
  if (touches(start, n, p1::kGoalPosition, 2) && !touches(start, n, p1::kTorqueEnable, 1)) {
    set_register(p1::kTorqueEnable, 1);
  }
}

uint8_t Protocol1Servo::check_write(const Table& candidate, uint8_t start, std::size_t n) const noexcept {
  const ServoMode m =
      mode_for(read_le(candidate, p1::kCwAngleLimit, 2), read_le(candidate, p1::kCcwAngleLimit, 2));
  if (touches(start, n, p1::kGoalPosition, 2)) {
    const uint16_t raw = read_le(candidate, p1::kGoalPosition, 2);
    const int32_t goal = is_mx() ? static_cast<int16_t>(raw) : raw;
    if (m != ServoMode::kMultiTurn && (goal < 0 || goal > spec().servo.position_max_raw)) {
      return p1_error::kRange;
    }
    if (m == ServoMode::kJoint) {
      const uint16_t cw = read_le(candidate, p1::kCwAngleLimit, 2);
      const uint16_t ccw = read_le(candidate, p1::kCcwAngleLimit, 2);
      if (goal < cw || goal > ccw) {
        return p1_error::kAngleLimit;
      }
    }
  }
  if (touches(start, n, p1::kMovingSpeed, 2) && m != ServoMode::kWheel &&
      read_le(candidate, p1::kMovingSpeed, 2) > kMagnitudeMask) {
    return p1_error::kRange;  // 1024..2047 (direction bit) only exist in wheel mode
  }
  return 0;
}

ServoCommand Protocol1Servo::command() const noexcept {
  const ServoSpec& s = spec().servo;
  const double u = s.units_per_rad();
  const ServoMode m = mode();
  ServoCommand c;
  c.torque_enabled = register_raw(p1::kTorqueEnable) != 0 && (conditions_ & register_raw(p1::kAlarmShutdown)) == 0;
  c.wheel_mode = m == ServoMode::kWheel;
  c.multi_turn = m == ServoMode::kMultiTurn;

  const uint16_t goal_raw = register_raw(p1::kGoalPosition);
  if (m == ServoMode::kMultiTurn) {
    const int32_t divider = std::max<int32_t>(1, register_raw(p1::kResolutionDivider));
    const int32_t offset = static_cast<int16_t>(register_raw(p1::kMultiTurnOffset));
    const auto to_rad = [&](int32_t raw) { return ((raw - offset) * divider - s.position_center_raw) / u; };
    c.min_position_rad = to_rad(-kMultiTurnLimit);
    c.max_position_rad = to_rad(kMultiTurnLimit);
    c.goal_position_rad = to_rad(static_cast<int16_t>(goal_raw));
  } else {
    if (m == ServoMode::kWheel) {
      c.min_position_rad = position_rad_from_raw(0);
      c.max_position_rad = position_rad_from_raw(s.position_max_raw);
    } else {
      c.min_position_rad = position_rad_from_raw(register_raw(p1::kCwAngleLimit));
      c.max_position_rad = position_rad_from_raw(register_raw(p1::kCcwAngleLimit));
    }
    const int32_t goal = is_mx() ? static_cast<int16_t>(goal_raw) : goal_raw;
    c.goal_position_rad =
        std::min(std::max(position_rad_from_raw(goal), c.min_position_rad), std::max(c.min_position_rad, c.max_position_rad));
  }

  const uint16_t speed_raw = register_raw(p1::kMovingSpeed);
  if (m == ServoMode::kWheel) {
    c.moving_speed_rad_s = signed_from_direction(speed_raw) * s.speed_unit_rpm * kTwoPi / 60.0;
  } else {
    c.moving_speed_rad_s = speed_rad_s_from_raw(speed_raw);
  }
  c.torque_limit_ratio = std::min(1.0, register_raw(p1::kTorqueLimit) / kLoadFull);
  c.punch_raw = register_raw(p1::kPunch);
  if (is_mx()) {
    c.pid = mx_pid_gains(static_cast<uint8_t>(register_raw(p1::kPGain)), static_cast<uint8_t>(register_raw(p1::kIGain)),
                         static_cast<uint8_t>(register_raw(p1::kDGain)));
    c.goal_acceleration_rad_s2 = register_raw(p1::kGoalAcceleration) * kMxAccelerationUnitRadS2;
    if (has_register(p1::kTorqueCtrlModeEnable)) {
      c.torque_control = register_raw(p1::kTorqueCtrlModeEnable) != 0;
      c.goal_current_a = signed_from_direction(register_raw(p1::kGoalTorque)) * kMxCurrentUnitA;
    }
  } else {
    c.cw_compliance_margin_raw = static_cast<uint8_t>(register_raw(p1::kCwComplianceMargin));
    c.ccw_compliance_margin_raw = static_cast<uint8_t>(register_raw(p1::kCcwComplianceMargin));
    c.cw_compliance_slope_raw = static_cast<uint8_t>(register_raw(p1::kCwComplianceSlope));
    c.ccw_compliance_slope_raw = static_cast<uint8_t>(register_raw(p1::kCcwComplianceSlope));
  }
  return c;
}

void Protocol1Servo::apply(const ServoFeedback& feedback) noexcept {
  const ServoSpec& s = spec().servo;
  const ServoMode m = mode();
  if (std::isfinite(feedback.position_rad)) {
    last_position_rad_ = feedback.position_rad;
  }

  // Position: AX/RX potentiometer saturates at its ends; MX magnetic encoder wraps each turn.
  const int64_t counts = position_raw_from_rad(last_position_rad_);
  int64_t present = 0;
  if (!is_mx()) {
    present = std::clamp<int64_t>(counts, 0, s.position_max_raw);
  } else if (m == ServoMode::kMultiTurn) {
    const int64_t divider = std::max<int64_t>(1, register_raw(p1::kResolutionDivider));
    const int64_t offset = static_cast<int16_t>(register_raw(p1::kMultiTurnOffset));
    present = std::clamp<int64_t>(floor_div(counts, divider) + offset, -kMultiTurnLimit, kMultiTurnLimit);
  } else {
    present = ((counts % 4096) + 4096) % 4096;
  }
  set_register(p1::kPresentPosition, static_cast<uint16_t>(present));

  const double rpm = std::abs(feedback.velocity_rad_s) * 60.0 / kTwoPi;
  const uint16_t speed_raw =
      direction_magnitude(std::isfinite(rpm) ? rpm / s.speed_unit_rpm : 0.0, feedback.velocity_rad_s < 0.0);
  set_register(p1::kPresentSpeed, speed_raw);
  const double ratio = std::isfinite(feedback.torque_ratio) ? feedback.torque_ratio : 0.0;
  set_register(p1::kPresentLoad, direction_magnitude(std::abs(ratio) * kLoadFull, ratio < 0.0));
  const auto voltage_raw = static_cast<uint8_t>(clamp_round(feedback.voltage_v * 10.0, 0, 255));
  const auto temperature_raw = static_cast<uint8_t>(clamp_round(feedback.temperature_c, 0, 255));
  set_register(p1::kPresentVoltage, voltage_raw);
  set_register(p1::kPresentTemperature, temperature_raw);
  if (has_register(p1::kCurrent)) {
    const double current_a = std::isfinite(feedback.current_a) ? feedback.current_a : 0.0;
    set_register(p1::kCurrent,
                 static_cast<uint16_t>(clamp_round(kMxCurrentZero + current_a / kMxCurrentUnitA, 0, 4095)));
  }
  if (has_register(p1::kRealtimeTick)) {
    const int64_t ms = feedback.sim_time_ns / 1'000'000;
    set_register(p1::kRealtimeTick, static_cast<uint16_t>(((ms % 32768) + 32768) % 32768));
  }

  // Moving: turning, or (torque on, position control) not yet within the dead band of the goal.
  const bool torque_on = register_raw(p1::kTorqueEnable) != 0;
  bool moving = (speed_raw & kMagnitudeMask) != 0;
  if (torque_on && m != ServoMode::kWheel) {
    const int32_t goal_raw = is_mx() ? static_cast<int16_t>(register_raw(p1::kGoalPosition))
                                     : static_cast<int32_t>(register_raw(p1::kGoalPosition));
    const int32_t band = is_mx() ? 1
                                 : std::max<int32_t>(register_raw(p1::kCwComplianceMargin),
                                                     register_raw(p1::kCcwComplianceMargin));
    moving = moving || std::abs(goal_raw - static_cast<int32_t>(present)) > band;
  }
  set_register(p1::kMoving, moving ? 1 : 0);

  // Condition bits (reference §1.4).
  const detail::ServoConditions found =
      detail::servo_conditions(temperature_raw, register_raw(p1::kTemperatureLimit), voltage_raw,
                               register_raw(p1::kMinVoltageLimit), register_raw(p1::kMaxVoltageLimit), torque_on,
                               feedback.overload);
  const auto conditions = static_cast<uint8_t>((found.overheating ? p1_error::kOverheating : 0) |
                                               (found.input_voltage ? p1_error::kInputVoltage : 0) |
                                               (found.overload ? p1_error::kOverload : 0));
  conditions_ = conditions;

  // Alarm Shutdown: a masked condition switches the torque off (S7 manuals); the host must write
  // Torque Enable = 1 again once the condition has cleared.
  if ((conditions_ & register_raw(p1::kAlarmShutdown)) != 0) {
    set_register(p1::kTorqueEnable, 0);
  }
}

}  // namespace doppel::dynamixel
