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

struct DcMotorParams {
  double back_emf_v_s_rad = 0.0;        // ke, V per rad/s at the output shaft
  double resistance_ohm = 0.0;          // R, armature resistance
  double torque_constant_nm_a = 0.0;    // kt, N·m per A at the output shaft
  double stall_torque_nm = 0.0;         // datasheet stall torque at rated_voltage_v: Torque Limit 100 %
  double rated_voltage_v = 0.0;         // voltage of the datasheet figures
  double friction_nm = 0.0;             // Coulomb gear friction at the output, N·m, powered or not
  double thermal_resistance_k_w = 0.0;  // winding to ambient, K/W
  double thermal_time_constant_s = 0.0; // of the winding + case, s
  double viscous_friction_nm_s_rad = 0.0;  // viscous gear friction at the output, N·m per rad/s
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
// not (no drive), with the gear friction at the output speed `velocity_rad_s` of the last step
// (Coulomb + viscous, the viscous part thus one step late). rt-safe.
DriveLaw motor_drive(const DcMotorParams& params, const MotorCommand& command, double supply_v,
                     double velocity_rad_s) noexcept;

// The speed an unloaded output shaft settles at with `volts` applied: the motor's torque equals
// the gear friction, kt (V - ke w) / R = friction + viscous w (or 0 when friction holds it). rt-safe.
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
