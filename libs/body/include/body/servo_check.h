#pragma once
// Doppel's servo against measured hardware (docs/fidelity.md): Rhoban's BAM (Duclusaud, Passault
// et al., ICRA 2025, github.com/Rhoban/bam) recorded MX-64 and MX-106 servos swinging a pendulum
// under their firmware's P control, and earlier their no-load speed per motor voltage and their
// PWM duty per position error. This replays such a log through Doppel's own chain (firmware
// controller -> DC motor with its gear friction -> one physics joint) and reports the position
// error as BAM does (mean absolute error), and computes Doppel's answer to the steady-state
// tables. The logs are not shipped (the user points the tool at them); the formats are BAM's
// (bam/dynamixel/record.py, bam/process.py, atomic/data/*.json). Setup code: parsing throws
// std::invalid_argument naming the file and what is wrong.

#include <cstddef>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "physics/backend.h"

namespace doppel::body {

struct PendulumSample {
  double time_s = 0.0;
  double position_rad = 0.0;       // measured servo angle, 0 = arm hanging down, + = CCW
  double goal_position_rad = 0.0;  // what the recorder commanded
  bool torque_enable = true;
};

// One BAM pendulum log: a mass at the end of an arm on the servo's horn, recorded at firmware
// P gain `kp` (the raw P Gain register) with `vin_v` on the bus.
struct PendulumLog {
  std::string name;              // the file, for messages
  std::string motor;             // BAM's name ("mx64", "mx106", ...), may be empty
  std::string trajectory;        // BAM's trajectory name, may be empty
  double mass_kg = 0.0;          // end mass
  double arm_mass_kg = 0.0;      // the arm, a uniform rod
  double length_m = 0.0;         // axis to end mass
  double kp = 0.0;               // P Gain register, raw
  double vin_v = 15.0;           // supply (BAM's default when the log has none)
  std::vector<PendulumSample> samples;  // time strictly increasing, at least two
};

// Parses a raw (`entries[].timestamp`) or processed (`dt` and entries without timestamps) BAM log.
PendulumLog parse_bam_log(std::string_view json_text, std::string_view name);

struct ReplayOptions {
  std::string servo = "MX-64";  // the registry model that turns the servo
  int bam_model = 0;            // 0: the registry's motor and friction; 1..6: BAM's identification M1..M6
  bool armature = true;         // add the identification's armature to the pendulum's inertia
  double step_s = 0.001;        // physics and firmware step
};

struct ReplayResult {
  double mae_rad = 0.0;        // mean |simulated - measured| over the log's samples
  double rmse_rad = 0.0;
  double max_error_rad = 0.0;
  std::size_t samples = 0;
  std::vector<double> simulated_rad;  // at each sample's time
};

// Replays `log` on a one-joint pendulum in a world on `backend`: the goal and torque enable of the
// latest sample drive the servo's firmware controller every step, the arm starts at rest at the
// first measured angle. Throws std::invalid_argument for a servo or identification not known.
ReplayResult replay_bam_log(const PendulumLog& log, const ReplayOptions& options,
                            std::unique_ptr<physics::Backend> backend);

// BAM's no-load speed per voltage applied to the motor (atomic/data/velocity_<servo>.json:
// {"volts": rad/s}).
struct SpeedPoint {
  double volts = 0.0;
  double measured_rad_s = 0.0;
};
std::vector<SpeedPoint> parse_speed_table(std::string_view json_text, std::string_view name);

// BAM's oscilloscope PWM readings (atomic/data/pwm_<servo>.json): goal and present angle in
// degrees, P Gain, the high time of the PWM period; duty = period / pwm_period.
struct DutyPoint {
  double error_rad = 0.0;  // |position - target|
  double kp = 0.0;
  double measured_duty = 0.0;
};
std::vector<DutyPoint> parse_duty_table(std::string_view json_text, std::string_view name);

// Doppel's steady no-load speed of `servo` (registry motor or BAM's M<bam_model>) at `volts` on the
// motor: physics::no_load_speed_rad_s.
double doppel_no_load_speed_rad_s(std::string_view servo, int bam_model, double volts);

// The duty Doppel's firmware controller of `servo` puts out for a position error `error_rad` at
// P Gain `kp` (I = D = 0), at rest.
double doppel_duty(std::string_view servo, double kp, double error_rad);

}  // namespace doppel::body
