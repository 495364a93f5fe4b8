// doppel-walk: the reference walk for the FUmanoid 2011 robot (robots/fumanoid-2011.textproto),
// written as a team's robot code would be: it knows the robot only through its serial port, speaks
// Protocol 1.0 with its own small client, reads the IMU and SYNC WRITEs goal positions once per IMU
// sample. Its clock is the IMU's Sample Counter (simulation time), never the wall clock.
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

constexpr uint8_t kImuId = 100;
constexpr uint8_t kImuSamplePeriodMs = 10;  // written to the IMU's Sample Period (addr 6): 100 Hz
constexpr double kUnitsPerRad = 195.57;     // AX/RX: 1024 units over 300 deg, 512 = 0 rad
constexpr double kFallTiltRad = 0.8;        // IMU pitch or roll beyond this: the robot fell

// Servo IDs of the figure's links and their mounting (`reversed`: right side mirrored).
struct Servo {
  uint8_t id;
  int direction;
};
// Legs in the gait's order: left yaw, roll, pitch, knee, ankle pitch, ankle roll; then right.
constexpr std::array<Servo, 12> kLegs = {{{9, 1}, {13, 1}, {11, 1}, {15, 1}, {19, 1}, {17, 1},
                                          {10, -1}, {14, -1}, {12, -1}, {16, -1}, {20, -1}, {18, -1}}};
// Head pitch/yaw, waist, shoulders and elbows: held at their design angle (arms slightly out).
constexpr std::array<Servo, 9> kUpper = {{{1, 1}, {2, 1}, {21, 1}, {3, 1}, {4, -1}, {5, 1}, {6, -1}, {7, 1}, {8, -1}}};
constexpr std::array<double, 9> kUpperRad = {0, 0, 0, 0, 0, 0.15, -0.15, 0, 0};
// The robot file's initial pose (hip -15, knee 30, ankle -15 deg), where the handler holds it.
constexpr double kDeg = 3.14159265358979323846 / 180;
constexpr walk::LegJoints kInitialLegs = {0, 0, -15 * kDeg, 30 * kDeg, -15 * kDeg, 0,
                                          0, 0, -15 * kDeg, 30 * kDeg, -15 * kDeg, 0};

int16_t le16(const uint8_t* p) { return static_cast<int16_t>(p[0] | (p[1] << 8)); }

uint16_t to_units(double rad, int direction) {
  const double units = 512 + direction * rad * kUnitsPerRad;
  return static_cast<uint16_t>(std::lround(std::fmin(1023.0, std::fmax(0.0, units))));
}

class Robot {
 public:
  Robot(walk::Protocol1Client& bus) : bus_(bus) {
    for (std::size_t i = 0; i < kLegs.size(); ++i) ids_[i] = kLegs[i].id;
    for (std::size_t i = 0; i < kUpper.size(); ++i) ids_[kLegs.size() + i] = kUpper[i].id;
  }
  // SYNC WRITE of all 21 goal positions (addr 30, 2 bytes each).
  void send_goals(const walk::LegJoints& legs) {
    for (std::size_t i = 0; i < kLegs.size(); ++i) put(i, to_units(legs[i], kLegs[i].direction));
    for (std::size_t i = 0; i < kUpper.size(); ++i) put(kLegs.size() + i, to_units(kUpperRad[i], kUpper[i].direction));
    bus_.sync_write(30, 2, ids_, goals_);
  }
  // SYNC WRITE of one byte to every servo.
  void send_byte(uint8_t address, uint8_t value) {
    std::array<uint8_t, kCount> data;
    data.fill(value);
    bus_.sync_write(address, 1, ids_, data);
  }

 private:
  static constexpr std::size_t kCount = kLegs.size() + kUpper.size();
  void put(std::size_t i, uint16_t units) {
    goals_[2 * i] = static_cast<uint8_t>(units & 0xFF);
    goals_[2 * i + 1] = static_cast<uint8_t>(units >> 8);
  }
  walk::Protocol1Client& bus_;
  std::array<uint8_t, kCount> ids_{};
  std::array<uint8_t, 2 * kCount> goals_{};
};

struct ImuSample {
  walk::ImuReading reading;
  uint16_t counter = 0;
};

ImuSample read_imu(walk::Protocol1Client& bus) {
  std::array<uint8_t, 24> raw{};  // addr 26..49: pitch, roll, yaw, gyro xyz, accel xyz, ..., Sample Counter
  for (int attempt = 0; attempt < 5; ++attempt) {
    if (bus.read(kImuId, 26, raw)) {
      ImuSample s;
      s.reading.pitch = le16(&raw[0]) * 1e-4;
      s.reading.roll = le16(&raw[2]) * 1e-4;
      s.reading.gyro_x = le16(&raw[6]) * 1e-3;
      s.reading.gyro_y = le16(&raw[8]) * 1e-3;
      s.counter = static_cast<uint16_t>(raw[22] | (raw[23] << 8));
      return s;
    }
  }
  throw std::runtime_error("the IMU (ID 100) does not answer READ 26..49");
}

double smooth(double x) {  // 0..1 -> 0..1 with zero slope at both ends
  x = std::fmin(1.0, std::fmax(0.0, x));
  return x * x * (3 - 2 * x);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("doppel-walk: the reference walk for the FUmanoid 2011 robot, through its serial port only", "doppel-walk");
  std::string port;
  double seconds = 30, speed = 0.05, turn = 0;
  walk::GaitParameters params;
  bool verbose = false;
  app.add_option("--port", port, "the robot's serial port (doppel's link, e.g. /tmp/doppel/ttyDXL0)")->required();
  app.add_option("--seconds", seconds, "simulated seconds to run, stand-up and stop included")
      ->capture_default_str()->transform(doppel::number_in<double>(1, 3600));
  app.add_option("--speed", speed, "forward speed, m/s")->capture_default_str()->transform(doppel::number_in<double>(-0.2, 0.2));
  app.add_option("--turn", turn, "turn rate, rad/s (+ = left)")->capture_default_str()->transform(doppel::number_in<double>(-1, 1));
  app.add_option("--period", params.period_s, "gait cycle, s")->capture_default_str()->transform(doppel::number_in<double>(0.2, 2));
  app.add_option("--sway", params.sway_m, "lateral sway, m")->capture_default_str()->transform(doppel::number_in<double>(0, 0.06));
  app.add_option("--lift", params.lift_m, "foot lift, m")->capture_default_str()->transform(doppel::number_in<double>(0, 0.06));
  app.add_option("--height", params.hip_height_m, "hip height, m")->capture_default_str()->transform(doppel::number_in<double>(0.2, 0.265));
  app.add_option("--lean", params.trunk_pitch_rad, "trunk lean, rad")->capture_default_str()->transform(doppel::number_in<double>(-0.3, 0.3));
  app.add_option("--foot-x", params.foot_x_m, "feet forward of hips, m")->capture_default_str()->transform(doppel::number_in<double>(-0.05, 0.05));
  app.add_option("--foot-y", params.foot_y_m, "extra foot spread, m")->capture_default_str()->transform(doppel::number_in<double>(-0.02, 0.05));
  app.add_option("--sway-lead", params.sway_lead, "sway phase lead, rad")->capture_default_str()->transform(doppel::number_in<double>(-1.5, 1.5));
  app.add_option("--gyro-pitch", params.gyro_pitch_gain, "ankle pitch per rad/s")->capture_default_str();
  app.add_option("--gyro-roll", params.gyro_roll_gain, "ankle roll per rad/s")->capture_default_str();
  app.add_option("--tilt-pitch", params.tilt_pitch_gain, "ankle pitch per rad")->capture_default_str();
  app.add_option("--tilt-roll", params.tilt_roll_gain, "hip roll per rad")->capture_default_str();
  int slope = 16;
  app.add_option("--slope", slope, "RX compliance slope of every servo")->capture_default_str()->check(CLI::IsMember({2, 4, 8, 16, 32, 64, 128}));
  app.add_flag("--verbose", verbose, "print the IMU every simulated second");
  CLI11_PARSE(app, argc, argv);

  try {
    walk::Protocol1Client bus(port, 1000000);
    Robot robot(bus);
    const uint8_t period = kImuSamplePeriodMs;
    if (!bus.write(kImuId, 6, std::span<const uint8_t>(&period, 1))) {
      throw std::runtime_error("the IMU (ID 100) refused its Sample Period (addr 6)");
    }
    ImuSample imu = read_imu(bus);
    // Stiffer than the factory compliance slope 32, as walking needs; goals at the held pose, then
    // torque on for every servo at once (the handler lets go when all have torque).
    robot.send_byte(28, static_cast<uint8_t>(slope));
    robot.send_byte(29, static_cast<uint8_t>(slope));
    robot.send_goals(kInitialLegs);
    robot.send_byte(24, 1);

    walk::Gait gait(walk::LegGeometry{}, params);
    // Where the gait stands (amplitude 0): found once for the blend from the held pose.
    walk::Gait stance(walk::LegGeometry{}, params);
    stance.step(0, 0, 0, 0, {});
    constexpr double kStandUpS = 1.0, kRampS = 1.0;
    double t = 0;
    uint16_t last_counter = imu.counter;
    int next_report = 1;
    while (t < seconds) {
      imu = read_imu(bus);
      const uint16_t elapsed = static_cast<uint16_t>(imu.counter - last_counter);
      if (elapsed == 0) {
        std::this_thread::sleep_for(std::chrono::milliseconds(1));  // polling pace only; the clock is the IMU
        continue;
      }
      last_counter = imu.counter;
      const double dt = elapsed * kImuSamplePeriodMs * 1e-3;
      t += dt;
      if (std::fabs(imu.reading.pitch) > kFallTiltRad || std::fabs(imu.reading.roll) > kFallTiltRad) {
        std::printf("doppel-walk: fell at %.2f s (IMU pitch %.2f roll %.2f rad)\n", t, imu.reading.pitch, imu.reading.roll);
        return 3;
      }
      walk::LegJoints goals;
      if (t < kStandUpS) {
        const double k = smooth(t / kStandUpS);
        for (std::size_t i = 0; i < goals.size(); ++i) goals[i] = (1 - k) * kInitialLegs[i] + k * stance.joints()[i];
      } else {
        const double walking = t - kStandUpS;
        const double amplitude = smooth(walking / kRampS) * smooth((seconds - t) / kRampS);
        gait.step(dt, speed, turn, amplitude, imu.reading);
        goals = gait.joints();
      }
      robot.send_goals(goals);
      if (verbose && t >= next_report) {
        std::printf("t %.2f s  pitch %+.3f roll %+.3f  gyro x %+.2f y %+.2f\n", t, imu.reading.pitch, imu.reading.roll,
                    imu.reading.gyro_x, imu.reading.gyro_y);
        ++next_report;
      }
    }
    std::printf("doppel-walk: %.2f s of simulation time, speed %.3f m/s, turn %.3f rad/s, standing\n", t, speed, turn);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "doppel-walk: %s\n", error.what());
    return 2;
  }
  return 0;
}
