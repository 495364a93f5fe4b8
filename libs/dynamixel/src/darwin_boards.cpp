#include "dynamixel/darwin_boards.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "dynamixel/models.h"

namespace doppel::dynamixel {

namespace {

// 512 + value / unit, rounded and held inside the 10-bit range; 512 for a value that is not finite.
uint16_t ten_bit(double value, double unit) noexcept {
  const double counts = 512.0 + value / unit;
  if (!std::isfinite(counts)) {
    return 512;
  }
  return static_cast<uint16_t>(std::lround(std::clamp(counts, 0.0, 1023.0)));
}

// value / unit rounded into 0..255 (0 for a value that is not finite).
uint8_t byte_of(double value, double unit) noexcept {
  const double units = value / unit;
  if (!std::isfinite(units)) {
    return 0;
  }
  return static_cast<uint8_t>(std::lround(std::clamp(units, 0.0, 255.0)));
}

constexpr double kRadToDeg = 180.0 / std::numbers::pi;

}  // namespace

Cm730::Cm730(uint8_t id, uint8_t baud_raw, uint8_t return_delay_raw)
    : Protocol1Device(board_spec(DeviceKind::kCm730), id, baud_raw, return_delay_raw) {
  apply(ImuFeedback{});
  apply(PowerFeedback{});
}

void Cm730::apply(const ImuFeedback& feedback) noexcept {
  const double g_per_ms2 = 1.0 / kStandardGravityMS2;
  // The gyro's axes are the accelerometer's turned 90 deg about z: X = -y(S), Y = x(S), Z = z(S).
  set_register(cm730::kGyroX, ten_bit(-feedback.w_WS_S_rad_s[1] * kRadToDeg, kGyroDegSPerCount));
  set_register(cm730::kGyroY, ten_bit(feedback.w_WS_S_rad_s[0] * kRadToDeg, kGyroDegSPerCount));
  set_register(cm730::kGyroZ, ten_bit(feedback.w_WS_S_rad_s[2] * kRadToDeg, kGyroDegSPerCount));
  set_register(cm730::kAccelX, ten_bit(feedback.a_WS_S_m_s2[0] * g_per_ms2, kAccelGPerCount));
  set_register(cm730::kAccelY, ten_bit(feedback.a_WS_S_m_s2[1] * g_per_ms2, kAccelGPerCount));
  set_register(cm730::kAccelZ, ten_bit(feedback.a_WS_S_m_s2[2] * g_per_ms2, kAccelGPerCount));
}

void Cm730::apply(const PowerFeedback& feedback) noexcept {
  set_register(cm730::kVoltage, byte_of(feedback.supply_v, kVoltageUnitV));
}

void Cm730::apply(const ButtonInput& input) noexcept { set_register(cm730::kButton, input.pressed & 0x03); }

DarwinFsr::DarwinFsr(uint8_t id, uint8_t baud_raw, uint8_t return_delay_raw)
    : Protocol1Device(board_spec(DeviceKind::kDarwinFsr), id, baud_raw, return_delay_raw) {
  apply(FootFeedback{});
  set_supply_voltage(kDefaultSupplyVoltage_v);
}

void DarwinFsr::apply(const FootFeedback& feedback) noexcept {
  constexpr uint8_t kCells[4] = {darwin_fsr::kFsr1, darwin_fsr::kFsr2, darwin_fsr::kFsr3, darwin_fsr::kFsr4};
  uint32_t raw[4] = {};
  for (std::size_t i = 0; i < 4; ++i) {
    const double force = feedback.force_n[i];
    if (std::isfinite(force) && force >= kMinimumLoadN) {
      raw[i] = static_cast<uint32_t>(std::lround(std::min(force / kForceUnitN, 65535.0)));
    }
    set_register(kCells[i], static_cast<uint16_t>(raw[i]));
  }
  const uint32_t sum = raw[0] + raw[1] + raw[2] + raw[3];
  if (sum == 0) {
    set_register(darwin_fsr::kFsrX, kNoContact);
    set_register(darwin_fsr::kFsrY, kNoContact);
    return;
  }
  const auto share = [sum](uint32_t part) {
    return static_cast<uint16_t>((254u * part + sum / 2) / sum);  // rounded, 0..254
  };
  set_register(darwin_fsr::kFsrX, share(raw[1] + raw[3]));
  set_register(darwin_fsr::kFsrY, share(raw[0] + raw[1]));
}

void DarwinFsr::set_supply_voltage(double volts) noexcept {
  supply_v_ = volts;
  set_register(darwin_fsr::kPresentVoltage, byte_of(volts, 0.1));
}

}  // namespace doppel::dynamixel
