#include "dynamixel/fumanoid_boards.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace doppel::dynamixel {

namespace {

uint16_t to_int16_raw(double value, double unit) noexcept {
  const double units = value / unit;
  if (!(units == units)) {
    return 0;
  }
  const auto v = static_cast<int16_t>(std::llround(std::clamp(units, -32768.0, 32767.0)));
  return static_cast<uint16_t>(v);
}

uint16_t to_uint16_raw(double value, double unit) noexcept {
  const double units = value / unit;
  if (!(units == units)) {
    return 0;
  }
  return static_cast<uint16_t>(std::llround(std::clamp(units, 0.0, 65535.0)));
}

// Wraps to [-pi, pi).
double wrap_angle(double a) noexcept {
  if (!std::isfinite(a)) {
    return 0.0;
  }
  const double two_pi = 2.0 * std::numbers::pi;
  double w = std::fmod(a + std::numbers::pi, two_pi);
  if (w < 0.0) {
    w += two_pi;
  }
  return w - std::numbers::pi;
}

}  // namespace

FumanoidBoard::FumanoidBoard(const ModelSpec& spec, DeviceKind kind, uint8_t id, uint8_t baud_raw,
                             uint8_t return_delay_raw)
    : Protocol1Device(spec, id, baud_raw, return_delay_raw) {
  if (spec.kind != kind) {
    throw std::invalid_argument(std::string(spec.name) + " is not the expected board model");
  }
}

int64_t FumanoidBoard::sample_period_ns() const noexcept {
  return std::max<int64_t>(1, register_raw(fumanoid::kSamplePeriod)) * 1'000'000;
}

bool FumanoidBoard::sample_due(int64_t t_ns) noexcept {
  if (has_sample_ && t_ns >= last_sample_ns_ && t_ns < next_sample_ns_) {
    return false;
  }
  const int64_t period = sample_period_ns();
  int64_t slot = t_ns / period;
  if (t_ns % period != 0 && t_ns < 0) {
    --slot;
  }
  has_sample_ = true;
  last_sample_ns_ = t_ns;
  next_sample_ns_ = (slot + 1) * period;
  ++samples_;
  set_register(fumanoid::kSampleCounter, static_cast<uint16_t>(samples_ & 0xFFFF));
  return true;
}

void FumanoidBoard::after_factory_reset() noexcept {
  has_sample_ = false;
  samples_ = 0;
}

FumanoidImu::FumanoidImu(uint8_t id, uint8_t baud_raw, uint8_t return_delay_raw)
    : FumanoidBoard(board_spec(DeviceKind::kImu), DeviceKind::kImu, id, baud_raw, return_delay_raw) {}

void FumanoidImu::apply(const ImuFeedback& feedback) noexcept {
  if (!sample_due(feedback.sim_time_ns)) {
    return;
  }
  set_register(fumanoid::kPitch, to_int16_raw(wrap_angle(feedback.pitch_rad), kAngleUnitRad));
  set_register(fumanoid::kRoll, to_int16_raw(wrap_angle(feedback.roll_rad), kAngleUnitRad));
  set_register(fumanoid::kYaw, to_int16_raw(wrap_angle(feedback.yaw_rad), kAngleUnitRad));
  set_register(fumanoid::kGyroX, to_int16_raw(feedback.w_WS_S_rad_s[0], kGyroUnitRadS));
  set_register(fumanoid::kGyroY, to_int16_raw(feedback.w_WS_S_rad_s[1], kGyroUnitRadS));
  set_register(fumanoid::kGyroZ, to_int16_raw(feedback.w_WS_S_rad_s[2], kGyroUnitRadS));
  set_register(fumanoid::kAccelX, to_int16_raw(feedback.a_WS_S_m_s2[0], kAccelUnitMS2));
  set_register(fumanoid::kAccelY, to_int16_raw(feedback.a_WS_S_m_s2[1], kAccelUnitMS2));
  set_register(fumanoid::kAccelZ, to_int16_raw(feedback.a_WS_S_m_s2[2], kAccelUnitMS2));
}

FumanoidFootBoard::FumanoidFootBoard(uint8_t id, uint8_t baud_raw, uint8_t return_delay_raw)
    : FumanoidBoard(board_spec(DeviceKind::kFootBoard), DeviceKind::kFootBoard, id, baud_raw, return_delay_raw) {}

void FumanoidFootBoard::apply(const FootFeedback& feedback) noexcept {
  if (!sample_due(feedback.sim_time_ns)) {
    return;
  }
  constexpr uint8_t kCells[4] = {fumanoid::kForceFrontLeft, fumanoid::kForceFrontRight, fumanoid::kForceBackLeft,
                                 fumanoid::kForceBackRight};
  uint32_t total = 0;
  for (std::size_t i = 0; i < 4; ++i) {
    const uint16_t raw = to_uint16_raw(feedback.force_n[i], kForceUnitN);
    set_register(kCells[i], raw);
    total += raw;
  }
  set_register(fumanoid::kForceTotal, static_cast<uint16_t>(std::min<uint32_t>(total, 0xFFFF)));
}

}  // namespace doppel::dynamixel
