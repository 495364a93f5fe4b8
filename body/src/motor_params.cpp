#include "body/motor_params.h"

#include "dynamixel/model_registry.h"

namespace doppel::body {
namespace {

physics::DcMotorParams from_spec(const dynamixel::MotorSpec& m) noexcept {
  physics::DcMotorParams p;
  p.back_emf_v_s_rad = m.back_emf_v_s_rad;
  p.resistance_ohm = m.resistance_ohm;
  p.torque_constant_nm_a = m.torque_constant_nm_a;
  p.stall_torque_nm = m.stall_torque_nm;
  p.rated_voltage_v = m.rated_voltage_v;
  p.friction_nm = m.friction_nm;
  p.thermal_resistance_k_w = m.thermal_resistance_k_w;
  p.thermal_time_constant_s = m.thermal_time_constant_s;
  p.viscous_friction_nm_s_rad = m.viscous_friction_nm_s_rad;
  return p;
}

}  // namespace

physics::DcMotorParams motor_params(std::string_view model) { return from_spec(*dynamixel::servo_spec(model).motor); }

std::optional<physics::DcMotorParams> find_motor_params(std::string_view model) noexcept {
  const dynamixel::ServoSpec* servo = dynamixel::find_servo_spec(model);
  if (servo == nullptr || servo->motor == nullptr) {
    return std::nullopt;
  }
  return from_spec(*servo->motor);
}

physics::MotorCatalog motor_catalog() { return find_motor_params; }

}  // namespace doppel::body
