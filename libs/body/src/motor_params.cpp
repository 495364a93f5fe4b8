#include "body/motor_params.h"

#include <stdexcept>
#include <string>

#include "dynamixel/bam_models.h"
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
  p.friction.law = physics::FrictionLaw::kM1;
  p.friction.coulomb_nm = m.friction_nm;
  p.friction.viscous_nm_s_rad = m.viscous_friction_nm_s_rad;
  p.thermal_resistance_k_w = m.thermal_resistance_k_w;
  p.thermal_time_constant_s = m.thermal_time_constant_s;
  return p;
}

// BAM's identification M<law> replaces kt, R (ke = kt: BAM's motor is tau = kt (V - kt w) / R) and
// the friction; the datasheet stall torque, thermal constants and mass stay the registry's.
physics::DcMotorParams with_bam(physics::DcMotorParams p, const dynamixel::BamModel& b, int law) noexcept {
  p.torque_constant_nm_a = b.kt_nm_a;
  p.back_emf_v_s_rad = b.kt_nm_a;
  p.resistance_ohm = b.resistance_ohm;
  p.armature_kg_m2 = b.armature_kg_m2;
  p.powered_friction = true;
  physics::GearFriction& f = p.friction;
  f = physics::GearFriction{};
  f.law = static_cast<physics::FrictionLaw>(law);
  f.viscous_nm_s_rad = b.friction_viscous;
  f.coulomb_nm = b.friction_base;
  f.stribeck_nm = b.friction_stribeck;
  f.stribeck_velocity_rad_s = b.dtheta_stribeck;
  f.stribeck_alpha = b.alpha;
  f.load = b.load_friction_base;
  f.load_stribeck = b.load_friction_stribeck;
  f.load_motor = b.load_friction_motor;
  f.load_external = b.load_friction_external;
  f.load_motor_stribeck = b.load_friction_motor_stribeck;
  f.load_external_stribeck = b.load_friction_external_stribeck;
  f.quadratic_motor_per_nm = b.load_friction_motor_quad;
  f.quadratic_external_per_nm = b.load_friction_external_quad;
  return p;
}

}  // namespace

physics::DcMotorParams motor_params(std::string_view model, int bam_model) {
  const dynamixel::ServoSpec& servo = dynamixel::servo_spec(model);
  if (bam_model == 0) {
    return from_spec(*servo.motor);
  }
  const dynamixel::BamModel* bam = dynamixel::find_bam_model(model, bam_model);
  if (bam == nullptr) {
    throw std::invalid_argument("servo model '" + std::string(model) + "' has no BAM identification M" +
                                std::to_string(bam_model) + " (BAM identified the MX-64 and MX-106, M1 to M6)");
  }
  return with_bam(from_spec(*servo.motor), *bam, bam_model);
}

std::optional<physics::DcMotorParams> find_motor_params(std::string_view model, int bam_model) noexcept {
  const dynamixel::ServoSpec* servo = dynamixel::find_servo_spec(model);
  if (servo == nullptr || servo->motor == nullptr) {
    return std::nullopt;
  }
  if (bam_model == 0) {
    return from_spec(*servo->motor);
  }
  const dynamixel::BamModel* bam = dynamixel::find_bam_model(model, bam_model);
  if (bam == nullptr) {
    return std::nullopt;
  }
  return with_bam(from_spec(*servo->motor), *bam, bam_model);
}

physics::MotorCatalog motor_catalog() { return find_motor_params; }

}  // namespace doppel::body
