#pragma once
// Private helpers shared by the Protocol 1.0 and 2.0 servo models (protocol1_servo.cpp,
// protocol2_servo.cpp) for turning simulation feedback into register values and the overload
// condition. Not part of the public API.

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace doppel::dynamixel::detail {

// |drive ratio| this close to its limit (Torque Limit, PWM Limit) counts as saturated.
constexpr double kSaturationMargin = 0.01;

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

// The overload condition: with the torque on, |drive_ratio| has stayed within kSaturationMargin of
// `limit_ratio` (> 0) for `hold_ns`. `saturated` and `saturated_since_ns` are the servo's state
// between calls. rt-safe.
inline bool overload_held(bool torque_on, double drive_ratio, double limit_ratio, int64_t now_ns, int64_t hold_ns,
                          bool& saturated, int64_t& saturated_since_ns) noexcept {
  const bool at_limit = torque_on && limit_ratio > 0.0 && std::abs(drive_ratio) >= limit_ratio - kSaturationMargin;
  if (!at_limit) {
    saturated = false;
    return false;
  }
  if (!saturated) {
    saturated = true;
    saturated_since_ns = now_ns;
    return false;
  }
  return now_ns - saturated_since_ns >= hold_ns;
}

}  // namespace doppel::dynamixel::detail
