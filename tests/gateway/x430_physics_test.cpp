// End-to-end with the body simulated on Protocol 2.0: the real doppel serving data/robots/fumanoid-x430
// (fumanoid-2011's body on 21 XM430-W350 over four 4 Mbps buses), driven and read back through the
// four ptys as a driver (p2_robot_buses.h, over tests/support/reference_client_p2.h). What it reads
// comes from the physics world through the Bit-Bots IMU (float32 quaternion, reference §8.2) and the BitFoot
// boards (int32 counts, docs/devices.md P7). ODE only, to keep the run short.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <thread>
#include <vector>

#include "doppel_process.h"
#include "held_pose.h"
#include "p2_robot_buses.h"
#include "reference_client.h"
#include "reference_client_p2.h"

namespace doppel::testing {
namespace {

constexpr uint32_t kBaud = 4000000;
constexpr double kRobotMassKg = 4.7;  // data/robots/fumanoid-x430.textproto: sum of its body masses
constexpr double kGravity = 9.80665;
// A held robot's servos stay within 7 position units (0.6 deg, 0.088 deg per unit) of their start.
constexpr int kHeldPositionUnits = 7;
// fumanoid-x430: servos per bus (ttyDXL0..3), the IMU on bus 0, left foot 102 on bus 2, right 101 on bus 3.
const std::vector<std::vector<uint8_t>> kServos = {{1, 2, 21}, {3, 4, 5, 6, 7, 8}, {9, 11, 13, 15, 17, 19},
                                                   {10, 12, 14, 16, 18, 20}};
constexpr uint8_t kImuId = 241;
constexpr uint16_t kPositionPGain = 84, kTorqueEnable = 64, kPresentCurrent = 126;  // XM430-W350 (reference §3.7)
// Position P Gain the driver sets before the torque goes on. With the factory 800 (Kp = 6.25 PWM
// units per pulse, about 19 N·m/rad per joint at 12 V) hip, knee and ankle in series per leg are
// softer than the 4.7 kg body's toppling stiffness (m g h, about 16 N·m/rad), so it sinks and falls,
// as a soft-tuned real robot would; humanoid drivers raise the gains.
constexpr uint16_t kStandingPGain = 1600;
constexpr uint8_t kCoreId = 42;                                 // BITBOTS-CORE on bus 0 (reference §8.4)
constexpr uint16_t kCoreCurrent = 34;                           // u16 raw ADC (reference §8.4)
constexpr double kXm430StallCurrentA = 2.3;                     // at 12 V (reference §5)

struct Pose {
  double pitch_deg = 0.0;
  double roll_deg = 0.0;
  double feet_n = 0.0;  // both BitFoot boards, all eight cells
};

class X430Body : public ::testing::Test {
 protected:
  X430Body(std::vector<std::string> extra = {}) : doppel_(args(std::move(extra)), "ttyDXL3"), buses_(doppel_, kBaud, kServos) {}
  static std::vector<std::string> args(std::vector<std::string> extra) {
    std::vector<std::string> a = {"--robot", "fumanoid-x430", "--physics", "ode", "--timing", "fast"};
    a.insert(a.end(), extra.begin(), extra.end());
    return a;
  }

  Bytes read(int b, uint8_t id, uint16_t address, uint16_t length) { return buses_.read(b, id, address, length); }

  // As a driver starting up: gains, then Torque Enable := 1 on all 21 servos.
  void torque_on() {
    for (int b = 0; b < 4; ++b) buses_.sync_write(b, kPositionPGain, 2, [](uint8_t) { return kStandingPGain; });
    for (int b = 0; b < 4; ++b) buses_.sync_write(b, kTorqueEnable, 1, [](uint8_t) { return 1; });
  }

  double foot_total_n(int b, uint8_t id) { return buses_.foot_total_n(b, id); }

  // The servos' supply current the CORE board measures, decoded as the Bit-Bots driver does.
  double core_current_a() {
    const Bytes raw = read(0, kCoreId, kCoreCurrent, 2);
    return raw.size() == 2 ? ((raw[0] | (raw[1] << 8)) * 3.3 / 1024.0 - 2.5) / -0.066 : 0.0;
  }

  Pose read_pose() {
    const RollPitch imu = buses_.imu_roll_pitch(0, kImuId);
    return Pose{imu.pitch_deg, imu.roll_deg, foot_total_n(2, 102) + foot_total_n(3, 101)};
  }

  std::vector<int32_t> read_positions() { return buses_.read_positions(); }

  // Simulation time from the first servo's Realtime Tick; gives up after 30 s.
  void wait_sim_time(double seconds) { buses_.wait_sim_time(seconds, 0, kServos[0][0], 30); }

  DoppelProcess doppel_;
  P2RobotBuses buses_;
};

TEST_F(X430Body, StandsWithTorqueOnAndTheFeetCarryItsWeight) {
  torque_on();
  // Straightening from the bent initial pose rocks the body on its ankles (about 1.3 Hz, lightly
  // damped with the factory Position D Gain 0); after 3 s the swing is within about 2 degrees.
  wait_sim_time(3.0);
  for (int b = 0; b < 4; ++b) {
    for (uint8_t id : kServos[static_cast<std::size_t>(b)]) {
      ASSERT_EQ(read(b, id, kTorqueEnable, 1), Bytes{1}) << "ID " << int(id);
      ASSERT_EQ(read(b, id, kPositionPGain, 2), le16(kStandingPGain)) << "ID " << int(id);
    }
  }
  const Pose pose = read_pose();
  // Standing upright: the IMU reads the body level (its 22° head mount is compensated in the file).
  EXPECT_LT(std::fabs(pose.pitch_deg), 5.0) << pose.pitch_deg;
  EXPECT_LT(std::fabs(pose.roll_deg), 5.0) << pose.roll_deg;
  EXPECT_NEAR(pose.feet_n, kRobotMassKg * kGravity, 0.1 * kRobotMassKg * kGravity);
  // Each foot carries part of the weight: both boards are fed from their own foot.
  EXPECT_GT(foot_total_n(2, 102), 0.2 * kRobotMassKg * kGravity);
  EXPECT_GT(foot_total_n(3, 101), 0.2 * kRobotMassKg * kGravity);
  // Present Current reflects the work of a loaded knee (left knee, ID 15 on bus 2): not zero.
  const Bytes current = read(2, 15, kPresentCurrent, 2);
  ASSERT_EQ(current.size(), 2u);
  EXPECT_NE(static_cast<int16_t>(current[0] | (current[1] << 8)), 0);
  // The CORE board in the servo supply sees the 21 servos holding the body up: a current (over
  // 0.2 s, as the body still rocks a little), and far less than a single stalled servo draws.
  double supply_a = 0.0;
  for (int i = 0; i < 10; ++i) {
    supply_a += core_current_a() / 10.0;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  EXPECT_GT(supply_a, 0.02) << supply_a;  // at least about one ADC count (0.049 A)
  EXPECT_LT(supply_a, kXm430StallCurrentA) << supply_a;
}

// The handler pins the trunk and locks every joint. Over the 3 s in which a limp robot lies down
// (CollapsesWithoutTorque) nothing moves: every servo keeps the position of the first instant, the
// trunk stays level and the feet keep resting on the carpet with the load they settled at.
TEST_F(X430Body, HeldUntilTheDriverEnablesTorque) {
  const std::vector<int32_t> initial = read_positions();
  wait_sim_time(0.5);  // the feet settle on the carpet within the first 0.1 s
  const Pose settled = read_pose();
  wait_sim_time(2.5);
  const Pose held = read_pose();
  const std::vector<int32_t> positions = read_positions();

  for (std::size_t i = 0; i < positions.size(); ++i) {
    EXPECT_NEAR(positions[i], initial[i], kHeldPositionUnits) << "servo " << i << " in kServos order";
  }
  expect_held_still(settled, held);
  // Torque off everywhere: the servos draw nothing (one ADC count is 0.049 A).
  EXPECT_NEAR(core_current_a(), 0.0, 0.049);
}

class LimpX430Body : public X430Body {
 protected:
  LimpX430Body() : X430Body({"--no-hold"}) {}
};

TEST_F(LimpX430Body, CollapsesWithoutTorque) {
  wait_sim_time(3.0);
  const Pose pose = read_pose();
  // Lying on the carpet: the trunk is far from upright, or at least the feet no longer carry it all.
  EXPECT_TRUE(std::fabs(pose.pitch_deg) > 30.0 || std::fabs(pose.roll_deg) > 30.0 ||
              pose.feet_n < 0.5 * kRobotMassKg * kGravity)
      << pose.pitch_deg << " " << pose.roll_deg << " " << pose.feet_n;
}

}  // namespace
}  // namespace doppel::testing
