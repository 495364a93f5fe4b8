#include "physics/dc_motor.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace doppel::physics {

double max_torque_nm(const DcMotorParams& params, double supply_v) noexcept {
  return params.stall_torque_nm * std::max(0.0, supply_v) / params.rated_voltage_v;
}

double friction_budget(const GearFriction& f, double motor_torque_nm, double external_torque_nm,
                       double velocity_rad_s) noexcept {
  double budget = f.coulomb_nm + f.viscous_nm_s_rad * std::abs(velocity_rad_s);
  const bool stribeck = f.law == FrictionLaw::kM2 || f.law >= FrictionLaw::kM4;
  const double s = stribeck && f.stribeck_velocity_rad_s > 0.0
                       ? std::exp(-std::pow(std::abs(velocity_rad_s / f.stribeck_velocity_rad_s), f.stribeck_alpha))
                       : 0.0;
  const double tm = motor_torque_nm;
  const double te = external_torque_nm;
  switch (f.law) {
    case FrictionLaw::kM1:
      break;
    case FrictionLaw::kM2:
      budget += s * f.stribeck_nm;
      break;
    case FrictionLaw::kM3:
      budget += f.load * std::abs(tm - te);
      break;
    case FrictionLaw::kM4:
      budget += f.load * std::abs(tm - te) + s * (f.stribeck_nm + f.load_stribeck * std::abs(tm - te));
      break;
    case FrictionLaw::kM5:
    case FrictionLaw::kM6: {
      budget += std::abs(f.load_motor * tm - f.load_external * te) +
                s * (f.stribeck_nm + std::abs(f.load_motor_stribeck * tm - f.load_external_stribeck * te));
      const bool opposed = (tm > 0.0 && te < 0.0) || (tm < 0.0 && te > 0.0);
      if (f.law == FrictionLaw::kM6 && opposed) {
        if (std::abs(tm) > std::abs(te)) {
          budget += s * f.quadratic_external_per_nm * te * te;
        } else if (std::abs(te) > std::abs(tm)) {
          budget += s * f.quadratic_motor_per_nm * tm * tm;
        }
      }
      break;
    }
  }
  return std::max(0.0, budget);
}

DriveLaw motor_drive(const DcMotorParams& params, const MotorCommand& command, double supply_v,
                     double velocity_rad_s, double motor_torque_nm, double external_torque_nm) noexcept {
  const double friction = friction_budget(params.friction, motor_torque_nm, external_torque_nm, velocity_rad_s);
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
  const double top = std::abs(volts) / params.back_emf_v_s_rad;  // the motor's own no-load speed
  // Net torque at speed w: the motor's minus the friction budget; falls with w, so bisect its zero.
  const auto net = [&](double w) {
    const double motor = damping * (top - w);
    return motor - friction_budget(params.friction, motor, 0.0, w);
  };
  if (!(top > 0.0) || net(0.0) <= 0.0) {
    return 0.0;
  }
  double lo = 0.0;
  double hi = top;
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (net(mid) > 0.0 ? lo : hi) = mid;
  }
  return std::copysign(0.5 * (lo + hi), volts);
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
