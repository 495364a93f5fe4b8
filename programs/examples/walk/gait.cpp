#include "gait.h"

#include <algorithm>
#include <cmath>

namespace walk {

namespace {
constexpr double kPi = 3.14159265358979323846;
constexpr double kUnloadedN = 5;  // a foot carrying less than this is in the air
}

bool leg_ik(const LegGeometry& leg, double x, double y, double z, double yaw, LegAngles& out) {
  // Vector from the hip (roll/pitch axes) to the ankle, in the pelvis frame; the ankle sits
  // ankle_height_m above the flat sole.
  const double dx0 = x;
  const double dy0 = y;
  const double dz = (z + leg.ankle_height_m) - leg.hip_height_m;  // negative: ankle below hip
  // Hip yaw turns the roll/pitch chain: express the vector in the yawed frame.
  const double c = std::cos(yaw), s = std::sin(yaw);
  const double dx = c * dx0 + s * dy0;
  const double dy = -s * dx0 + c * dy0;
  // Hip roll about x: a positive angle swings the foot towards +y.
  const double roll = std::atan2(dy, -dz);
  const double down = std::hypot(dy, dz);  // hip-to-ankle distance in the rolled sagittal plane, vertical part
  double length = std::hypot(dx, down);
  const double a = leg.thigh_m, b = leg.shank_m;
  bool ok = true;
  if (length > a + b - 1e-6) {
    length = a + b - 1e-6;
    ok = false;
  }
  // Knee: + bends (shank swings back); law of cosines.
  const double cos_knee_inner = std::clamp((a * a + b * b - length * length) / (2 * a * b), -1.0, 1.0);
  const double knee = kPi - std::acos(cos_knee_inner);
  // Hip pitch: + swings the foot backwards. The thigh leans forward of the hip-ankle line by beta.
  const double alpha = std::atan2(dx, down);  // hip-ankle line forward of vertical
  const double cos_beta = std::clamp((a * a + length * length - b * b) / (2 * a * length), -1.0, 1.0);
  const double beta = std::acos(cos_beta);
  const double hip_pitch = -(alpha + beta);
  out.hip_yaw = yaw;
  out.hip_roll = roll;
  out.hip_pitch = hip_pitch;
  out.knee = knee;
  out.ankle_pitch = -(hip_pitch + knee);  // sole parallel to the pelvis
  out.ankle_roll = -roll;
  return ok;
}

void Gait::step(double dt_s, double speed_m_s, double turn_rad_s, double amplitude, const ImuReading& imu) {
  phase_ = std::fmod(phase_ + 2 * kPi * dt_s / p_.period_s, 2 * kPi);
  const double ph = phase_;
  // Heading hold: the target heading follows the commanded turn; the error to the IMU's yaw adds
  // to the turn rate the feet are asked for.
  if (!heading_set_) {
    heading_target_ = imu.yaw;
    heading_set_ = true;
  }
  heading_target_ = std::remainder(heading_target_ + amplitude * turn_rad_s * dt_s, 2 * kPi);
  const double heading_error = std::remainder(heading_target_ - imu.yaw, 2 * kPi);
  const double turn_rate = turn_rad_s + std::clamp(p_.heading_gain * heading_error, -0.5, 0.5);
  // A cycle has two steps; in each the standing foot sweeps one step length (half the cycle's
  // travel) backward relative to the hips while the other swings forward.
  const double step = amplitude * p_.stride_scale * speed_m_s * p_.period_s / 2;
  const double turn = amplitude * turn_rate * p_.period_s / 2;
  const double lift = amplitude * p_.lift_m;
  const double sway = amplitude * p_.sway_m * std::sin(ph + p_.sway_lead);
  // Left foot swings for phase in (0, pi), right foot in (pi, 2 pi).
  const double swing_left = std::max(0.0, std::sin(ph));
  const double swing_right = std::max(0.0, -std::sin(ph));
  const double x_left = -0.5 * step * std::cos(ph);
  const double x_right = 0.5 * step * std::cos(ph);
  const double yaw_left = -0.5 * turn * std::cos(ph);
  const double yaw_right = 0.5 * turn * std::cos(ph);

  // Reach: a trunk rolled beyond the deadband over its standing foot stretches the other leg, left
  // hanging in the air on the high side, towards the floor (foot sensors say which foot is free).
  const double excess_roll = std::copysign(std::max(0.0, std::fabs(imu.roll) - p_.reach_deadband), imu.roll);
  const auto hanging = [](double load_n) { return load_n >= 0 && load_n < kUnloadedN; };
  const double reach_left = hanging(imu.load_left_n) ? p_.reach_gain * std::max(0.0, excess_roll) : 0;  // + roll: right side down
  const double reach_right = hanging(imu.load_right_n) ? p_.reach_gain * std::max(0.0, -excess_roll) : 0;

  LegAngles left, right;
  const double z_left = leg_.hip_height_m - p_.hip_height_m + lift * swing_left - reach_left;
  const double z_right = leg_.hip_height_m - p_.hip_height_m + lift * swing_right - reach_right;
  // Sway: the hips move towards the standing foot, so both feet move the other way relative to them.
  reachable_ = leg_ik(leg_, p_.foot_x_m + x_left, p_.foot_y_m + sway, z_left, yaw_left, left);
  reachable_ = leg_ik(leg_, p_.foot_x_m + x_right, -p_.foot_y_m + sway, z_right, yaw_right, right) && reachable_;

  // Pelvis: in single support the standing hip rolls its foot outward, which lifts the pelvis on
  // the swinging side against the sag of the compliant hip and ankle roll servos.
  const double pelvis = amplitude * p_.pelvis_roll_rad;
  const double pelvis_left = pelvis * swing_right;
  const double pelvis_right = -pelvis * swing_left;
  // IMU feedback on the ankles (and hips for roll): a trunk pitching nose-down gets its feet'
  // toes pushed down, which rights it; likewise for roll.
  const double pitch_fb = p_.gyro_pitch_gain * imu.gyro_y + p_.tilt_pitch_gain * imu.pitch;
  const double roll_fb = p_.gyro_roll_gain * imu.gyro_x;
  const double hip_roll_fb = p_.tilt_roll_gain * imu.roll;
  joints_ = {left.hip_yaw,  left.hip_roll + pelvis_left + hip_roll_fb,  left.hip_pitch - p_.trunk_pitch_rad,  left.knee,
             left.ankle_pitch + pitch_fb,  left.ankle_roll + roll_fb,
             right.hip_yaw, right.hip_roll + pelvis_right + hip_roll_fb, right.hip_pitch - p_.trunk_pitch_rad, right.knee,
             right.ankle_pitch + pitch_fb, right.ankle_roll + roll_fb};
}

}  // namespace walk
