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

constexpr double kFrictionShare = 0.02;  // gear friction: Coulomb, and viscous at no-load speed, per stall torque

// Table 7 motor constants (ke, R, kt) with the datasheet's stall torque and no-load speed at `volts`.
constexpr DcMotorParams from_table7(double ke, double r, double kt, double volts, double no_load_rpm,
                                    double stall_nm, double r_th, double tau_th) {
  return DcMotorParams{ke, r, kt, stall_nm, volts, kFrictionShare * stall_nm, r_th, tau_th,
                       kFrictionShare * stall_nm / (no_load_rpm * kRpm)};
}

// Datasheet line: no-load speed and stall torque/current at a rated voltage. The no-load speed is
// measured against the gear's friction: kt (V - ke w) / R = Coulomb + viscous w at w = no-load speed.
constexpr DcMotorParams from_datasheet(double volts, double no_load_rpm, double stall_nm, double stall_a,
                                       double r_th, double tau_th) {
  const double w = no_load_rpm * kRpm;
  const double r = volts / stall_a, kt = stall_nm / stall_a;
  const double coulomb = kFrictionShare * stall_nm, viscous = kFrictionShare * stall_nm / w;
  return DcMotorParams{(volts - r * (coulomb + viscous * w) / kt) / w, r, kt, stall_nm, volts, coulomb, r_th, tau_th,
                       viscous};
}

// Thermal constants are assumptions (no datasheet gives them): chosen so that a stall at the full
// Torque Limit passes the 80 C limit within about a minute, while holding a standing pose warms a
// motor by only a few kelvin.
const std::array<NamedParams, 8> kModels{{
    {"RX-64", from_table7(2.82, 0.75, 3.2, 18.5, 64.0, 5.3, 60.0, 60.0)},  // Table 7 of the thesis
    {"RX-28", from_table7(2.02, 0.8, 1.9, 18.5, 85.0, 3.7, 50.0, 50.0)},   // Table 7 of the thesis
    {"AX-12A", from_datasheet(12.0, 59.0, 1.5, 1.5, 30.0, 40.0)},
    {"MX-28", from_datasheet(12.0, 55.0, 2.5, 1.4, 30.0, 50.0)},
    {"MX-64", from_datasheet(12.0, 63.0, 6.0, 4.1, 12.0, 60.0)},
    {"MX-106", from_datasheet(12.0, 45.0, 8.4, 5.2, 10.0, 70.0)},
    {"XM430-W350", from_datasheet(12.0, 46.0, 4.1, 2.3, 18.0, 60.0)},
    {"XL430-W250", from_datasheet(12.0, 61.0, 1.5, 1.4, 30.0, 40.0)},  // 1.4 A: assumed, not in the reference
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
  // MX servos with Protocol 2.0 firmware: the same motor and gears as with Protocol 1.0 firmware.
  if (model == "MX-28(2.0)") return dc_motor_params("MX-28");
  if (model == "MX-64(2.0)") return dc_motor_params("MX-64");
  if (model == "MX-106(2.0)") return dc_motor_params("MX-106");
  return std::nullopt;
}

double max_torque_nm(const DcMotorParams& params, double supply_v) noexcept {
  return params.stall_torque_nm * std::max(0.0, supply_v) / params.rated_voltage_v;
}

DriveLaw motor_drive(const DcMotorParams& params, const MotorCommand& command, double supply_v,
                     double velocity_rad_s) noexcept {
  const double friction = params.friction_nm + params.viscous_friction_nm_s_rad * std::abs(velocity_rad_s);
  if (!command.enabled) {
    return DriveLaw{0.0, 0.0, 0.0, friction};
  }
  const double pwm = std::clamp(command.pwm_ratio, -1.0, 1.0);
  const double limit = std::clamp(command.torque_limit_ratio, 0.0, 1.0);
  const double volts = pwm * supply_v;
  return DriveLaw{volts / params.back_emf_v_s_rad,
                  params.torque_constant_nm_a * params.back_emf_v_s_rad / params.resistance_ohm,
                  limit * max_torque_nm(params, supply_v), friction};
}

double no_load_speed_rad_s(const DcMotorParams& params, double volts) noexcept {
  const double damping = params.torque_constant_nm_a * params.back_emf_v_s_rad / params.resistance_ohm;
  const double drive = damping * std::abs(volts) / params.back_emf_v_s_rad;  // motor torque at w = 0
  const double w = std::max(0.0, drive - params.friction_nm) / (damping + params.viscous_friction_nm_s_rad);
  return std::copysign(w, volts);
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
