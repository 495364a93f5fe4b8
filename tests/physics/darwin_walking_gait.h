#pragma once
// The DARwIn-OP framework's walking gait (darwinop-ens/darwin-op, Framework/src/motion/modules/
// Walking.cpp, commit fe301d0) as equations, written for Doppel's tests from the published
// algorithm so that CI can walk the darwin-op body the way the robot's own software does without
// the framework (GPL, not vendored). Facts carried over: the constructor's parameters, the
// sinusoidal foot and body trajectories and their phases, when the amplitudes are taken up, the
// 8 ms time step with its snap to the half period, the leg lengths of Kinematics.cpp, the joint
// directions, and the gyro balance offsets. Checked against the framework's own Walking::Process
// (docs/fidelity.md, "DARwIn-OP framework walk": the same goal positions, cycle by cycle).

#include <algorithm>
#include <array>
#include <cmath>

namespace doppel::testing::darwin_walking {

// Walking's constructor defaults (no [Walking Config] in Data/config.ini); mm, deg, ms.
struct Parameters {
  double x_offset = -10, y_offset = 5, z_offset = 20;
  double hip_pitch_offset = 13.0;
  double period = 600, dsp_ratio = 0.1, step_fb_ratio = 0.28;
  double z_move = 40, y_swap = 20, z_swap = 5;
  double pelvis_offset = 3.0, arm_swing_gain = 1.5;
  double balance_knee = 0.3, balance_ankle_pitch = 0.9, balance_hip_roll = 0.5, balance_ankle_roll = 1.0;
};

// Kinematics.cpp: thigh and calf 93 mm, sole 33.5 mm below the ankle axes, 219.5 mm in all.
inline constexpr double kThigh = 93.0, kCalf = 93.0, kAnkle = 33.5, kLeg = 219.5;
// MX28.cpp: 11.378 counts per degree around 2048.
inline constexpr double kCountsPerDeg = 11.378;
inline constexpr double kTimeUnitMs = 8.0;  // MotionModule::TIME_UNIT
inline int angle_to_value(double deg) { return static_cast<int>(deg * kCountsPerDeg) + 2048; }

// Goal Position of IDs 1..18 (index 0 unused); the head (19, 20) belongs to another module.
using Goals = std::array<int, 19>;

class Walking {
 public:
  explicit Walking(const Parameters& p = {}) : p_(p) {
    take_time_parameters();
    take_move_parameters();
  }

  // The command, taken up at the next quarter period as the framework does.
  double x_amplitude = 0, y_amplitude = 0, a_amplitude = 0;

  void start() { ctrl_running_ = real_running_ = true; }
  void stop() { ctrl_running_ = false; }
  bool running() const { return real_running_; }

  // One 8 ms cycle with the calibrated gyro counts (MotionStatus FB_GYRO = Gyro Y - centre,
  // RL_GYRO = Gyro X - centre); returns every joint's goal.
  const Goals& process(int fb_gyro, int rl_gyro) {
    const double half_unit = kTimeUnitMs / 2;
    if (time_ == 0) {
      take_time_parameters();
      stop_if_asked();
    } else if (time_ >= phase1_ - half_unit && time_ < phase1_ + half_unit) {
      take_move_parameters();
    } else if (time_ >= phase2_ - half_unit && time_ < phase2_ + half_unit) {
      take_time_parameters();
      time_ = phase2_;
      stop_if_asked();
    } else if (time_ >= phase3_ - half_unit && time_ < phase3_ + half_unit) {
      take_move_parameters();
    }
    compute(fb_gyro, rl_gyro);
    return goals_;
  }

 private:
  // A sinusoid of the framework's form: mag sin(2 pi t / period - shift) + offset, with its own
  // 3.141592 for pi.
  static double wave(double t, double period, double shift, double mag, double offset) {
    return mag * std::sin(2 * 3.141592 / period * t - shift) + offset;
  }
  static constexpr double kPi = 3.14159265;

  void take_time_parameters() {
    period_ = p_.period;
    const double ssp = 1 - p_.dsp_ratio;
    x_swap_period_ = period_ / 2;
    x_move_period_ = period_ * ssp;
    y_swap_period_ = period_;
    z_swap_period_ = period_ / 2;
    z_move_period_ = period_ * ssp / 2;
    a_move_period_ = period_ * ssp;
    ssp_start_l_ = (1 - ssp) * period_ / 4;
    ssp_end_l_ = (1 + ssp) * period_ / 4;
    ssp_start_r_ = (3 - ssp) * period_ / 4;
    ssp_end_r_ = (3 + ssp) * period_ / 4;
    phase1_ = (ssp_end_l_ + ssp_start_l_) / 2;
    phase2_ = (ssp_start_r_ + ssp_end_l_) / 2;
    phase3_ = (ssp_end_r_ + ssp_start_r_) / 2;
    pelvis_offset_ = p_.pelvis_offset * kCountsPerDeg;
    pelvis_swing_ = pelvis_offset_ * 0.35;
  }

  void take_move_parameters() {
    x_move_ = x_amplitude;
    x_swap_ = x_amplitude * p_.step_fb_ratio;
    y_move_ = y_amplitude / 2;
    y_swap_ = p_.y_swap + std::abs(y_move_) * 0.04;
    z_move_ = p_.z_move / 2;
    a_move_ = a_amplitude * kPi / 180.0 / 2;
  }

  // At the start and the half of a period: a stop request ends the walk once the amplitudes are 0.
  void stop_if_asked() {
    if (ctrl_running_) return;
    if (x_move_ == 0 && y_move_ == 0 && a_move_ == 0) {
      real_running_ = false;
    } else {
      x_amplitude = y_amplitude = a_amplitude = 0;
    }
  }

  struct Foot {
    double x, y, z, yaw;
  };

  // A swing phase of one foot: x, y and yaw travel from -amplitude to +amplitude over the single
  // support time, z lifts and lowers twice as fast; `base` is the start of that foot's swing and
  // `half` puts the right foot's travel half a cycle behind the left's.
  double travel(double t, double period, double base, bool half, double mag, double offset) const {
    return wave(t, period, kPi / 2 + 2 * kPi / period * base + (half ? kPi : 0.0), mag, offset);
  }

  void compute(int fb_gyro, int rl_gyro) {
    const double t = time_;
    const double x_swap = wave(t, x_swap_period_, kPi, x_swap_, 0);
    const double y_swap = wave(t, y_swap_period_, 0, y_swap_, 0);
    const double z_swap = wave(t, z_swap_period_, kPi * 3 / 2, p_.z_swap, p_.z_swap);
    const double zm = z_move_, zm_offset = z_move_ / 2;
    const double ym_offset = std::abs(y_move_), am_offset = std::abs(a_move_);

    // Which time each trajectory is evaluated at: it holds its end values outside its swing.
    double t_xl, t_zl, t_zr, pelvis_l = 0, pelvis_r = 0;
    bool right_swing;
    if (t <= ssp_start_l_) {
      t_xl = ssp_start_l_, t_zl = ssp_start_l_, t_zr = ssp_start_r_, right_swing = false;
    } else if (t <= ssp_end_l_) {
      t_xl = t, t_zl = t, t_zr = ssp_start_r_, right_swing = false;
      pelvis_l = wave(t, z_move_period_, kPi / 2 + 2 * kPi / z_move_period_ * ssp_start_l_, pelvis_swing_ / 2,
                      pelvis_swing_ / 2);
      pelvis_r = wave(t, z_move_period_, kPi / 2 + 2 * kPi / z_move_period_ * ssp_start_l_, -pelvis_offset_ / 2,
                      -pelvis_offset_ / 2);
    } else if (t <= ssp_start_r_) {
      t_xl = ssp_end_l_, t_zl = ssp_end_l_, t_zr = ssp_start_r_, right_swing = false;
    } else if (t <= ssp_end_r_) {
      t_xl = t, t_zl = ssp_end_l_, t_zr = t, right_swing = true;
      pelvis_l = wave(t, z_move_period_, kPi / 2 + 2 * kPi / z_move_period_ * ssp_start_r_, pelvis_offset_ / 2,
                      pelvis_offset_ / 2);
      pelvis_r = wave(t, z_move_period_, kPi / 2 + 2 * kPi / z_move_period_ * ssp_start_r_, -pelvis_swing_ / 2,
                      -pelvis_swing_ / 2);
    } else {
      t_xl = ssp_end_r_, t_zl = ssp_end_l_, t_zr = ssp_end_r_, right_swing = true;
    }
    const double base = right_swing ? ssp_start_r_ : ssp_start_l_;
    Foot left{travel(t_xl, x_move_period_, base, right_swing, x_move_, 0),
              travel(t_xl, x_move_period_, base, right_swing, y_move_, ym_offset),
              travel(t_zl, z_move_period_, ssp_start_l_, false, zm, zm_offset),
              travel(t_xl, a_move_period_, base, right_swing, a_move_, am_offset)};
    Foot right{travel(t_xl, x_move_period_, base, right_swing, -x_move_, 0),
               travel(t_xl, x_move_period_, base, right_swing, -y_move_, -ym_offset),
               travel(t_zr, z_move_period_, ssp_start_r_, false, zm, zm_offset),
               travel(t_xl, a_move_period_, base, right_swing, -a_move_, -am_offset)};
    right = {x_swap + right.x + p_.x_offset, y_swap + right.y - p_.y_offset / 2, z_swap + right.z + p_.z_offset,
             right.yaw};
    left = {x_swap + left.x + p_.x_offset, y_swap + left.y + p_.y_offset / 2, z_swap + left.z + p_.z_offset, left.yaw};

    double arm_r = 0, arm_l = 0;
    if (x_move_ != 0) {
      arm_r = wave(t, period_, kPi * 1.5, -x_move_ * p_.arm_swing_gain, 0);
      arm_l = wave(t, period_, kPi * 1.5, x_move_ * p_.arm_swing_gain, 0);
    }

    if (real_running_) {
      time_ += kTimeUnitMs;
      if (time_ >= period_) time_ = 0;
    }

    std::array<double, 6> r{}, l{};
    if (!leg(right, r) || !leg(left, l)) return;  // out of reach: the goals stay as they were

    // Joint directions (servo counts per IK angle) in the order hip yaw, hip roll, hip pitch, knee,
    // ankle pitch, ankle roll; right leg IDs 7, 9, ..., 17, left 8, 10, ..., 18.
    constexpr std::array<int, 6> dir_r{-1, -1, 1, 1, -1, 1}, dir_l{-1, -1, -1, -1, 1, 1};
    auto value = [](int dir, double deg, double extra) {
      return 2048 + static_cast<int>(dir * deg * kCountsPerDeg + extra);
    };
    std::array<int, 6> out_r{}, out_l{};
    for (int j = 0; j < 6; ++j) {
      double extra_r = 0, extra_l = 0;
      if (j == 1) extra_r = dir_r[j] * pelvis_r, extra_l = dir_l[j] * pelvis_l;
      if (j == 2) {
        extra_r = -dir_r[j] * p_.hip_pitch_offset * kCountsPerDeg;
        extra_l = -dir_l[j] * p_.hip_pitch_offset * kCountsPerDeg;
      }
      out_r[j] = value(dir_r[j], r[j], extra_r);
      out_l[j] = value(dir_l[j], l[j], extra_l);
    }
    // Gyro balance: hip rolls and ankle rolls against the roll rate, knees and ankle pitches
    // against the pitch rate (4 counts per count of gain).
    const double rl = rl_gyro, fb = fb_gyro;
    out_r[1] += static_cast<int>(dir_r[1] * rl * p_.balance_hip_roll * 4);
    out_l[1] += static_cast<int>(dir_l[1] * rl * p_.balance_hip_roll * 4);
    out_r[3] -= static_cast<int>(dir_r[3] * fb * p_.balance_knee * 4);
    out_l[3] -= static_cast<int>(dir_l[3] * fb * p_.balance_knee * 4);
    out_r[4] -= static_cast<int>(dir_r[4] * fb * p_.balance_ankle_pitch * 4);
    out_l[4] -= static_cast<int>(dir_l[4] * fb * p_.balance_ankle_pitch * 4);
    out_r[5] -= static_cast<int>(dir_r[5] * rl * p_.balance_ankle_roll * 4);
    out_l[5] -= static_cast<int>(dir_l[5] * rl * p_.balance_ankle_roll * 4);

    auto clamp = [](int v) { return v < 0 ? 0 : v > 4095 ? 4095 : v; };
    for (int j = 0; j < 6; ++j) {
      goals_[7 + 2 * j] = clamp(out_r[j]);
      goals_[8 + 2 * j] = clamp(out_l[j]);
    }
    // Arms: Walking's standing angles, the shoulder pitches swinging with the step.
    goals_[1] = clamp(angle_to_value(-48.345) + static_cast<int>(arm_r * kCountsPerDeg));
    goals_[2] = clamp(angle_to_value(41.313) + static_cast<int>(-arm_l * kCountsPerDeg));
    goals_[3] = angle_to_value(-17.873);
    goals_[4] = angle_to_value(17.580);
    goals_[5] = angle_to_value(29.300);
    goals_[6] = angle_to_value(-29.593);
  }

  // Walking's leg inverse kinematics for a flat sole at (x, y, z) mm from the point 219.5 mm below
  // the hip (z up) turned by yaw (rad): hip yaw, roll, pitch, knee, ankle pitch, ankle roll in
  // degrees, in the framework's senses (knee + bends, hip pitch + swings the leg back). The knee
  // and the ankle roll are exact. The hip angles are not: the framework's Matrix3D product starts
  // its sum from the identity (Matrix.cpp, operator*), so the hip-to-ankle rotation it decomposes
  // is I + Rz(yaw) Rx(-ankle roll). On the robot that gives about half the commanded hip yaw and
  // half the ankle roll at the hip; the servos get those values, so Doppel's tests send them too.
  static bool leg(const Foot& f, std::array<double, 6>& out) {
    // Its degree conversions: 180 / 3.14159265 one way, 3.141592 / 180 the other.
    const double eff = 3.141592 / kPi;
    const double px = f.x, py = f.y, pz = f.z - kLeg;
    const double c = std::cos(f.yaw * eff), s = std::sin(f.yaw * eff);
    // The ankle axes' crossing point (the sole is level: 33.5 mm straight up from it).
    const double vx = px, vy = py, vz = pz + kAnkle;
    const double cos_knee = (vx * vx + vy * vy + vz * vz - kThigh * kThigh - kCalf * kCalf) / (2 * kThigh * kCalf);
    if (!(cos_knee >= -1.0 && cos_knee <= 1.0)) return false;
    const double knee = std::acos(cos_knee);
    // Ankle roll: the hip seen from the sole point, in the foot's y-z plane.
    const double hy = s * px - c * py, hz = -pz;
    const double k = std::sqrt(hy * hy + hz * hz), l = std::sqrt(hy * hy + (hz - kAnkle) * (hz - kAnkle));
    const double m = std::clamp((k * k - l * l - kAnkle * kAnkle) / (2 * l * kAnkle), -1.0, 1.0);
    const double ankle_roll = hy < 0.0 ? -std::acos(m) : std::acos(m);
    const double cr = std::cos(ankle_roll * eff), sr = std::sin(ankle_roll * eff);
    // I + Rz(yaw) Rx(-ankle roll): the entries the decomposition reads.
    const double m0 = c + 1, m1 = -s * cr, m2 = -s * sr, m4 = s, m5 = c * cr + 1, m6 = c * sr, m9 = -sr;
    const double yaw = std::atan2(-m1, m5);
    const double cy = std::cos(yaw), sy = std::sin(yaw);
    const double roll = std::atan2(m9, -m1 * sy + m5 * cy);
    const double theta = std::atan2(m2 * cy + m6 * sy, m0 * cy + m4 * sy);
    const double a = std::sin(knee) * kCalf, b = -kThigh - std::cos(knee) * kCalf;
    const double along = cy * vx + sy * vy;
    const double down = std::cos(roll) * vz + sy * std::sin(roll) * vx - cy * std::sin(roll) * vy;
    const double sp = (a * down + b * along) / (a * a + b * b);
    const double hip_pitch = std::atan2(sp, (down - a * sp) / b);
    const double to_deg = 180.0 / kPi;
    out = {yaw * to_deg, roll * to_deg, hip_pitch * to_deg, knee * to_deg, (theta - knee - hip_pitch) * to_deg,
           ankle_roll * to_deg};
    return true;
  }

  Parameters p_;
  double time_ = 0;
  bool ctrl_running_ = false, real_running_ = false;
  double period_ = 0, x_swap_period_ = 0, x_move_period_ = 0, y_swap_period_ = 0, z_swap_period_ = 0,
         z_move_period_ = 0, a_move_period_ = 0;
  double ssp_start_l_ = 0, ssp_end_l_ = 0, ssp_start_r_ = 0, ssp_end_r_ = 0, phase1_ = 0, phase2_ = 0, phase3_ = 0;
  double pelvis_offset_ = 0, pelvis_swing_ = 0;
  double x_move_ = 0, x_swap_ = 0, y_move_ = 0, y_swap_ = 0, z_move_ = 0, a_move_ = 0;
  Goals goals_{};
};

}  // namespace doppel::testing::darwin_walking
