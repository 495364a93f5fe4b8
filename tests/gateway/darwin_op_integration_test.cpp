// End-to-end: the darwin-op robot driven over its pty the way the DARwIn-OP framework
// (darwinop-ens/darwin-op, Framework/src/CM730.cpp and MotionManager.cpp) drives the real bus:
// CM730::Connect() writes Dynamixel Power = 1 to ID 200 before anything else, then every 8 ms
// MotionManager::Process() sends one SYNC WRITE of D, I, P gain, a reserved byte and Goal Position
// (MX-28 addresses 26..31) and CM730::BulkRead() asks the CM-730 for 30 bytes from 24 and both FSR
// boards for 10 bytes from 26 (MakeBulkReadPacket: 200, then 112, then 111). Expected packets come
// from the reference's framing rules (reference_client.h), values from the manuals and physics.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <thread>

#include "doppel_process.h"
#include "reference_client.h"

namespace doppel::testing {
namespace {

constexpr uint32_t kBaud = 1000000;
constexpr uint8_t kPing = 0x01, kRead = 0x02, kWrite = 0x03, kSyncWrite = 0x83, kBulkRead = 0x92;
constexpr uint8_t kBroadcast = 0xFE;
constexpr uint8_t kCm730 = 200, kRightFsr = 111, kLeftFsr = 112;
constexpr uint8_t kDxlPower = 24, kDGain = 26, kPresentPosition = 36, kPGain = 28, kGoalPosition = 30;
constexpr uint8_t kTorqueEnable = 24;

Bytes status(uint8_t id, uint8_t error, const Bytes& params = {}) { return p1_instruction(id, error, params); }

uint16_t word(const Bytes& reply, std::size_t offset) {
  return static_cast<uint16_t>(reply.at(offset) | (reply.at(offset + 1) << 8));
}

// What the CM-730 answers to the framework's BULK READ of 24..53 with the robot at rest and the
// servos powered: Dynamixel Power 1, LEDs and buttons 0, gyro 512 (zero rate), ACC X/Y 512 and
// ACC Z 640 (1 g = 512 + 128, e-Manual scale), Present Voltage 120 (the file's 12.0 V), MIC/ADC 0.
Bytes cm730_block() {
  Bytes b(30, 0);
  b[0] = 1;
  for (std::size_t address : {38u, 40u, 42u, 44u, 46u}) {
    b[address - 24] = 0x00;
    b[address - 24 + 1] = 0x02;
  }
  b[48 - 24] = 0x80;
  b[49 - 24] = 0x02;
  b[50 - 24] = 120;
  return b;
}

// FSR1..4 and the centre of pressure of a foot at rest: the kinematic stand-in's 4 kg
// (body/kinematic_body.h) on eight cells, 4.0 x 9.80665 / 8 = 4.903 N = 4903 mN each, the
// centre at 254 x 1/2 = 127 on both axes.
Bytes fsr_block() {
  const auto cell = static_cast<uint16_t>(std::lround(4.0 * 9.80665 / 8.0 * 1000.0));
  Bytes b;
  for (int i = 0; i < 4; ++i) {
    b.push_back(static_cast<uint8_t>(cell & 0xFF));
    b.push_back(static_cast<uint8_t>(cell >> 8));
  }
  b.push_back(127);
  b.push_back(127);
  return b;
}

TEST(DarwinOp, IsListed) {
  auto [code, list] = run_command(doppel_executable() + " --list-robots");
  EXPECT_EQ(code, 0);
  EXPECT_NE(list.find("darwin-op       DARwIn-OP bus only, no body yet"), std::string::npos) << list;
}

TEST(DarwinOp, FrameworkConnectThenTheEightMillisecondCycleInWireMode) {
  DoppelProcess doppel({"--robot", "darwin-op", "--timing", "wire"});
  SerialClient client(doppel.link(), kBaud);

  // Power-on: Dynamixel Power is 0, so the MX-28s and the FSR boards have no supply.
  EXPECT_TRUE(client.transact(p1_instruction(1, kPing), 6, 100).empty());
  EXPECT_TRUE(client.transact(p1_instruction(kRightFsr, kPing), 6, 100).empty());
  EXPECT_EQ(client.transact(p1_instruction(kCm730, kRead, {kDxlPower, 1}), 7), status(kCm730, 0, {0}));

  // CM730::Connect(): the CM-730 answers its PING, then DXLPowerOn() writes 24 = 1.
  ASSERT_EQ(client.transact(p1_instruction(kCm730, kPing), 6), status(kCm730, 0));
  ASSERT_EQ(client.transact(p1_instruction(kCm730, kWrite, {kDxlPower, 1}), 6), status(kCm730, 0));
  for (uint8_t id = 1; id <= 20; ++id) {
    ASSERT_EQ(client.transact(p1_instruction(id, kPing), 6), status(id, 0)) << int(id);
  }
  ASSERT_EQ(client.transact(p1_instruction(kLeftFsr, kPing), 6), status(kLeftFsr, 0));
  ASSERT_EQ(client.transact(p1_instruction(kRightFsr, kPing), 6), status(kRightFsr, 0));

  // MotionManager::Initialize() reads every joint's Present Position.
  std::array<uint16_t, 21> present{};
  for (uint8_t id = 1; id <= 20; ++id) {
    const Bytes reply = client.transact(p1_instruction(id, kRead, {kPresentPosition, 2}), 8);
    ASSERT_EQ(reply.size(), 8u) << int(id);
    present[id] = word(reply, 5);
    ASSERT_EQ(reply, status(id, 0, {reply[5], reply[6]})) << int(id);
  }

  const Bytes bulk_read = p1_instruction(kBroadcast, kBulkRead,
                                         {0x00, 30, kCm730, kDxlPower, 10, kLeftFsr, 26, 10, kRightFsr, 26});
  Bytes expected_bulk = status(kCm730, 0, cm730_block());
  for (uint8_t id : {kLeftFsr, kRightFsr}) {
    const Bytes foot = status(id, 0, fsr_block());
    expected_bulk.insert(expected_bulk.end(), foot.begin(), foot.end());
  }
  ASSERT_EQ(expected_bulk.size(), 36u + 16u + 16u);

  // The 8 ms cycle for 2 s: joint k's goal sweeps 0..49 counts around where it stood.
  constexpr int kCycles = 250;
  constexpr auto kPeriod = std::chrono::milliseconds(8);
  // LinuxCM730::SetPacketTimeout(68 x 1.5): 12 x (1000 / 1 000 000) x 102 + 5 ms = 6.2 ms.
  constexpr double kFrameworkTimeoutMs = 12.0 * 1000.0 / kBaud * (68 * 1.5) + 5.0;
  int errors = 0;
  int beyond_framework_timeout = 0;
  int overruns = 0;
  double worst_reply_ms = 0.0;
  std::array<uint16_t, 21> goal{};
  auto next = std::chrono::steady_clock::now();
  for (int cycle = 0; cycle < kCycles; ++cycle) {
    Bytes sync = {kDGain, 6};
    for (uint8_t id = 1; id <= 20; ++id) {
      goal[id] = static_cast<uint16_t>(present[id] + (cycle % 50));
      sync.insert(sync.end(), {id, 0, 0, 40, 0, static_cast<uint8_t>(goal[id] & 0xFF),
                               static_cast<uint8_t>(goal[id] >> 8)});
    }
    client.send(p1_instruction(kBroadcast, kSyncWrite, sync));
    const auto asked = std::chrono::steady_clock::now();
    const Bytes reply = client.transact(bulk_read, expected_bulk.size(), 100);
    const double reply_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - asked).count();
    worst_reply_ms = std::max(worst_reply_ms, reply_ms);
    if (reply_ms > kFrameworkTimeoutMs) ++beyond_framework_timeout;
    const auto statuses = parse_p1_statuses(reply);
    if (reply != expected_bulk || !statuses || statuses->size() != 3) {
      ++errors;
      ADD_FAILURE() << "cycle " << cycle << ": " << reply.size() << " bytes, not the expected bulk-read answer";
    }
    next += kPeriod;
    if (std::chrono::steady_clock::now() > next) {
      ++overruns;
      next = std::chrono::steady_clock::now();
    }
    std::this_thread::sleep_until(next);
  }
  // SYNC WRITE has no status: nothing may be left on the line.
  EXPECT_TRUE(client.drain(50).empty());
  EXPECT_EQ(errors, 0);
  RecordProperty("worst_bulk_read_reply_ms", std::to_string(worst_reply_ms));
  RecordProperty("beyond_framework_timeout", beyond_framework_timeout);
  RecordProperty("cycle_overruns", overruns);
  std::printf("darwin-op cycle: worst BULK READ reply %.2f ms (framework timeout %.2f ms, %d beyond it), %d of %d "
              "cycles overran 8 ms\n",
              worst_reply_ms, kFrameworkTimeoutMs, beyond_framework_timeout, overruns, kCycles);

  // The last SYNC WRITE reached every servo: P gain 40, its goal, and the torque on (a Goal
  // Position write switches it on, docs/devices.md 3.7).
  for (uint8_t id = 1; id <= 20; ++id) {
    EXPECT_EQ(client.transact(p1_instruction(id, kRead, {kPGain, 1}), 7), status(id, 0, {40})) << int(id);
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
