// End-to-end with the body simulated on Protocol 2.0: the real doppel serving robots/fumanoid-x430
// (fumanoid-2011's body on 21 XM430-W350 over four 4 Mbps buses), driven and read back through the
// four ptys by the reference client of tests/support/reference_client_p2.h. What it reads comes from
// the physics world through the Bit-Bots IMU (float32 quaternion, reference §8.2) and the BitFoot
// boards (int32 counts, docs/devices.md P7). ODE only, to keep the run short.
#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <memory>
#include <thread>
#include <vector>

#include "doppel_process.h"
#include "held_pose.h"
#include "reference_client.h"
#include "reference_client_p2.h"

namespace doppel::testing {
namespace {

constexpr uint32_t kBaud = 4000000;
constexpr uint8_t kRead = 0x02, kSyncWrite = 0x83;
constexpr double kRobotMassKg = 4.7;  // robots/fumanoid-x430.textproto: sum of its body masses
constexpr double kGravity = 9.80665;
// A held robot's servos stay within 7 position units (0.6 deg, 0.088 deg per unit) of their start.
constexpr int kHeldPositionUnits = 7;
// BitFoot default calibration (docs/devices.md P7): raw = 1e7 counts + force / 3e-6 N per count.
constexpr double kFootZeroCounts = 1e7;
constexpr double kFootNewtonPerCount = 3e-6;
// fumanoid-x430: servos per bus (ttyDXL0..3), the IMU on bus 0, left foot 102 on bus 2, right 101 on bus 3.
const std::vector<std::vector<uint8_t>> kServos = {{1, 2, 21}, {3, 4, 5, 6, 7, 8}, {9, 11, 13, 15, 17, 19},
                                                   {10, 12, 14, 16, 18, 20}};
constexpr uint8_t kImuId = 241;
constexpr uint16_t kPositionPGain = 84, kTorqueEnable = 64, kPresentCurrent = 126, kPresentPosition = 132;  // XM430-W350 (reference §3.7)
constexpr uint16_t kRealtimeTick = 120;
// Position P Gain the driver sets before the torque goes on. With the factory 800 (Kp = 6.25 PWM
// units per pulse, about 19 N·m/rad per joint at 12 V) hip, knee and ankle in series per leg are
// softer than the 4.7 kg body's toppling stiffness (m g h, about 16 N·m/rad), so it sinks and falls,
// as a soft-tuned real robot would; humanoid drivers raise the gains.
constexpr uint16_t kStandingPGain = 1600;
constexpr uint16_t kImuQuaternion = 60;                         // x, y, z, w float32 (reference §8.2)
constexpr uint16_t kFootSensors = 36;                           // four int32 (reference §8.3)
constexpr uint8_t kCoreId = 42;                                 // BITBOTS-CORE on bus 0 (reference §8.4)
constexpr uint16_t kCoreCurrent = 34;                           // u16 raw ADC (reference §8.4)
constexpr double kXm430StallCurrentA = 2.3;                     // at 12 V (reference §5)

float f32_at(const Bytes& b, std::size_t offset) {
  uint32_t raw = 0;
  for (int i = 0; i < 4; ++i) {
    raw |= static_cast<uint32_t>(b.at(offset + static_cast<std::size_t>(i))) << (8 * i);
  }
  float f;
  std::memcpy(&f, &raw, sizeof f);
  return f;
}

struct Pose {
  double pitch_deg = 0.0;
  double roll_deg = 0.0;
  double feet_n = 0.0;  // both BitFoot boards, all eight cells
};

class X430Body : public ::testing::Test {
 protected:
  X430Body(std::vector<std::string> extra = {}) : doppel_(args(std::move(extra)), "ttyDXL3") {
    for (int bus = 0; bus < 4; ++bus) {
      clients_.push_back(std::make_unique<SerialClient>(doppel_.link("ttyDXL" + std::to_string(bus)), kBaud));
    }
  }
  static std::vector<std::string> args(std::vector<std::string> extra) {
    std::vector<std::string> a = {"--robot", "fumanoid-x430", "--physics", "ode", "--timing", "fast"};
    a.insert(a.end(), extra.begin(), extra.end());
    return a;
  }
  SerialClient& bus(int index) { return *clients_.at(static_cast<std::size_t>(index)); }

  // One READ; the status' parameters (empty on any transport or status error).
  Bytes read(int b, uint8_t id, uint16_t address, uint16_t length) {
    Bytes params = le16(address);
    const Bytes l = le16(length);
    params.insert(params.end(), l.begin(), l.end());
    const auto statuses = parse_p2_statuses(bus(b).transact(p2_instruction(id, kRead, params), 11u + length));
    if (!statuses || statuses->size() != 1 || (*statuses)[0].id != id || (*statuses)[0].error != 0 ||
        (*statuses)[0].params.size() != length) {
      ADD_FAILURE() << "no " << length << "-byte READ reply from ID " << int(id) << " on bus " << b;
      return {};
    }
    return (*statuses)[0].params;
  }

  // SYNC WRITE of `value` (`size` bytes) at `address` to every servo of every bus.
  void sync_write_all(uint16_t address, uint16_t size, uint16_t value) {
    for (int b = 0; b < 4; ++b) {
      Bytes params = le16(address);
      const Bytes length = le16(size);
      params.insert(params.end(), length.begin(), length.end());
      for (uint8_t id : kServos[static_cast<std::size_t>(b)]) {
        params.push_back(id);
        for (uint16_t i = 0; i < size; ++i) {
          params.push_back(static_cast<uint8_t>(value >> (8 * i)));
        }
      }
      bus(b).send(p2_instruction(0xFE, kSyncWrite, params));
    }
  }

  // As a driver starting up: gains, then Torque Enable := 1 on all 21 servos.
  void torque_on() {
    sync_write_all(kPositionPGain, 2, kStandingPGain);
    sync_write_all(kTorqueEnable, 1, 1);
  }

  double foot_total_n(int b, uint8_t id) {
    const Bytes raw = read(b, id, kFootSensors, 16);
    double total = 0.0;
    for (std::size_t cell = 0; cell < 4 && raw.size() == 16; ++cell) {
      total += (static_cast<double>(le32_at(raw, 4 * cell)) - kFootZeroCounts) * kFootNewtonPerCount;
    }
    return total;
  }

  // The servos' supply current the CORE board measures, decoded as the Bit-Bots driver does.
  double core_current_a() {
    const Bytes raw = read(0, kCoreId, kCoreCurrent, 2);
    return raw.size() == 2 ? ((raw[0] | (raw[1] << 8)) * 3.3 / 1024.0 - 2.5) / -0.066 : 0.0;
  }

  Pose read_pose() {
    Pose pose;
    const Bytes q = read(0, kImuId, kImuQuaternion, 16);
    if (q.size() == 16) {
      const double x = f32_at(q, 0), y = f32_at(q, 4), z = f32_at(q, 8), w = f32_at(q, 12);
      // Roll and pitch of the ZYX (yaw, pitch, roll) rotation the quaternion describes.
      pose.roll_deg = std::atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y)) * 180.0 / M_PI;
      pose.pitch_deg = std::asin(std::clamp(2.0 * (w * y - z * x), -1.0, 1.0)) * 180.0 / M_PI;
    }
    pose.feet_n = foot_total_n(2, 102) + foot_total_n(3, 101);
    return pose;
  }

  // Present Position of every servo, bus by bus in kServos order.
  std::vector<int32_t> read_positions() {
    std::vector<int32_t> positions;
    for (int b = 0; b < 4; ++b) {
      for (uint8_t id : kServos[static_cast<std::size_t>(b)]) {
        const Bytes raw = read(b, id, kPresentPosition, 4);
        positions.push_back(raw.size() == 4 ? le32_at(raw, 0) : -1);
      }
    }
    return positions;
  }

  // Waits until `seconds` of simulation time have passed, read from a servo's Realtime Tick (120,
  // ms of simulation time, wraps at 32768): on a loaded machine the simulation may run behind the
  // wall clock, and the robot must be judged after simulated time. Gives up after 30 s.
  void wait_sim_time(double seconds) {
    auto tick_ms = [&] {
      const Bytes tick = read(0, kServos[0][0], kRealtimeTick, 2);
      return tick.size() == 2 ? static_cast<int>(tick[0] | (tick[1] << 8)) : 0;
    };
    const int start = tick_ms();
    const auto wanted = static_cast<int>(seconds * 1000.0);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    while ((tick_ms() - start + 32768) % 32768 < wanted) {
      ASSERT_LT(std::chrono::steady_clock::now(), deadline) << "the simulation did not advance " << seconds << " s";
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  }

  DoppelProcess doppel_;
  std::vector<std::unique_ptr<SerialClient>> clients_;
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
