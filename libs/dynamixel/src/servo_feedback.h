#pragma once
// Private helpers shared by the Protocol 1.0 and 2.0 servo models (protocol1_servo.cpp,
// protocol2_servo.cpp) for turning simulation feedback into register values. Not part of the
// public API.

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace doppel::dynamixel::detail {

// `v` rounded to the nearest integer in [lo, hi]; +-infinity to the bound, NaN to 0 (or the bound
// nearest 0). rt-safe.
inline int64_t clamp_round(double v, int64_t lo, int64_t hi) noexcept {
  if (!std::isfinite(v)) {
    return v > 0 ? hi : (v < 0 ? lo : std::clamp<int64_t>(0, lo, hi));
  }
  return std::llround(std::clamp(v, static_cast<double>(lo), static_cast<double>(hi)));
}

// a / b rounded towards negative infinity (b != 0). rt-safe.
inline int64_t floor_div(int64_t a, int64_t b) noexcept {
  const int64_t q = a / b;
  return (a % b != 0 && ((a < 0) != (b < 0))) ? q - 1 : q;
}

// The conditions both servo firmwares check after every measurement (P1 error bits of reference
// §1.4, X Hardware Error Status of §3.7): winding above the Temperature Limit, supply outside the
// voltage limits (both in register units), and the motor controller's overload while powered.
struct ServoConditions {
  bool overheating = false;
  bool input_voltage = false;
  bool overload = false;
};

inline ServoConditions servo_conditions(int64_t temperature_raw, int64_t temperature_limit_raw, int64_t voltage_raw,
                                        int64_t min_voltage_raw, int64_t max_voltage_raw, bool torque_on,
                                        bool overload) noexcept {
  return ServoConditions{temperature_raw > temperature_limit_raw,
                         voltage_raw < min_voltage_raw || voltage_raw > max_voltage_raw, torque_on && overload};
}

}  // namespace doppel::dynamixel::detail
