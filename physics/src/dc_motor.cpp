#include "physics/dc_motor.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace doppel::physics {

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
