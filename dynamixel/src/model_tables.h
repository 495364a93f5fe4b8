#pragma once
// Private helpers shared by the Protocol 1.0 (models.cpp) and Protocol 2.0 (protocol2_models.cpp)
// model tables: the DC-motor constants derived from a datasheet point, the register lookup and the
// list of known names for error messages. Not part of the public API.

#include <numbers>
#include <span>
#include <string>

#include "dynamixel/models.h"

namespace doppel::dynamixel::detail {

constexpr double rpm_to_rad_s(double rpm) { return rpm * 2.0 * std::numbers::pi / 60.0; }

// Fills the datasheet point of `s` (reference §5, at `volts`) and derives the DC-motor constants
// from it as the thesis does for the RX-64 (§4.2.1.2): at no load all of V is back-EMF ->
// ke = V / w_no_load; at stall only the armature limits the current -> R = V / I_stall;
// kt = tau_stall / I_stall. All at the output shaft, so the gear is inside the constants.
constexpr ServoSpec with_datasheet_motor(ServoSpec s, double volts, double no_load_rpm, double stall_n_m,
                                         double stall_a, double gear, double mass_kg) {
  s.nominal_voltage_v = volts;
  s.no_load_speed_rpm = no_load_rpm;
  s.stall_torque_n_m = stall_n_m;
  s.stall_current_a = stall_a;
  s.ke_v_s_per_rad = volts / rpm_to_rad_s(no_load_rpm);
  s.resistance_ohm = volts / stall_a;
  s.kt_n_m_per_a = stall_n_m / stall_a;
  s.gear_ratio = gear;
  s.mass_kg = mass_kg;
  return s;
}

// The register (RegisterSpec or P2RegisterSpec) whose bytes contain `address`; nullptr for none.
// rt-safe.
template <class Register, class Address>
const Register* register_containing(std::span<const Register> registers, Address address) noexcept {
  for (const Register& r : registers) {
    if (address >= r.address && address < r.address + r.size) {
      return &r;
    }
  }
  return nullptr;
}

// "A, B, C": the names of `models` (ModelSpec or P2ModelSpec) for an "unknown model" message. Setup only.
template <class Model>
std::string model_names(std::span<const Model* const> models) {
  std::string names;
  for (const Model* m : models) {
    names += names.empty() ? "" : ", ";
    names += m->name;
  }
  return names;
}

}  // namespace doppel::dynamixel::detail
