// doppel-walk: the reference walk for the FUmanoid 2011 robot (data/robots/fumanoid-2011.textproto)
// and the DARwIn-OP (data/robots/darwin-op.textproto, `--robot darwin-op`),
// written as a team's robot code would be: it knows the robot only through its serial port, speaks
// Protocol 1.0 with its own small client, reads the IMU and SYNC WRITEs goal positions once per IMU
// sample. Its clock is the FUMANOID-IMU's Sample Counter (simulation time); the DARwIn-OP's CM-730 has
// none, so there it paces by an 8 ms wall-clock cycle as the DARwIn-OP framework does.
// docs/walk.md explains the gait and what it achieves.
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <thread>

#include "base/command_line.h"
#include "gait.h"
#include "protocol1_client.h"

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180;
constexpr double kFallTiltRad = 0.8;  // IMU pitch or roll beyond this: the robot fell
// READ attempts of 100 ms before the walk gives up: rides out a loaded machine stalling for 2 s.
constexpr int kReadAttempts = 20;

// One servo of a figure link: goal units = centre + (offset + sign x link angle) x units per rad.
// sign -1 where the robot file's motor is `reversed`; offset = the file's `offset_deg`.
struct Servo {
  uint8_t id;
  int sign;
  double offset_rad = 0;
};

// What the walk knows of a robot: its leg geometry, servo IDs and mounting, the pose the robot
// file's handler holds it in, the servos' position scale and the IMU it has.
struct RobotConfig {
  const char* name;
  walk::LegGeometry leg;
  // Legs in the gait's order: left yaw, roll, pitch, knee, ankle pitch, ankle roll; then right.
  std::array<Servo, 12> legs;
  std::array<Servo, 9> upper;           // held at upper_rad; `upper_count` of them used
  std::array<double, 9> upper_rad;
  std::size_t upper_count;
  walk::LegJoints initial;              // the robot file's initial pose (link angles)
  double units_per_rad, centre_units, max_units;
  uint8_t p_gain_address;               // 0: RX compliance slopes (28/29) instead
  walk::GaitParameters gait;            // this robot's defaults
};

// FUmanoid 2011 (data/robots/fumanoid-2011.textproto): RX/AX servos, 1024 units over 300 deg, 512 = 0,
// the right side mirrored; initial pose hip -15, knee 30, ankle -15 deg.
RobotConfig fumanoid() {
  RobotConfig r{};
  r.name = "fumanoid";
  r.leg = walk::LegGeometry{};
  r.legs = {{{9, 1}, {13, 1}, {11, 1}, {15, 1}, {19, 1}, {17, 1},
             {10, -1}, {14, -1}, {12, -1}, {16, -1}, {20, -1}, {18, -1}}};
  // Head pitch/yaw, waist, shoulders and elbows: held at their design angle (arms slightly out).
  r.upper = {{{1, 1}, {2, 1}, {21, 1}, {3, 1}, {4, -1}, {5, 1}, {6, -1}, {7, 1}, {8, -1}}};
  r.upper_rad = {0, 0, 0, 0, 0, 0.15, -0.15, 0, 0};
  r.upper_count = 9;
  r.initial = {0, 0, -15 * kDeg, 30 * kDeg, -15 * kDeg, 0, 0, 0, -15 * kDeg, 30 * kDeg, -15 * kDeg, 0};
  r.units_per_rad = 1024 / (300 * kDeg);
  r.centre_units = 512;
  r.max_units = 1023;
  r.p_gain_address = 0;
  return r;
}

// DARwIn-OP (data/robots/darwin-op.textproto, which cites its sources): MX-28s, 4096 units per turn,
// 2048 = servo 0. Legs: Kinematics.cpp's THIGH = CALF = 93 mm, ANKLE 33.5 mm, LEG_SIDE_OFFSET
// 37 mm; hip axes 219.5 mm above the soles in the design pose (legs straight and plumb, the trunk
// 12.92 deg forward, so the hip pitch servos read -+12.92 deg at link 0). Signs and offsets are the
// file's `reversed` / `offset_deg`; the initial pose is its walk-ready pose (initial_deg).
RobotConfig darwin_op() {
  RobotConfig r{};
  r.name = "darwin-op";
  r.leg = walk::LegGeometry{0.093, 0.093, 0.0335, 0.2195, 0.037};
  r.legs = {{{8, -1}, {10, -1}, {12, -1, 12.92 * kDeg}, {14, -1}, {16, 1}, {18, 1},
             {7, -1}, {9, -1}, {11, 1, -12.92 * kDeg}, {13, 1}, {15, -1}, {17, 1}}};
  // Head pan, tilt; left shoulder pitch, roll, elbow; right the same: the walk-ready angles.
  r.upper = {{{19, 1}, {20, -1, 40 * kDeg}, {2, 1}, {4, -1, 45 * kDeg}, {6, 1, 90 * kDeg},
              {1, -1}, {3, -1, -45 * kDeg}, {5, -1, -90 * kDeg}, {0, 0}}};
  r.upper_rad = {0, 30.07 * kDeg, 41.31 * kDeg, 27.42 * kDeg, -119.53 * kDeg,
                 48.34 * kDeg, -27.16 * kDeg, -119.27 * kDeg, 0};
  r.upper_count = 8;
  r.initial = {0, 0.35 * kDeg, -23.2 * kDeg, 53.17 * kDeg, -29.97 * kDeg, -0.79 * kDeg,
               0, -0.35 * kDeg, -23.2 * kDeg, 53.17 * kDeg, -29.97 * kDeg, 0.79 * kDeg};
  r.units_per_rad = 4096 / (2 * kPi);
  r.centre_units = 2048;
  r.max_units = 4095;
  r.p_gain_address = 28;  // MX P Gain
  // Walking.cpp's defaults (period 600 ms, hip 20 mm below straight legs, feet 5 mm wider); sway
  // and lift smaller than its Y swing 20 / Z 40 mm, which rocked this gait's sinusoids over on
  // the model (docs/walk.md).
  r.gait.period_s = 0.6;
  r.gait.hip_height_m = 0.1995;
  r.gait.lift_m = 0.02;
  r.gait.sway_m = 0.012;
  r.gait.foot_y_m = 0.005;
  // Its roll comes from the accelerometer, which the sway swings by about 0.3 rad: no roll angle
  // feedback; nor the default robot's pelvis lift (not tuned on this robot).
  r.gait.tilt_roll_gain = 0;
  r.gait.pelvis_roll_rad = 0;
  r.gait.stride_scale = 0.8;  // measured (docs/walk.md): 0.64 and 0.75 walked short of the commanded distance
  return r;
}

int16_t le16(const uint8_t* p) { return static_cast<int16_t>(p[0] | (p[1] << 8)); }

class Robot {
 public:
  Robot(walk::Protocol1Client& bus, const RobotConfig& config) : bus_(bus), c_(config) {
    count_ = c_.legs.size() + c_.upper_count;
    for (std::size_t i = 0; i < c_.legs.size(); ++i) ids_[i] = c_.legs[i].id;
    for (std::size_t i = 0; i < c_.upper_count; ++i) ids_[c_.legs.size() + i] = c_.upper[i].id;
  }
  // SYNC WRITE of all goal positions (addr 30, 2 bytes each).
  void send_goals(const walk::LegJoints& legs) {
    for (std::size_t i = 0; i < c_.legs.size(); ++i) put(i, to_units(legs[i], c_.legs[i]));
    for (std::size_t i = 0; i < c_.upper_count; ++i) put(c_.legs.size() + i, to_units(c_.upper_rad[i], c_.upper[i]));
    bus_.sync_write(30, 2, std::span(ids_.data(), count_), std::span(goals_.data(), 2 * count_));
  }
  // SYNC WRITE of one byte to every servo.
  void send_byte(uint8_t address, uint8_t value) {
    std::array<uint8_t, kMax> data;
    data.fill(value);
    bus_.sync_write(address, 1, std::span(ids_.data(), count_), std::span(data.data(), count_));
  }

 private:
  static constexpr std::size_t kMax = 21;
  uint16_t to_units(double rad, const Servo& s) const {
    const double units = c_.centre_units + (s.offset_rad + s.sign * rad) * c_.units_per_rad;
    return static_cast<uint16_t>(std::lround(std::fmin(c_.max_units, std::fmax(0.0, units))));
  }
  void put(std::size_t i, uint16_t units) {
    goals_[2 * i] = static_cast<uint8_t>(units & 0xFF);
    goals_[2 * i + 1] = static_cast<uint8_t>(units >> 8);
  }
  walk::Protocol1Client& bus_;
  const RobotConfig& c_;
  std::size_t count_ = 0;
  std::array<uint8_t, kMax> ids_{};
  std::array<uint8_t, 2 * kMax> goals_{};
};

// FUmanoid: the FUMANOID-IMU (ID 100), sampled every 10 ms; its Sample Counter is the clock.
constexpr uint8_t kImuId = 100;
constexpr uint8_t kImuSamplePeriodMs = 10;  // written to the IMU's Sample Period (addr 6): 100 Hz

struct ImuSample {
  walk::ImuReading reading;
  uint16_t counter = 0;
};

ImuSample read_imu(walk::Protocol1Client& bus) {
  std::array<uint8_t, 24> raw{};  // addr 26..49: pitch, roll, yaw, gyro xyz, accel xyz, ..., Sample Counter
  for (int attempt = 0; attempt < kReadAttempts; ++attempt) {
    if (bus.read(kImuId, 26, raw)) {
      ImuSample s;
      s.reading.pitch = le16(&raw[0]) * 1e-4;
      s.reading.roll = le16(&raw[2]) * 1e-4;
      s.reading.yaw = le16(&raw[4]) * 1e-4;
      s.reading.gyro_x = le16(&raw[6]) * 1e-3;
      s.reading.gyro_y = le16(&raw[8]) * 1e-3;
      s.reading.gyro_z = le16(&raw[10]) * 1e-3;
      s.counter = static_cast<uint16_t>(raw[22] | (raw[23] << 8));
      return s;
    }
  }
  throw std::runtime_error("the IMU (ID 100) does not answer READ 26..49");
}

// FUmanoid: the foot boards (ID 101 left, 102 right), Force Total (addr 34, 0.01 N); -1 when one
// does not answer.
void read_feet(walk::Protocol1Client& bus, walk::ImuReading& out) {
  double* loads[2] = {&out.load_left_n, &out.load_right_n};
  for (int foot = 0; foot < 2; ++foot) {
    std::array<uint8_t, 2> raw{};
    *loads[foot] = bus.read(static_cast<uint8_t>(101 + foot), 34, raw) ? (raw[0] | (raw[1] << 8)) * 0.01 : -1;
  }
}

// DARwIn-OP: the CM-730 (ID 200). Gyro Z/Y/X at 38/40/42, ACC X/Y/Z at 44/46/48, 10 bit with 512
// at zero; gyro 1600 deg/s and ACC 4 g over 512 counts (docs/devices.md, CM-730). Its ACC axes: X
// right, Y forward, Z up; gyro X back, Y right, Z up. So the trunk's roll rate (+ right side down,
// about forward) is -Gyro X, its pitch rate (+ nose down, about left) -Gyro Y and its yaw rate
// (+ left) Gyro Z; the tilts come from the accelerometer (nose down: ACC Y < 512; right side down: ACC X < 512).
constexpr uint8_t kCm730Id = 200;
walk::ImuReading read_cm730(walk::Protocol1Client& bus) {
  std::array<uint8_t, 12> raw{};
  for (int attempt = 0; attempt < kReadAttempts; ++attempt) {
    if (bus.read(kCm730Id, 38, raw)) {
      const auto counts = [&](int i) { return static_cast<double>(le16(&raw[2 * i])) - 512; };
      constexpr double kGyro = 1600.0 / 512 * kDeg;  // rad/s per count
      walk::ImuReading r;
      r.gyro_x = -counts(2) * kGyro;
      r.gyro_y = -counts(1) * kGyro;
      r.gyro_z = counts(0) * kGyro;
      const double ax = counts(3), ay = counts(4), az = counts(5);
      r.pitch = std::atan2(-ay, az);
      r.roll = std::atan2(-ax, az);
      return r;
    }
  }
  throw std::runtime_error("the CM-730 (ID 200) does not answer READ 38..49");
}

double smooth(double x) {  // 0..1 -> 0..1 with zero slope at both ends
  x = std::fmin(1.0, std::fmax(0.0, x));
  return x * x * (3 - 2 * x);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("doppel-walk: the reference walk for the FUmanoid 2011 and DARwIn-OP robots, through their serial port only",
               "doppel-walk");
  std::string port, robot_name = "fumanoid";
  double seconds = 30, speed = 0.05, turn = 0;
  walk::GaitParameters params;
  bool verbose = false;
  std::string log_path;
  app.add_option("--port", port, "the robot's serial port (doppel's link, e.g. /tmp/doppel/ttyDXL0)")->required();
  app.add_option("--robot", robot_name, "the robot: fumanoid (data/robots/fumanoid-2011) or darwin-op (data/robots/darwin-op)")
      ->capture_default_str()->check(CLI::IsMember({"fumanoid", "darwin-op"}));
  app.add_option("--seconds", seconds, "seconds to run, stand-up and stop included (simulated; the DARwIn-OP paces by the wall clock)")
      ->capture_default_str()->transform(doppel::number_in<double>(1, 3600));
  app.add_option("--speed", speed, "forward speed, m/s")->capture_default_str()->transform(doppel::number_in<double>(-0.2, 0.2));
  app.add_option("--turn", turn, "turn rate, rad/s (+ = left)")->capture_default_str()->transform(doppel::number_in<double>(-1, 1));
  app.add_option("--period", params.period_s, "gait cycle, s")->transform(doppel::number_in<double>(0.2, 2));
  app.add_option("--sway", params.sway_m, "lateral sway, m")->transform(doppel::number_in<double>(0, 0.06));
  app.add_option("--lift", params.lift_m, "foot lift, m")->transform(doppel::number_in<double>(0, 0.06));
  app.add_option("--height", params.hip_height_m, "hip height, m")->transform(doppel::number_in<double>(0.15, 0.265));
  app.add_option("--lean", params.trunk_pitch_rad, "trunk lean, rad")->transform(doppel::number_in<double>(-0.3, 0.3));
  app.add_option("--foot-x", params.foot_x_m, "feet forward of hips, m")->transform(doppel::number_in<double>(-0.05, 0.05));
  app.add_option("--foot-y", params.foot_y_m, "extra foot spread, m")->transform(doppel::number_in<double>(-0.02, 0.05));
  app.add_option("--sway-lead", params.sway_lead, "sway phase lead, rad")->transform(doppel::number_in<double>(-1.5, 1.5));
  app.add_option("--gyro-pitch", params.gyro_pitch_gain, "ankle pitch per rad/s");
  app.add_option("--gyro-roll", params.gyro_roll_gain, "ankle roll per rad/s");
  app.add_option("--tilt-pitch", params.tilt_pitch_gain, "ankle pitch per rad");
  app.add_option("--tilt-roll", params.tilt_roll_gain, "hip roll per rad");
  app.add_option("--reach", params.reach_gain, "high side's foot lowered per rad of roll beyond the deadband, m/rad");
  app.add_option("--pelvis", params.pelvis_roll_rad, "stance hip roll outward in single support, rad");
  app.add_option("--heading-gain", params.heading_gain, "turn rate per rad of heading error");
  app.add_option("--stride-scale", params.stride_scale, "stride per commanded speed x period");
  int slope = 16, p_gain = 32;  // p_gain: the DARwIn-OP framework's walking gain (JointData::P_GAIN_DEFAULT)
  double max_gait_step = 0.02;
  app.add_option("--max-gait-step", max_gait_step, "the gait advances at most this many seconds per control cycle")->capture_default_str();
  app.add_option("--slope", slope, "fumanoid: RX compliance slope of every servo")->capture_default_str()
      ->check(CLI::IsMember({2, 4, 8, 16, 32, 64, 128}));
  app.add_option("--p-gain", p_gain, "darwin-op: MX-28 P gain of every servo")->capture_default_str()
      ->transform(doppel::number_in<int>(1, 254));
  app.add_flag("--verbose", verbose, "print the IMU every second");
  app.add_option("--log", log_path, "write every control cycle (time, phase, amplitude, IMU, foot forces) to this CSV file");
  CLI11_PARSE(app, argc, argv);

  const bool darwin = robot_name == "darwin-op";
  const RobotConfig config = darwin ? darwin_op() : fumanoid();
  {
    // The robot's gait defaults, for every gait option not given.
    walk::GaitParameters given = params;
    params = config.gait;
    const auto keep = [&](const char* name, double& field, double value) {
      if (app.count(name) > 0) field = value;
    };
    keep("--period", params.period_s, given.period_s);
    keep("--sway", params.sway_m, given.sway_m);
    keep("--lift", params.lift_m, given.lift_m);
    keep("--height", params.hip_height_m, given.hip_height_m);
    keep("--lean", params.trunk_pitch_rad, given.trunk_pitch_rad);
    keep("--foot-x", params.foot_x_m, given.foot_x_m);
    keep("--foot-y", params.foot_y_m, given.foot_y_m);
    keep("--sway-lead", params.sway_lead, given.sway_lead);
    keep("--gyro-pitch", params.gyro_pitch_gain, given.gyro_pitch_gain);
    keep("--gyro-roll", params.gyro_roll_gain, given.gyro_roll_gain);
    keep("--tilt-pitch", params.tilt_pitch_gain, given.tilt_pitch_gain);
    keep("--tilt-roll", params.tilt_roll_gain, given.tilt_roll_gain);
    keep("--reach", params.reach_gain, given.reach_gain);
    keep("--pelvis", params.pelvis_roll_rad, given.pelvis_roll_rad);
    keep("--heading-gain", params.heading_gain, given.heading_gain);
    keep("--stride-scale", params.stride_scale, given.stride_scale);
  }

  try {
    walk::Protocol1Client bus(port, 1000000);
    Robot robot(bus, config);
    walk::ImuReading imu;
    uint16_t last_counter = 0;
    using Clock = std::chrono::steady_clock;
    constexpr auto kCycle = std::chrono::milliseconds(8);  // the DARwIn-OP framework's motion timer
    if (darwin) {
      // As the framework's CM730::Connect(): Dynamixel Power on, then give the supply 300 ms.
      const uint8_t on = 1;
      if (!bus.write(kCm730Id, 24, std::span<const uint8_t>(&on, 1))) {
        throw std::runtime_error("the CM-730 (ID 200) refused Dynamixel Power (addr 24)");
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(300));
      imu = read_cm730(bus);
      robot.send_byte(config.p_gain_address, static_cast<uint8_t>(p_gain));
    } else {
      const uint8_t period = kImuSamplePeriodMs;
      if (!bus.write(kImuId, 6, std::span<const uint8_t>(&period, 1))) {
        throw std::runtime_error("the IMU (ID 100) refused its Sample Period (addr 6)");
      }
      const ImuSample sample = read_imu(bus);
      imu = sample.reading;
      last_counter = sample.counter;
      // Stiffer than the factory compliance slope 32, as walking needs.
      robot.send_byte(28, static_cast<uint8_t>(slope));
      robot.send_byte(29, static_cast<uint8_t>(slope));
    }
    // Goals at the held pose, then torque on for every servo at once (the handler lets go when all
    // have torque).
    robot.send_goals(config.initial);
    robot.send_byte(24, 1);

    std::FILE* log = nullptr;
    if (!log_path.empty()) {
      log = std::fopen(log_path.c_str(), "w");
      if (log == nullptr) throw std::runtime_error("cannot write the log " + log_path);
      std::fprintf(log, "t,phase,amplitude,pitch,roll,yaw,gyro_x,gyro_y,gyro_z,force_left,force_right\n");
    }
    walk::Gait gait(config.leg, params);
    // Where the gait stands (amplitude 0): found once for the blend from the held pose.
    walk::Gait stance(config.leg, params);
    stance.step(0, 0, 0, 0, {});
    constexpr double kStandUpS = 1.0, kRampS = 1.0;
    double t = 0;
    int next_report = 1;
    auto next_cycle = Clock::now() + kCycle;
    while (t < seconds) {
      double dt = 0;
      if (darwin) {
        // No sample counter on the CM-730: a fixed 8 ms cycle on the wall clock, as the framework's
        // MotionManager timer (doppel runs the body in real time).
        std::this_thread::sleep_until(next_cycle);
        next_cycle += kCycle;
        if (Clock::now() > next_cycle) next_cycle = Clock::now() + kCycle;  // overrun: no catch-up burst
        const double yaw = imu.yaw;
        imu = read_cm730(bus);
        dt = 0.008;
        imu.yaw = std::remainder(yaw + imu.gyro_z * dt, 2 * kPi);  // no orientation on the CM-730: the gyro integrated
      } else {
        const ImuSample sample = read_imu(bus);
        const uint16_t elapsed = static_cast<uint16_t>(sample.counter - last_counter);
        if (elapsed == 0) {
          std::this_thread::sleep_for(std::chrono::milliseconds(1));  // polling pace only; the clock is the IMU
          continue;
        }
        last_counter = sample.counter;
        imu = sample.reading;
        read_feet(bus, imu);
        dt = elapsed * kImuSamplePeriodMs * 1e-3;
      }
      t += dt;
      if (std::fabs(imu.pitch) > kFallTiltRad || std::fabs(imu.roll) > kFallTiltRad) {
        std::printf("doppel-walk: fell at %.2f s (IMU pitch %.2f roll %.2f rad)\n", t, imu.pitch, imu.roll);
        return 3;
      }
      walk::LegJoints goals;
      if (t < kStandUpS) {
        const double k = smooth(t / kStandUpS);
        for (std::size_t i = 0; i < goals.size(); ++i) goals[i] = (1 - k) * config.initial[i] + k * stance.joints()[i];
      } else {
        const double walking = t - kStandUpS;
        const double amplitude = smooth(walking / kRampS) * smooth((seconds - t) / kRampS);
        // A client that missed samples (starved of CPU) lets the gait lag rather than jump ahead.
        gait.step(std::fmin(dt, max_gait_step), speed, turn, amplitude, imu);
        goals = gait.joints();
      }
      robot.send_goals(goals);
      if (log != nullptr) {
        const double amplitude = t < kStandUpS ? 0 : smooth((t - kStandUpS) / kRampS) * smooth((seconds - t) / kRampS);
        std::fprintf(log, "%.3f,%.3f,%.3f,%.4f,%.4f,%.4f,%.3f,%.3f,%.3f,%.2f,%.2f\n", t, gait.phase(), amplitude, imu.pitch,
                     imu.roll, imu.yaw, imu.gyro_x, imu.gyro_y, imu.gyro_z, imu.load_left_n, imu.load_right_n);
      }
      if (verbose && t >= next_report) {
        std::printf("t %.2f s  pitch %+.3f roll %+.3f  gyro x %+.2f y %+.2f\n", t, imu.pitch, imu.roll, imu.gyro_x, imu.gyro_y);
        ++next_report;
      }
    }
    std::printf("doppel-walk: %s, %.2f s, speed %.3f m/s, turn %.3f rad/s, standing\n", config.name, t, speed, turn);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "doppel-walk: %s\n", error.what());
    return 2;
  }
  return 0;
}
