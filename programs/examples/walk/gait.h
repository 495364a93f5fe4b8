#pragma once
// The reference walk's gait: an open-loop, sinusoidal (CPG-style) pattern of foot positions
// relative to the hips, turned into joint angles by an analytic leg inverse kinematics for the
// FUmanoid 2011 leg (data/robots/fumanoid-2011.textproto), plus feedback from the IMU (gyro damping,
// roll angle, heading) and the foot sensors (a hanging foot reaches for the floor), without which
// it fell sideways now and then. docs/walk.md explains it with the measurements.

#include <array>
#include <cstdint>

namespace walk {

// Leg geometry of data/robots/fumanoid-2011.textproto (link anchors): hip roll/pitch axes at z 0.27 m,
// knee at 0.15, ankle pitch/roll at 0.04, sole at 0; hips 0.05 m either side of the centre.
struct LegGeometry {
  double thigh_m = 0.12;
  double shank_m = 0.11;
  double ankle_height_m = 0.04;
  double hip_height_m = 0.27;
  double hip_offset_y_m = 0.05;
};

// Link angles of one leg (rad, the robot file's link convention: 0 = design pose).
struct LegAngles {
  double hip_yaw = 0, hip_roll = 0, hip_pitch = 0, knee = 0, ankle_pitch = 0, ankle_roll = 0;
};

// Angles that put the sole's centre at (x, y, z) relative to the point on the floor below the hip
// in the design pose (z = 0 is the floor), with the sole flat and turned by `yaw` about z.
// Returns false (angles clamped to a straight knee) when the point is out of reach.
bool leg_ik(const LegGeometry& leg, double x, double y, double z, double yaw, LegAngles& out);

struct GaitParameters {
  double period_s = 0.5;        // one full cycle: a left and a right step
  double hip_height_m = 0.245;  // hip above the floor while walking (design pose 0.27)
  double lift_m = 0.018;        // swing foot lift
  double sway_m = 0.015;        // lateral hip sway amplitude
  double sway_lead = 0.3;       // sway phase lead (rad) over the lift
  double foot_x_m = 0.0;        // feet forward of the hips (shifts the centre of mass back)
  double foot_y_m = 0.0;        // extra foot spread either side
  double trunk_pitch_rad = 0.0;    // forward lean of the trunk (added to both hip pitches)
  double pelvis_roll_rad = 0.1;    // standing hip rolled outward in single support (lifts the swinging side)
  double gyro_pitch_gain = 0.1;    // ankle pitch per rad/s of trunk pitch rate
  double gyro_roll_gain = 0.1;     // ankle roll per rad/s of trunk roll rate
  double tilt_pitch_gain = 0.0;    // ankle pitch per rad of trunk pitch
  double tilt_roll_gain = -0.3;    // hip roll per rad of trunk roll (-: hips away from the low side)
  double reach_gain = 0.15;         // an unloaded foot on the high side lowered (m) per rad of roll beyond reach_deadband
  double reach_deadband = 0.05;    // rad
  double heading_gain = 1.0;       // turn rate (rad/s) per rad of heading error
  double stride_scale = 0.64;      // step length per commanded (speed x period / 2): calibration
};

// What the IMU says (docs/devices.md, FUMANOID-IMU): pitch + nose down, roll + right side down,
// rates about the board's y and x axes.
struct ImuReading {
  double pitch = 0, roll = 0, yaw = 0, gyro_x = 0, gyro_y = 0, gyro_z = 0;
  double load_left_n = -1, load_right_n = -1;  // foot load cells' totals, N (-1: the robot has none)
};

// The 12 leg joints in the order left (yaw, roll, pitch, knee, ankle pitch, ankle roll), right (same).
using LegJoints = std::array<double, 12>;

class Gait {
 public:
  Gait(const LegGeometry& leg, const GaitParameters& params) : leg_(leg), p_(params) {}

  // Advances simulation time by dt_s with commanded forward speed (m/s) and turn rate (rad/s);
  // `amplitude` in [0, 1] scales step, sway and lift (0 = stand, ramps avoid jerks).
  void step(double dt_s, double speed_m_s, double turn_rad_s, double amplitude, const ImuReading& imu);
  const LegJoints& joints() const { return joints_; }
  double phase() const { return phase_; }
  bool reachable() const { return reachable_; }

 private:
  LegGeometry leg_;
  GaitParameters p_;
  double phase_ = 0;
  LegJoints joints_{};
  bool reachable_ = true;
  bool heading_set_ = false;
  double heading_target_ = 0;
};

}  // namespace walk
