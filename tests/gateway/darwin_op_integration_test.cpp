// End-to-end: the darwin-op robot driven over its pty the way the DARwIn-OP framework
// (darwinop-ens/darwin-op, Framework/src/CM730.cpp and MotionManager.cpp) drives the real bus:
// CM730::Connect() writes Dynamixel Power = 1 to ID 200 before anything else, then every 8 ms
// MotionManager::Process() sends one SYNC WRITE of D, I, P gain, a reserved byte and Goal Position
// (MX-28 addresses 26..31) and CM730::BulkRead() asks the CM-730 for 30 bytes from 24 and both FSR
// boards for 10 bytes from 26 (MakeBulkReadPacket: 200, then 112, then 111). Expected packets come
// from the reference's framing rules (reference_client.h), values from the manuals and physics
// (the body: darwin_op_physics_test.cpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <thread>
#include <vector>

#include "cycle_stats.h"
#include "darwin_op_framework.h"
#include "doppel_process.h"
#include "reference_client.h"

namespace doppel::testing {
namespace {

using namespace darwin;

Bytes status(uint8_t id, uint8_t error, const Bytes& params = {}) { return p1_instruction(id, error, params); }

// CM-730 bytes 24..53 whose value the cycle determines: Dynamixel Power 1, LED panel, LEDs,
// button and the undefined 31..37 all 0, Present Voltage 120 (the file's 12.0 V), MIC 1 and ADC 2's
// low byte 0 (no signal is simulated). Gyro and ACC (38..49) come from physics: 10-bit values.
::testing::AssertionResult cm730_block_ok(const Bytes& block) {
  if (block.size() != 30u) return ::testing::AssertionFailure() << block.size() << " bytes";
  for (std::size_t address = 24; address <= 53; ++address) {
    const uint8_t byte = block[address - 24];
    if (address >= kGyroZ && address < kVoltage) {
      if ((address % 2 == 1) && byte > 3) return ::testing::AssertionFailure() << "address " << address << ": " << int(byte);
      continue;
    }
    const uint8_t expected = address == kDxlPower ? 1 : address == kVoltage ? 120 : 0;
    if (byte != expected) {
      return ::testing::AssertionFailure() << "address " << address << ": " << int(byte) << ", not " << int(expected);
    }
  }
  return ::testing::AssertionSuccess();
}

// FSR1..4 (1 mN) come from physics; FSR_Central_X / Y follow from them (docs/devices.md, FSR):
// round(254 x (FSR2 + FSR4) / sum), round(254 x (FSR1 + FSR2) / sum), 255 without load.
::testing::AssertionResult fsr_block_ok(const Bytes& block, double& load_n) {
  if (block.size() != 10u) return ::testing::AssertionFailure() << block.size() << " bytes";
  uint32_t cell[4];
  for (int i = 0; i < 4; ++i) cell[i] = word_at(block, 2 * static_cast<std::size_t>(i));
  const uint32_t sum = cell[0] + cell[1] + cell[2] + cell[3];
  load_n = sum * 0.001;
  const uint8_t x = sum == 0 ? 255 : static_cast<uint8_t>((254u * (cell[1] + cell[3]) + sum / 2) / sum);
  const uint8_t y = sum == 0 ? 255 : static_cast<uint8_t>((254u * (cell[0] + cell[1]) + sum / 2) / sum);
  if (block[8] != x || block[9] != y) {
    return ::testing::AssertionFailure() << "centre " << int(block[8]) << "," << int(block[9]) << ", not " << int(x)
                                         << "," << int(y);
  }
  return ::testing::AssertionSuccess();
}

TEST(DarwinOp, IsListed) {
  auto [code, list] = run_command(doppel_executable() + " --list-robots");
  EXPECT_EQ(code, 0);
  EXPECT_NE(list.find("darwin-op       DARwIn-OP (ROBOTIS-OP2), 20 MX-28, CM-730 (200), FSR 111/112, head camera"),
            std::string::npos)
      << list;
}

// The framework on the simulated body, in wire mode, for 60 s: Connect(), MotionManager's reads of
// every joint, then every 8 ms one SYNC WRITE of the walk-ready goals at Walking's gains (the head
// panning +-20 deg, as Head's tracking moves it) and one BULK READ. The body stands throughout.
TEST(DarwinOp, TheFrameworksEightMillisecondCycleForSixtySecondsInWireMode) {
  // Bullet: on ODE this body, standing on P-only servos, starts to rock sideways after about 30 s
  // and falls at 40-50 s (docs/devices.md, DARwIn-OP body); on Bullet it stands the whole minute.
  DoppelProcess doppel({"--robot", "darwin-op", "--timing", "wire", "--physics", "bullet"});
  SerialClient client(doppel.link(), kBaud);

  // Power-on: Dynamixel Power is 0, so the MX-28s and the FSR boards have no supply.
  EXPECT_TRUE(client.transact(p1_instruction(1, kPing), 6, 100).empty());
  EXPECT_TRUE(client.transact(p1_instruction(kRightFsr, kPing), 6, 100).empty());
  EXPECT_EQ(client.transact(p1_instruction(kCm730, kRead, {kDxlPower, 1}), 7, 1000), status(kCm730, 0, {0}));

  // CM730::Connect(): the CM-730 answers its PING, then DXLPowerOn() writes 24 = 1.
  ASSERT_EQ(client.transact(p1_instruction(kCm730, kPing), 6, 1000), status(kCm730, 0));
  ASSERT_EQ(client.transact(p1_instruction(kCm730, kWrite, {kDxlPower, 1}), 6, 1000), status(kCm730, 0));
  for (uint8_t id = 1; id <= kServoCount; ++id) {
    ASSERT_EQ(client.transact(p1_instruction(id, kPing), 6, 1000), status(id, 0)) << int(id);
  }
  ASSERT_EQ(client.transact(p1_instruction(kLeftFsr, kPing), 6, 1000), status(kLeftFsr, 0));
  ASSERT_EQ(client.transact(p1_instruction(kRightFsr, kPing), 6, 1000), status(kRightFsr, 0));

  // MotionManager::Initialize() reads every joint's Present Position: the held robot stands in the
  // file's initial pose, the walk-ready pose, the arms up to 3 deg lower under the handler's finite
  // grip (darwin_op_physics_test.cpp, HeldUntilTheDriverPowersAndEnablesIt).
  for (uint8_t id = 1; id <= kServoCount; ++id) {
    const Bytes reply = client.transact(p1_instruction(id, kRead, {kPresentPosition, 2}), 8, 1000);
    ASSERT_EQ(reply.size(), 8u) << int(id);
    EXPECT_EQ(reply, status(id, 0, {reply[5], reply[6]})) << int(id);
    EXPECT_NEAR(word_at(reply, 5), kWalkReady[id], id <= 6 ? 34 : 7) << int(id);
  }

  // One BULK READ of the held robot: its trunk is pinned in the walk-ready lean, so the CM-730
  // reads zero rate and gravity alone: Gyro 512, ACC X 512, ACC Y = 512 - 128 sin(12.92 deg) = 483,
  // ACC Z = 512 + 128 cos(12.92 deg) = 637, each within a count (the pinned trunk trembles with the
  // feet's contacts); every other byte exactly.
  const Bytes bulk_read = framework_bulk_read();
  {
    const Bytes reply = client.transact(bulk_read, kBulkReplyBytes, 1000);
    const auto statuses = parse_p1_statuses(reply);
    ASSERT_TRUE(statuses && statuses->size() == 3u) << reply.size() << " bytes";
    const double lean = kLeanDeg * M_PI / 180.0;
    EXPECT_EQ(accel_counts(-std::sin(lean)), 483);
    EXPECT_EQ(accel_counts(std::cos(lean)), 637);
    EXPECT_EQ((*statuses)[0].id, kCm730);
    const Bytes& cm = (*statuses)[0].params;
    EXPECT_TRUE(cm730_block_ok(cm));
    const int at_rest[6] = {512, 512, 512, 512, accel_counts(-std::sin(lean)), accel_counts(std::cos(lean))};
    for (std::size_t k = 0; k < 6 && cm.size() == 30u; ++k) {
      EXPECT_NEAR(word_at(cm, kGyroZ - 24 + 2 * k), at_rest[k], 1) << "address " << kGyroZ + 2 * k;
    }
    double load_n = 0.0;
    EXPECT_EQ((*statuses)[1].id, kLeftFsr);
    EXPECT_TRUE(fsr_block_ok((*statuses)[1].params, load_n));
    EXPECT_EQ((*statuses)[2].id, kRightFsr);
    EXPECT_TRUE(fsr_block_ok((*statuses)[2].params, load_n));
  }

  constexpr int kCycles = 7500;  // 60 s of 8 ms
  constexpr auto kPeriod = std::chrono::milliseconds(8);
  constexpr double kPeriodMs = 8.0;
  CycleStats stats(kPeriodMs, kCycles);  // over the period: SYNC WRITE + BULK READ took longer than 8 ms
  int late_starts = 0;   // cycles that started late because the one before ran past its slot
  double last_feet_n = 0.0;
  int first_low_cycle = -1;  // the first cycle whose feet carry less than half the weight
  std::array<uint16_t, kServoCount + 1> goal = kWalkReady;
  auto next = std::chrono::steady_clock::now();
  for (int cycle = 0; cycle < kCycles; ++cycle) {
    // HEAD_PAN (19): 20 deg (227.6 counts) amplitude, 4 s period.
    goal[19] = static_cast<uint16_t>(2048 + std::lround(227.6 * std::sin(2.0 * M_PI * cycle * 0.008 / 4.0)));
    const auto start = std::chrono::steady_clock::now();
    client.send(framework_sync_write(goal));
    // A reply later than 8 ms is an overrun, counted below, not an error: the machine may stall the
    // test for a while (load 5-8), so only a reply missing after 1 s counts as lost.
    const Bytes reply = client.transact(bulk_read, kBulkReplyBytes, 1000);
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();

    const auto statuses = parse_p1_statuses(reply);
    bool ok = statuses && statuses->size() == 3u && reply.size() == kBulkReplyBytes;
    double left_n = 0.0, right_n = 0.0;
    if (ok) {
      const auto& s = *statuses;
      ok = s[0].id == kCm730 && s[1].id == kLeftFsr && s[2].id == kRightFsr && s[0].error == 0 && s[1].error == 0 &&
           s[2].error == 0 && cm730_block_ok(s[0].params) && fsr_block_ok(s[1].params, left_n) &&
           fsr_block_ok(s[2].params, right_n);
    }
    stats.add(ms, ok);
    if (!ok) {
      ADD_FAILURE() << "cycle " << cycle << ": " << reply.size() << " bytes, not a valid answer to the BULK READ";
    } else {
      last_feet_n = left_n + right_n;
      // From 2 s on (the first cycles still see the held robot, its trunk pinned).
      if (cycle >= 250 && first_low_cycle < 0 && last_feet_n < 0.5 * kRobotMassKg * kStandardGravity) {
        first_low_cycle = cycle;
      }
    }
    next += kPeriod;
    const auto now = std::chrono::steady_clock::now();
    if (now > next) {
      ++late_starts;
      next = now;
    }
    std::this_thread::sleep_until(next);
  }
  // SYNC WRITE has no status: nothing may be left on the line.
  EXPECT_TRUE(client.drain(50).empty());
  EXPECT_EQ(stats.errors(), 0);
  // After 60 s of the cycle the robot still stands on its feet.
  const double weight_n = kRobotMassKg * kStandardGravity;
  EXPECT_NEAR(last_feet_n, weight_n, 0.1 * weight_n);
  EXPECT_EQ(first_low_cycle, -1) << "the feet lost their load";

  RecordProperty("cycles", static_cast<int>(stats.cycles()));
  RecordProperty("errors", static_cast<int>(stats.errors()));
  RecordProperty("overruns", static_cast<int>(stats.over_period()));
  RecordProperty("late_starts", late_starts);
  RecordProperty("cycle_p50_ms", std::to_string(stats.percentile(0.5)));
  RecordProperty("cycle_p99_ms", std::to_string(stats.percentile(0.99)));
  RecordProperty("cycle_max_ms", std::to_string(stats.percentile(1.0)));
  std::printf("darwin-op 8 ms cycle (SYNC WRITE + BULK READ), wire mode, physics: %s; %d late starts; feet %.2f N\n",
              stats.summary().c_str(), late_starts, last_feet_n);

  // The last SYNC WRITE reached every servo: its P gain, its goal, and the torque on (a Goal
  // Position write switches it on, docs/devices.md 3.7).
  for (uint8_t id = 1; id <= kServoCount; ++id) {
    EXPECT_EQ(client.transact(p1_instruction(id, kRead, {kPGain, 1}), 7), status(id, 0, {p_gain(id)})) << int(id);
    EXPECT_EQ(client.transact(p1_instruction(id, kRead, {kGoalPosition, 2}), 8),
              status(id, 0, {static_cast<uint8_t>(goal[id] & 0xFF), static_cast<uint8_t>(goal[id] >> 8)}))
        << int(id);
    EXPECT_EQ(client.transact(p1_instruction(id, kRead, {kTorqueEnable, 1}), 7), status(id, 0, {1})) << int(id);
  }
}

// Dynamixel Power back to 0 cuts the servos' supply; 1 powers them up with their RAM at its
// power-on values (torque off, P gain 32), as a real power cycle does.
TEST(DarwinOp, DynamixelPowerOffSilencesTheServosAndOnIsAPowerCycle) {
  DoppelProcess doppel({"--robot", "darwin-op", "--timing", "fast"});
  SerialClient client(doppel.link(), kBaud);
  ASSERT_EQ(client.transact(p1_instruction(kCm730, kWrite, {kDxlPower, 1}), 6), status(kCm730, 0));
  ASSERT_EQ(client.transact(p1_instruction(5, kWrite, {kPGain, 50}), 6), status(5, 0));
  ASSERT_EQ(client.transact(p1_instruction(5, kWrite, {kTorqueEnable, 1}), 6), status(5, 0));

  ASSERT_EQ(client.transact(p1_instruction(kCm730, kWrite, {kDxlPower, 0}), 6), status(kCm730, 0));
  EXPECT_TRUE(client.transact(p1_instruction(5, kPing), 6, 100).empty());
  EXPECT_TRUE(client.transact(p1_instruction(5, kRead, {kPGain, 1}), 7, 100).empty());
  // A write to an unpowered servo is lost, not stored.
  client.send(p1_instruction(5, kWrite, {kPGain, 60}));
  EXPECT_TRUE(client.drain(100).empty());

  ASSERT_EQ(client.transact(p1_instruction(kCm730, kWrite, {kDxlPower, 1}), 6), status(kCm730, 0));
  EXPECT_EQ(client.transact(p1_instruction(5, kRead, {kPGain, 1}), 7), status(5, 0, {32}));
  EXPECT_EQ(client.transact(p1_instruction(5, kRead, {kTorqueEnable, 1}), 7), status(5, 0, {0}));
  EXPECT_EQ(client.transact(p1_instruction(kRightFsr, kPing), 6), status(kRightFsr, 0));
}

}  // namespace
}  // namespace doppel::testing
