#pragma once
// The electrical and thermal model of a servo's geared DC motor, referred to the output shaft:
// torque = kt * (V - ke * w) / R (thesis section 4.2.1.2), limited by the Torque Limit register,
// and a first-order thermal model of the winding. It is not the servo's firmware (that turns a goal
// into a voltage: dynamixel/servo_controller.h) and knows no engine: a backend applies the torque
// as an implicit drive (see DriveCommand in backend.h), which keeps the stiff back-EMF damping
// stable at a 1 ms step. It knows no servo models: its constants come from the device model
// registry through body/motor_params.h.

#include <cstdint>

namespace doppel::physics {

// The gear friction laws M1..M6 of Duclusaud, Passault, Padois and Ly, "Extended Friction Models
// for the Physics Simulation of Servo Actuators" (ICRA 2025; Rhoban/bam, docs/theory/models.rst
// and bam/model.py). Each gives the largest torque friction can oppose, the budget tau_fm, from
// the joint speed w, the motor's torque tau_m and the external torque tau_e on the joint (same sign
// convention: both accelerate the joint when positive); the joint sticks while the other torques
// stay within the budget (the backend's zero-speed row bounded by it, as BAM clips its stopping
// torque). s = exp(-|w / w_s|^alpha) is the Stribeck factor (1 at rest, 0 when sliding fast).
//   M1 Coulomb-viscous:           Kv|w| + Kc
//   M2 Stribeck:                  M1 + s Kcs
//   M3 load-dependent:            M1 + Kl |tau_m - tau_e|
//   M4 Stribeck load-dependent:   M3 + s (Kcs + Kls |tau_m - tau_e|)
//   M5 directional:               M1 + |Km tau_m - Ke tau_e| + s (Kcs + |Kms tau_m - Kes tau_e|)
//   M6 quadratic directional:     M5 + s Q, Q = Keq tau_e^2 if |tau_m| > |tau_e|, Kmq tau_m^2 if
//                                 |tau_e| > |tau_m|, only while tau_m and tau_e have opposite signs
//                                 (bam/model.py; the paper's text omits that condition), else 0.
enum class FrictionLaw : uint8_t { kM1 = 1, kM2, kM3, kM4, kM5, kM6 };

struct GearFriction {
  FrictionLaw law = FrictionLaw::kM1;
  double viscous_nm_s_rad = 0.0;          // Kv, N·m per rad/s
  double coulomb_nm = 0.0;                // Kc, N·m
  double stribeck_nm = 0.0;               // Kcs, N·m (M2, M4-M6)
  double stribeck_velocity_rad_s = 1.0;   // w_s, > 0 (M2, M4-M6)
  double stribeck_alpha = 1.0;            // alpha (M2, M4-M6)
  double load = 0.0;                      // Kl (M3, M4)
  double load_stribeck = 0.0;             // Kls (M4)
  double load_motor = 0.0;                // Km (M5, M6)
  double load_external = 0.0;             // Ke (M5, M6)
  double load_motor_stribeck = 0.0;       // Kms (M5, M6)
  double load_external_stribeck = 0.0;    // Kes (M5, M6)
  double quadratic_motor_per_nm = 0.0;    // Kmq, 1/N·m (M6)
  double quadratic_external_per_nm = 0.0; // Keq, 1/N·m (M6)
};

// The friction budget tau_fm >= 0 of `friction` (the equations above). rt-safe.
double friction_budget(const GearFriction& friction, double motor_torque_nm, double external_torque_nm,
                       double velocity_rad_s) noexcept;

// Whether the law has a term in tau_m or tau_e (M3..M6): the caller then needs the external torque.
constexpr bool load_dependent(FrictionLaw law) noexcept { return law >= FrictionLaw::kM3; }

struct DcMotorParams {
  double back_emf_v_s_rad = 0.0;        // ke, V per rad/s at the output shaft
  double resistance_ohm = 0.0;          // R, armature resistance
  double torque_constant_nm_a = 0.0;    // kt, N·m per A at the output shaft
  double stall_torque_nm = 0.0;         // datasheet stall torque at rated_voltage_v: Torque Limit 100 %
  double rated_voltage_v = 0.0;         // voltage of the datasheet figures
  double thermal_resistance_k_w = 0.0;  // winding to ambient, K/W
  double thermal_time_constant_s = 0.0; // of the winding + case, s
  GearFriction friction;                // gear friction at the output, powered or not
  // Whether the gear friction also acts while the servo is powered whatever
  // WorldOptions::powered_gear_friction says: true for BAM's identified models, which were fitted
  // on a powered servo.
  bool powered_friction = false;
  // Reflected rotor inertia at the output (BAM's identified armature), kg·m². The engines do not
  // simulate it (docs/physics.md); the one-joint check (body/servo_check.h) adds it to its load.
  double armature_kg_m2 = 0.0;
};

// What the firmware applies to the motor during one step.
struct MotorCommand {
  bool enabled = false;             // Torque Enable (and no shutdown): false = H-bridge off, joint limp
  double pwm_ratio = 0.0;           // -1..1, applied voltage = pwm_ratio * supply; + = servo CCW
  double torque_limit_ratio = 1.0;  // 0..1, Torque Limit register as a fraction of full torque
};

// A torque-speed law tau = clamp(damping * (target_velocity - w), +-max_torque), which a backend
// solves implicitly with the joint's new velocity w. A DC motor is exactly this law with
// target_velocity = V / ke and damping = kt * ke / R; a rigid lock is damping = infinity.
// Gear friction is a second, separate law on the same axis: a torque of at most friction_torque
// that opposes motion (a rigid zero-speed constraint bounded by it), so the joint sticks while
// the other torques stay below it and slides against it otherwise.
struct DriveLaw {
  double target_velocity = 0.0;  // rad/s (or m/s for a prismatic link)
  double damping = 0.0;          // N·m·s/rad; infinity = rigid velocity constraint
  double max_torque = 0.0;       // N·m (or N), >= 0; 0 = no drive
  double friction_torque = 0.0;  // N·m (or N), >= 0; 0 = no friction
};

// Maximum output torque at `supply_v` with a 100 % Torque Limit: the datasheet stall torque scaled
// by supply / rated voltage.
double max_torque_nm(const DcMotorParams& params, double supply_v) noexcept;

// The drive law for `command` at `supply_v`: powered (DC-motor line capped by the Torque Limit) or
// not (no drive), with the gear friction budget at the output speed `velocity_rad_s`, motor torque
// and external torque of the last step (so one step late). rt-safe.
DriveLaw motor_drive(const DcMotorParams& params, const MotorCommand& command, double supply_v,
                     double velocity_rad_s, double motor_torque_nm = 0.0, double external_torque_nm = 0.0) noexcept;

// The speed an unloaded output shaft settles at with `volts` applied: the motor's torque equals
// the gear friction budget with no external torque, kt (V - ke w) / R = tau_fm(tau_m, 0, w) (or 0
// when friction holds it). rt-safe (a bounded bisection).
double no_load_speed_rad_s(const DcMotorParams& params, double volts) noexcept;

// The motor's torque under the law at joint speed `velocity` (the speed after the step), without
// the gear friction. rt-safe.
double drive_torque(const DriveLaw& law, double velocity) noexcept;

// Winding temperature: C dT/dt = I^2 R - (T - T_ambient) / R_th, integrated exactly over a step.
class ThermalModel {
 public:
  ThermalModel(const DcMotorParams& params, double ambient_c, double step_s) noexcept;
  // Advances one step with the motor carrying `torque_nm` (current = torque / kt). rt-safe.
  void step(double torque_nm) noexcept;
  double temperature_c() const noexcept { return temperature_c_; }
  void set_temperature_c(double temperature_c) noexcept { temperature_c_ = temperature_c; }

 private:
  double ambient_c_;
  double resistance_ohm_;
  double torque_constant_nm_a_;
  double thermal_resistance_k_w_;
  double decay_;  // exp(-step / time constant)
  double temperature_c_;
};

}  // namespace doppel::physics
