#pragma once
// Rhoban's identified actuator models of MX servos (BAM: Duclusaud, Passault, Padois, Ly,
// "Extended Friction Models for the Physics Simulation of Servo Actuators", ICRA 2025;
// Rhoban/bam bam/params/<servo>/m1..m6.json at commit 1b5a1ce, Apache-2.0), fitted on pendulum
// trajectories under the servo's firmware P control at 15 V: the motor constants and the friction
// terms of the friction laws M1..M6 (physics/dc_motor.h gives the equations). Kept beside the
// model registry rather than in it: they are one team's measurement of one unit each, an option
// a robot file chooses (Motor.friction), not the model's defaults. std only.

#include <string_view>

namespace doppel::dynamixel {

// One identification; names follow BAM's files. Terms a law does not have are 0 (dtheta_stribeck
// and alpha 1).
struct BamModel {
  double kt_nm_a = 0.0;                          // kt (= ke, V per rad/s), output-shaft referred
  double resistance_ohm = 0.0;                   // R
  double armature_kg_m2 = 0.0;                   // reflected rotor inertia
  double friction_viscous = 0.0;                 // Kv, N m s/rad
  double friction_base = 0.0;                    // Kc, N m
  double friction_stribeck = 0.0;                // Kcs, N m (M2, M4-M6)
  double dtheta_stribeck = 1.0;                  // w_s, rad/s
  double alpha = 1.0;                            // Stribeck curvature
  double load_friction_base = 0.0;               // Kl (M3, M4)
  double load_friction_stribeck = 0.0;           // Kls (M4)
  double load_friction_motor = 0.0;              // Km (M5, M6)
  double load_friction_external = 0.0;           // Ke (M5, M6)
  double load_friction_motor_stribeck = 0.0;     // Kms (M5, M6)
  double load_friction_external_stribeck = 0.0;  // Kes (M5, M6)
  double load_friction_motor_quad = 0.0;         // Kmq (M6), multiplies tau_m^2
  double load_friction_external_quad = 0.0;      // Keq (M6), multiplies tau_e^2
};

// BAM's identification M<law> (1..6) of servo model `model`; null when BAM has none. MX-64 and
// MX-106 have them; their MX(2.0) versions share the motor and gear train and get the same.
const BamModel* find_bam_model(std::string_view model, int law) noexcept;

}  // namespace doppel::dynamixel
