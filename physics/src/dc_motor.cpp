#include "physics/dc_motor.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace doppel::physics {
namespace {

constexpr double kRpm = 2.0 * 3.14159265358979323846 / 60.0;

struct NamedParams {
  std::string_view model;
  DcMotorParams params;
};

// Datasheet line: no-load speed and stall torque/current at a rated voltage.
constexpr DcMotorParams from_datasheet(double volts, double no_load_rpm, double stall_nm, double stall_a,
                                       double friction_nm, double r_th, double tau_th) {
  return DcMotorParams{volts / (no_load_rpm * kRpm), volts / stall_a, stall_nm / stall_a, stall_nm, volts,
                       friction_nm, r_th, tau_th};
}

// Thermal constants are assumptions (no datasheet gives them): chosen so that a stall at the full
// Torque Limit passes the 80 C limit within about a minute, while holding a standing pose warms a
// motor by only a few kelvin. Gear friction: about 4 % of the stall torque.
const std::array<NamedParams, 8> kModels{{
    {"RX-64", {2.82, 0.75, 3.2, 5.3, 18.5, 0.2, 60.0, 60.0}},   // Table 7 of the thesis
    {"RX-28", {2.02, 0.8, 1.9, 3.7, 18.5, 0.15, 50.0, 50.0}},   // Table 7 of the thesis
    {"AX-12A", from_datasheet(12.0, 59.0, 1.5, 1.5, 0.06, 30.0, 40.0)},
    {"MX-28", from_datasheet(12.0, 55.0, 2.5, 1.4, 0.1, 30.0, 50.0)},
    {"MX-64", from_datasheet(12.0, 63.0, 6.0, 4.1, 0.24, 12.0, 60.0)},
    {"MX-106", from_datasheet(12.0, 45.0, 8.4, 5.2, 0.34, 10.0, 70.0)},
    {"XM430-W350", from_datasheet(12.0, 46.0, 4.1, 2.3, 0.16, 18.0, 60.0)},
    {"XL430-W250", from_datasheet(12.0, 61.0, 1.5, 1.4, 0.06, 30.0, 40.0)},  // 1.4 A: assumed, not in the reference
}};

}  // namespace

std::optional<DcMotorParams> dc_motor_params(std::string_view model) noexcept {
  for (const NamedParams& named : kModels) {
    if (named.model == model) {
      return named.params;
    }
  }
  if (model == "AX-12" || model == "AX-12+") {
    return dc_motor_params("AX-12A");
  }
  return std::nullopt;
}

double max_torque_nm(const DcMotorParams& params, double supply_v) noexcept {
  return params.stall_torque_nm * std::max(0.0, supply_v) / params.rated_voltage_v;
}

DriveLaw motor_drive(const DcMotorParams& params, const MotorCommand& command, double supply_v) noexcept {
  if (!command.enabled) {
    return DriveLaw{0.0, std::numeric_limits<double>::infinity(), params.friction_nm};
  }
  const double pwm = std::clamp(command.pwm_ratio, -1.0, 1.0);
  const double limit = std::clamp(command.torque_limit_ratio, 0.0, 1.0);
  const double volts = pwm * supply_v;
  return DriveLaw{volts / params.back_emf_v_s_rad,
                  params.torque_constant_nm_a * params.back_emf_v_s_rad / params.resistance_ohm,
                  limit * max_torque_nm(params, supply_v)};
}

double drive_torque(const DriveLaw& law, double velocity) noexcept {
  if (law.max_torque <= 0.0) {
    return 0.0;
  }
  if (std::isinf(law.damping)) {
    // A rigid lock delivers whatever holds it; report the cap's sign only when it slips.
    const double slip = law.target_velocity - velocity;
    return slip == 0.0 ? 0.0 : std::copysign(law.max_torque, slip);
  }
  return std::clamp(law.damping * (law.target_velocity - velocity), -law.max_torque, law.max_torque);
}

ThermalModel::ThermalModel(const DcMotorParams& params, double ambient_c, double step_s) noexcept
    : ambient_c_(ambient_c),
      resistance_ohm_(params.resistance_ohm),
      torque_constant_nm_a_(params.torque_constant_nm_a),
      thermal_resistance_k_w_(params.thermal_resistance_k_w),
      decay_(std::exp(-step_s / params.thermal_time_constant_s)),
      temperature_c_(ambient_c) {}

void ThermalModel::step(double torque_nm) noexcept {
  const double current_a = torque_nm / torque_constant_nm_a_;
  const double heat_w = current_a * current_a * resistance_ohm_;
  const double steady_c = ambient_c_ + heat_w * thermal_resistance_k_w_;
  temperature_c_ = steady_c + (temperature_c_ - steady_c) * decay_;
}

}  // namespace doppel::physics
