#include "dynamixel/protocol1_servo.h"
#include "dynamixel/servo_controller.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "test_support.h"

namespace doppel::dynamixel {
namespace {

using testing::Bytes;
using testing::transact;
using testing::make_packet;

constexpr double kPi = std::numbers::pi;

Protocol1Servo make_servo(const char* model, uint8_t id = 1) { return Protocol1Servo(model_spec(model), id, 1, 250); }

ServoFeedback at(double position_rad) {
  ServoFeedback f;
  f.position_rad = position_rad;
  f.voltage_v = 12.0;
  return f;
}

// Reference §1.7 worked packets.

TEST(Protocol1ServoGolden, PingId1) {
  auto sut = make_servo("RX-28");
  EXPECT_EQ(transact(sut, Bytes{0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB}), (Bytes{0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC}));
}

TEST(Protocol1ServoGolden, ReadTemperature32C) {
  auto sut = make_servo("RX-28");
  ServoFeedback f = at(0.0);
  f.temperature_c = 32.0;
  sut.apply(f);

  EXPECT_EQ(transact(sut, Bytes{0xFF, 0xFF, 0x01, 0x04, 0x02, 0x2B, 0x01, 0xCC}),
            (Bytes{0xFF, 0xFF, 0x01, 0x03, 0x00, 0x20, 0xDB}));
}

TEST(Protocol1ServoGolden, ReadModelNumberAndFirmwareOfRx28) {
  auto sut = make_servo("RX-28");
  EXPECT_EQ(transact(sut, Bytes{0xFF, 0xFF, 0x01, 0x04, 0x02, 0x00, 0x03, 0xF5}),
            (Bytes{0xFF, 0xFF, 0x01, 0x05, 0x00, 0x1C, 0x00, 0x08, 0xD5}));
}

TEST(Protocol1ServoGolden, ReadPresentPosition758) {
  auto sut = make_servo("RX-28");
  // 758 units = 246 units from the centre; 1024 units span 300 deg.
  sut.apply(at(246.0 * (300.0 / 1024.0) * kPi / 180.0));

  EXPECT_EQ(transact(sut, Bytes{0xFF, 0xFF, 0x01, 0x04, 0x02, 0x24, 0x02, 0xD2}),
            (Bytes{0xFF, 0xFF, 0x01, 0x04, 0x00, 0xF6, 0x02, 0x02}));
}

TEST(Protocol1ServoGolden, WriteGoalPosition512) {
  auto sut = make_servo("RX-28");
  sut.apply(at(0.5));
  sut.power_on(0.5);
  ASSERT_NE(sut.register_raw(p1::kGoalPosition), 512);

  EXPECT_EQ(transact(sut, Bytes{0xFF, 0xFF, 0x01, 0x05, 0x03, 0x1E, 0x00, 0x02, 0xD6}),
            (Bytes{0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC}));
  EXPECT_EQ(sut.register_raw(p1::kGoalPosition), 512);
}

// A switched-off supply (the CM-730's Dynamixel Power) loses RAM, keeps EEPROM (e-Manual: RAM
// area values are reset to their initial values when power is turned on).
TEST(Protocol1Servo, PowerCycleResetsRamAndKeepsEeprom) {
  auto sut = make_servo("MX-28", 7);
  sut.apply(at(0.5));
  ASSERT_EQ(sut.write_item(p1::kReturnDelayTime, 0), "");
  ASSERT_EQ(sut.write_item(p1::kPGain, 64), "");
  ASSERT_EQ(sut.write_item(p1::kGoalPosition, 1000), "");  // switches the torque on (docs/devices.md 3.7)
  ASSERT_EQ(sut.register_raw(p1::kTorqueEnable), 1);

  sut.power_cycle();

  EXPECT_EQ(sut.register_raw(p1::kTorqueEnable), 0);
  EXPECT_EQ(sut.register_raw(p1::kPGain), 32);  // MX-28 initial P gain
  EXPECT_EQ(sut.register_raw(p1::kGoalPosition), sut.register_raw(p1::kPresentPosition));
  EXPECT_EQ(sut.register_raw(p1::kReturnDelayTime), 0);
  EXPECT_EQ(sut.id(), 7);
  EXPECT_FALSE(sut.command().torque_enabled);
}

TEST(Protocol1ServoGolden, BroadcastWriteIdIsExecutedWithoutReply) {
  auto sut = make_servo("RX-64", 9);

  EXPECT_TRUE(transact(sut, Bytes{0xFF, 0xFF, 0xFE, 0x04, 0x03, 0x03, 0x01, 0xF6}).empty());
  EXPECT_EQ(sut.id(), 1);
}

TEST(Protocol1ServoGolden, RegWriteThenBroadcastAction) {
  auto sut = make_servo("RX-64");
  const uint16_t goal_before = sut.register_raw(p1::kGoalPosition);

  EXPECT_EQ(transact(sut, Bytes{0xFF, 0xFF, 0x01, 0x05, 0x04, 0x1E, 0xF4, 0x01, 0xE2}),
            (Bytes{0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC}));
  EXPECT_EQ(sut.register_raw(p1::kRegistered), 1);
  EXPECT_EQ(sut.register_raw(p1::kGoalPosition), goal_before);

  EXPECT_TRUE(transact(sut, Bytes{0xFF, 0xFF, 0xFE, 0x02, 0x05, 0xFA}).empty());
  EXPECT_EQ(sut.register_raw(p1::kGoalPosition), 500);
  EXPECT_EQ(sut.register_raw(p1::kRegistered), 0);
}

TEST(Protocol1ServoGolden, FactoryResetAnswersWithOldIdThenBecomesId1) {
  Protocol1Servo sut(model_spec("RX-28"), 0, 1, 10);
  ASSERT_TRUE(transact(sut, make_packet(0, instruction::kWrite, {p1::kCwAngleLimit, 0x10, 0x00})).size() > 0);

  EXPECT_EQ(transact(sut, Bytes{0xFF, 0xFF, 0x00, 0x02, 0x06, 0xF7}), (Bytes{0xFF, 0xFF, 0x00, 0x02, 0x00, 0xFD}));
  EXPECT_EQ(sut.id(), 1);
  EXPECT_EQ(sut.register_raw(p1::kBaudRate), 34);          // RX-28 factory default: 57 600 bps
  EXPECT_EQ(sut.register_raw(p1::kReturnDelayTime), 250);
  EXPECT_EQ(sut.register_raw(p1::kCwAngleLimit), 0);
  EXPECT_EQ(sut.baud_bps(), 2000000u / 35u);
}

TEST(Protocol1ServoGolden, SyncWriteEachDeviceTakesItsBlock) {
  Protocol1Servo id0(model_spec("RX-64"), 0, 1, 250);
  Protocol1Servo id1(model_spec("RX-64"), 1, 1, 250);
  Protocol1Servo id2(model_spec("RX-64"), 2, 1, 250);
  const Bytes sync = {0xFF, 0xFF, 0xFE, 0x0E, 0x83, 0x1E, 0x04, 0x00, 0x10, 0x00,
                      0x50, 0x01, 0x01, 0x20, 0x02, 0x60, 0x03, 0x67};
  const uint16_t id2_goal = id2.register_raw(p1::kGoalPosition);

  EXPECT_TRUE(transact(id0, sync).empty());
  EXPECT_TRUE(transact(id1, sync).empty());
  EXPECT_TRUE(transact(id2, sync).empty());

  EXPECT_EQ(id0.register_raw(p1::kGoalPosition), 0x010);
  EXPECT_EQ(id0.register_raw(p1::kMovingSpeed), 0x150);
  EXPECT_EQ(id1.register_raw(p1::kGoalPosition), 0x220);
  EXPECT_EQ(id1.register_raw(p1::kMovingSpeed), 0x360);
  EXPECT_EQ(id2.register_raw(p1::kGoalPosition), id2_goal);
}

TEST(Protocol1ServoGolden, SyncWriteToOwnIdIsAnInstructionError) {
  auto sut = make_servo("RX-64");
  // SYNC WRITE must go to 0xFE. Status: ID 1, ERR 0x40.
  EXPECT_EQ(transact(sut, make_packet(1, instruction::kSyncWrite, {0x1E, 0x02, 0x01, 0x00, 0x03})),
            (Bytes{0xFF, 0xFF, 0x01, 0x02, 0x40, 0xBC}));
  EXPECT_EQ(sut.register_raw(p1::kGoalPosition), 512);
}

TEST(Protocol1ServoGolden, BulkReadRepliesInListOrder) {
  auto first = make_servo("MX-28", 1);
  auto second = make_servo("MX-28", 2);
  const Bytes bulk = {0xFF, 0xFF, 0xFE, 0x09, 0x92, 0x00, 0x02, 0x01, 0x1E, 0x02, 0x02, 0x24, 0x1D};
  // The reference's example data (0x8000) is no reachable MX-28 value; at 0 rad both Goal (30)
  // and Present Position (36) are 2048 = 0x0800.
  Response r1;
  Response r2;
  first.handle(testing::parse_one(bulk), r1);
  second.handle(testing::parse_one(bulk), r2);

  EXPECT_EQ(testing::status_bytes(r1), (Bytes{0xFF, 0xFF, 0x01, 0x04, 0x00, 0x00, 0x08, 0xF2}));
  EXPECT_EQ(r1.timing, ReplyTiming::kAfterInstruction);
  EXPECT_EQ(testing::status_bytes(r2), (Bytes{0xFF, 0xFF, 0x02, 0x04, 0x00, 0x00, 0x08, 0xF1}));
  EXPECT_EQ(r2.timing, ReplyTiming::kAfterPrevious);
  EXPECT_EQ(r2.chain_position, 1);
}

TEST(Protocol1Servo, AxAndRxFirmwareIgnoreBroadcastBulkRead) {
  for (const char* model : {"AX-12A", "RX-28", "RX-64"}) {
    auto sut = make_servo(model, 1);
    const Bytes bulk = {0xFF, 0xFF, 0xFE, 0x09, 0x92, 0x00, 0x02, 0x01, 0x1E, 0x02, 0x02, 0x24, 0x1D};
    EXPECT_TRUE(transact(sut, bulk).empty()) << model;
  }
}

TEST(Protocol1Servo, BulkReadRepeatedIdCountsOnlyItsFirstBlock) {
  auto sut = make_servo("MX-64", 2);
  // Blocks [2, ID 1, 30], [1, ID 1, 3], [1, ID 2, 3]: ID 2 is the second distinct device.
  Response r;
  sut.handle(make_packet(kBroadcastId, instruction::kBulkRead, {0x00, 2, 1, 30, 1, 1, 3, 1, 2, 3}), r);

  EXPECT_EQ(testing::status_bytes(r), (Bytes{0xFF, 0xFF, 0x02, 0x03, 0x00, 0x02, 0xF8}));
  EXPECT_EQ(r.chain_position, 1);
}

TEST(Protocol1Servo, BulkReadFirstBlockOfOwnIdWins) {
  auto sut = make_servo("MX-106", 1);
  Response r;
  sut.handle(make_packet(kBroadcastId, instruction::kBulkRead, {0x00, 1, 1, 3, 2, 1, 30}), r);

  EXPECT_EQ(testing::status_bytes(r), (Bytes{0xFF, 0xFF, 0x01, 0x03, 0x00, 0x01, 0xFA}));
  EXPECT_EQ(r.timing, ReplyTiming::kAfterInstruction);
}

// Status Return Level (reference §1.5).

TEST(Protocol1Servo, StatusReturnLevel0AnswersPingOnly) {
  auto sut = make_servo("AX-12A");
  ASSERT_FALSE(transact(sut, make_packet(1, instruction::kWrite, {p1::kStatusReturnLevel, 0})).empty());

  EXPECT_EQ(transact(sut, make_packet(1, instruction::kPing)), (Bytes{0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC}));
  EXPECT_TRUE(transact(sut, make_packet(1, instruction::kRead, {p1::kId, 1})).empty());
  EXPECT_TRUE(transact(sut, make_packet(1, instruction::kWrite, {p1::kLed, 1})).empty());
  EXPECT_EQ(sut.register_raw(p1::kLed), 1);
}

TEST(Protocol1Servo, StatusReturnLevel1AnswersPingAndRead) {
  auto sut = make_servo("AX-12A");
  ASSERT_FALSE(transact(sut, make_packet(1, instruction::kWrite, {p1::kStatusReturnLevel, 1})).empty());

  EXPECT_EQ(transact(sut, make_packet(1, instruction::kRead, {p1::kId, 1})),
            (Bytes{0xFF, 0xFF, 0x01, 0x03, 0x00, 0x01, 0xFA}));
  EXPECT_TRUE(transact(sut, make_packet(1, instruction::kWrite, {p1::kLed, 1})).empty());
  // SYNC READ (0x82) is no instruction of this firmware, so no read: silent (docs/devices.md P6.6).
  EXPECT_TRUE(transact(sut, make_packet(1, instruction::kSyncRead, {p1::kId, 1})).empty());
}

TEST(Protocol1Servo, BroadcastPingIsAnswered) {
  auto sut = make_servo("RX-28", 3);
  // ~(03 + 02 + 00) = 0xFA
  EXPECT_EQ(transact(sut, make_packet(kBroadcastId, instruction::kPing)), (Bytes{0xFF, 0xFF, 0x03, 0x02, 0x00, 0xFA}));
}

TEST(Protocol1Servo, BroadcastReadIsNotAnswered) {
  auto sut = make_servo("RX-28");
  EXPECT_TRUE(transact(sut, make_packet(kBroadcastId, instruction::kRead, {p1::kId, 1})).empty());
}

TEST(Protocol1Servo, OtherIdsAreIgnored) {
  auto sut = make_servo("RX-28", 1);
  EXPECT_TRUE(transact(sut, make_packet(2, instruction::kWrite, {p1::kLed, 1})).empty());
  EXPECT_EQ(sut.register_raw(p1::kLed), 0);
}

// Error bits (reference §1.4).

TEST(Protocol1Servo, BadChecksumGetsChecksumErrorAndIsNotExecuted) {
  auto sut = make_servo("RX-28");
  // WRITE Goal Position 512 with checksum D7 instead of D6.
  sut.power_on(1.0);
  const uint16_t goal_after_power_on = sut.register_raw(p1::kGoalPosition);
  ASSERT_NE(goal_after_power_on, 512);

  EXPECT_EQ(transact(sut, Bytes{0xFF, 0xFF, 0x01, 0x05, 0x03, 0x1E, 0x00, 0x02, 0xD7}),
            (Bytes{0xFF, 0xFF, 0x01, 0x02, 0x10, 0xEC}));
  EXPECT_EQ(sut.register_raw(p1::kGoalPosition), goal_after_power_on);
}

TEST(Protocol1Servo, PingWithBadChecksumIsNotAnswered) {
  auto sut = make_servo("RX-64");
  EXPECT_TRUE(transact(sut, Bytes{0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFA}).empty());
}

TEST(Protocol1Servo, BroadcastWithBadChecksumIsIgnored) {
  auto sut = make_servo("RX-64", 9);
  EXPECT_TRUE(transact(sut, Bytes{0xFF, 0xFF, 0xFE, 0x04, 0x03, 0x03, 0x01, 0xF5}).empty());
  EXPECT_EQ(sut.id(), 9);
}

TEST(Protocol1Servo, UndefinedInstructionIsAnInstructionError) {
  auto sut = make_servo("RX-64");
  // FF FF 01 02 07 F5 -> ERR 0x40: ~(01 + 02 + 40) = 0xBC
  EXPECT_EQ(transact(sut, Bytes{0xFF, 0xFF, 0x01, 0x02, 0x07, 0xF5}), (Bytes{0xFF, 0xFF, 0x01, 0x02, 0x40, 0xBC}));
}

TEST(Protocol1Servo, ActionWithoutRegWriteIsAnInstructionError) {
  auto sut = make_servo("RX-64");
  EXPECT_EQ(transact(sut, Bytes{0xFF, 0xFF, 0x01, 0x02, 0x05, 0xF7}), (Bytes{0xFF, 0xFF, 0x01, 0x02, 0x40, 0xBC}));
  EXPECT_TRUE(transact(sut, Bytes{0xFF, 0xFF, 0xFE, 0x02, 0x05, 0xFA}).empty());
}

TEST(Protocol1Servo, WriteOutOfRangeIsRejected) {
  auto sut = make_servo("RX-28");
  // ID := 254 (max 253): FF FF 01 04 03 03 FE F6 -> ERR 0x08: ~(01 + 02 + 08) = 0xF4
  EXPECT_EQ(transact(sut, Bytes{0xFF, 0xFF, 0x01, 0x04, 0x03, 0x03, 0xFE, 0xF6}),
            (Bytes{0xFF, 0xFF, 0x01, 0x02, 0x08, 0xF4}));
  EXPECT_EQ(sut.id(), 1);
}

TEST(Protocol1Servo, WriteToReadOnlyRegisterIsARangeError) {
  auto sut = make_servo("RX-28");
  // Present Position (36) := 512
  EXPECT_EQ(transact(sut, Bytes{0xFF, 0xFF, 0x01, 0x05, 0x03, 0x24, 0x00, 0x02, 0xD0}),
            (Bytes{0xFF, 0xFF, 0x01, 0x02, 0x08, 0xF4}));
}

TEST(Protocol1Servo, ReadPastTheEndOfTheTableIsARangeErrorWithoutData) {
  auto sut = make_servo("RX-28");
  // READ 49, 2 bytes: the AX/RX table ends at 49.
  EXPECT_EQ(transact(sut, Bytes{0xFF, 0xFF, 0x01, 0x04, 0x02, 0x31, 0x02, 0xC5}),
            (Bytes{0xFF, 0xFF, 0x01, 0x02, 0x08, 0xF4}));
}

TEST(Protocol1Servo, MultiByteWriteIsAtomic) {
  auto sut = make_servo("RX-28");
  const uint16_t goal = sut.register_raw(p1::kGoalPosition);
  // Goal Position 512 and Moving Speed 2000 (joint mode allows 0..1023) in one WRITE.
  EXPECT_EQ(transact(sut, Bytes{0xFF, 0xFF, 0x01, 0x07, 0x03, 0x1E, 0x00, 0x02, 0xD0, 0x07, 0xFD}),
            (Bytes{0xFF, 0xFF, 0x01, 0x02, 0x08, 0xF4}));
  EXPECT_EQ(sut.register_raw(p1::kGoalPosition), goal);
  EXPECT_EQ(sut.register_raw(p1::kMovingSpeed), 0);
}

TEST(Protocol1Servo, WriteSpanningAReservedByteIsARangeError) {
  auto sut = make_servo("AX-12A");
  EXPECT_EQ(transact(sut, make_packet(1, instruction::kWrite, {44, 0, 0})), (Bytes{0xFF, 0xFF, 0x01, 0x02, 0x08, 0xF4}));
}

TEST(Protocol1Servo, GoalOutsideAngleLimitsIsAnAngleLimitErrorAndNotStored) {
  auto sut = make_servo("RX-64");
  // CW limit 100, CCW limit 900.
  ASSERT_EQ(transact(sut, Bytes{0xFF, 0xFF, 0x01, 0x07, 0x03, 0x06, 0x64, 0x00, 0x84, 0x03, 0x03}),
            (Bytes{0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC}));
  const uint16_t goal = sut.register_raw(p1::kGoalPosition);

  // Goal 50: ERR 0x02, ~(01 + 02 + 02) = 0xFA
  EXPECT_EQ(transact(sut, Bytes{0xFF, 0xFF, 0x01, 0x05, 0x03, 0x1E, 0x32, 0x00, 0xA6}),
            (Bytes{0xFF, 0xFF, 0x01, 0x02, 0x02, 0xFA}));
  EXPECT_EQ(sut.register_raw(p1::kGoalPosition), goal);
  EXPECT_EQ(transact(sut, make_packet(1, instruction::kWrite, {p1::kGoalPosition, 0x84, 0x03})),
            (Bytes{0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC}));
  EXPECT_EQ(sut.register_raw(p1::kGoalPosition), 900);
}

TEST(Protocol1Servo, WheelModeAcceptsAnyGoalAndSignedSpeed) {
  auto sut = make_servo("AX-12A");
  ASSERT_EQ(transact(sut, make_packet(1, instruction::kWrite, {p1::kCwAngleLimit, 0, 0, 0, 0}))[4], 0);
  ASSERT_EQ(sut.mode(), ServoMode::kWheel);

  EXPECT_EQ(transact(sut, make_packet(1, instruction::kWrite, {p1::kMovingSpeed, 0x64, 0x04}))[4], 0);  // 1124
  const ServoCommand c = sut.command();

  EXPECT_TRUE(c.wheel_mode);
  EXPECT_NEAR(c.moving_speed_rad_s, -100 * 0.111 * 2 * kPi / 60, 1e-9);
}

TEST(Protocol1Servo, RegWriteOutOfRangeIsNotRegistered) {
  auto sut = make_servo("RX-28");
  EXPECT_EQ(transact(sut, make_packet(1, instruction::kRegWrite, {p1::kId, 254})), (Bytes{0xFF, 0xFF, 0x01, 0x02, 0x08, 0xF4}));
  EXPECT_EQ(sut.register_raw(p1::kRegistered), 0);
}

TEST(Protocol1Servo, UnicastActionIsAnswered) {
  auto sut = make_servo("RX-28");
  ASSERT_EQ(transact(sut, make_packet(1, instruction::kRegWrite, {p1::kLed, 1}))[4], 0);

  EXPECT_EQ(transact(sut, make_packet(1, instruction::kAction)), (Bytes{0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC}));
  EXPECT_EQ(sut.register_raw(p1::kLed), 1);
}

// Lock (47).

TEST(Protocol1Servo, LockAllowsOnly24To35) {
  auto sut = make_servo("RX-64");
  ASSERT_EQ(transact(sut, make_packet(1, instruction::kWrite, {p1::kLock, 1}))[4], 0);

  EXPECT_EQ(transact(sut, make_packet(1, instruction::kWrite, {p1::kMaxTorque, 0x00, 0x02}))[4], p1_error::kRange);
  EXPECT_EQ(transact(sut, make_packet(1, instruction::kWrite, {p1::kPunch, 0x40, 0x00}))[4], p1_error::kRange);
  EXPECT_EQ(transact(sut, make_packet(1, instruction::kWrite, {p1::kLock, 0}))[4], p1_error::kRange);
  EXPECT_EQ(transact(sut, make_packet(1, instruction::kWrite, {p1::kTorqueLimit, 0x00, 0x02}))[4], 0);
  EXPECT_EQ(transact(sut, make_packet(1, instruction::kWrite, {p1::kTorqueEnable, 1}))[4], 0);
  EXPECT_TRUE(sut.locked());
  EXPECT_EQ(sut.register_raw(p1::kMaxTorque), 1023);
  EXPECT_EQ(sut.register_raw(p1::kTorqueLimit), 512);
}

// ID and baud changes take effect after the status.

TEST(Protocol1Servo, IdChangeAnswersWithOldId) {
  auto sut = make_servo("RX-28");
  EXPECT_EQ(transact(sut, Bytes{0xFF, 0xFF, 0x01, 0x04, 0x03, 0x03, 0x07, 0xED}),
            (Bytes{0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC}));
  EXPECT_EQ(sut.id(), 7);
  EXPECT_TRUE(transact(sut, make_packet(1, instruction::kPing)).empty());
  // ~(07 + 02 + 00) = 0xF6
  EXPECT_EQ(transact(sut, make_packet(7, instruction::kPing)), (Bytes{0xFF, 0xFF, 0x07, 0x02, 0x00, 0xF6}));
}

TEST(Protocol1Servo, BaudChangeTakesEffectAfterTheStatus) {
  Protocol1Servo sut(model_spec("RX-28"), 1, 34, 250);
  EXPECT_EQ(sut.baud_bps(), 57142u);

  EXPECT_EQ(transact(sut, make_packet(1, instruction::kWrite, {p1::kBaudRate, 1})), (Bytes{0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC}));
  EXPECT_EQ(sut.baud_bps(), 1000000u);
}

// Power-on values.

TEST(Protocol1Servo, PowerOnGoalIsPresentAndTorqueLimitIsMaxTorque) {
  Protocol1Servo sut(model_spec("MX-28"), 1, 1, 250, kPi / 2);

  EXPECT_EQ(sut.register_raw(p1::kPresentPosition), 2048 + 1024);
  EXPECT_EQ(sut.register_raw(p1::kGoalPosition), 2048 + 1024);
  EXPECT_EQ(sut.register_raw(p1::kTorqueLimit), sut.register_raw(p1::kMaxTorque));

  ASSERT_EQ(transact(sut, make_packet(1, instruction::kWrite, {p1::kMaxTorque, 0x00, 0x02}))[4], 0);
  sut.power_on(0.0);
  EXPECT_EQ(sut.register_raw(p1::kTorqueLimit), 512);
  EXPECT_EQ(sut.register_raw(p1::kGoalPosition), 2048);
}

TEST(Protocol1Servo, ConstructionRejectsBadConfig) {
  EXPECT_THROW(Protocol1Servo(model_spec("RX-28"), 254, 1, 250), std::invalid_argument);
  EXPECT_THROW(Protocol1Servo(model_spec("RX-28"), 1, 255, 250), std::invalid_argument);
  EXPECT_THROW(Protocol1Servo(model_spec("RX-28"), 1, 1, 255), std::invalid_argument);
  EXPECT_THROW(Protocol1Servo(model_spec("FUMANOID-IMU"), 1, 1, 250), std::invalid_argument);
}

// Feedback -> registers.

TEST(Protocol1ServoFeedback, ZeroRadiansIsTheCentre) {
  auto rx = make_servo("RX-64");
  auto mx = make_servo("MX-64");
  rx.apply(at(0.0));
  mx.apply(at(0.0));
  EXPECT_EQ(rx.register_raw(p1::kPresentPosition), 512);
  EXPECT_EQ(mx.register_raw(p1::kPresentPosition), 2048);
}

TEST(Protocol1ServoFeedback, AxRxPositionSaturatesMxWraps) {
  auto ax = make_servo("AX-12A");
  auto mx = make_servo("MX-28");
  ax.apply(at(kPi));  // beyond 150 deg: potentiometer end
  mx.apply(at(kPi));  // 180 deg = 2048 + 2048 = 4096 -> 0
  EXPECT_EQ(ax.register_raw(p1::kPresentPosition), 1023);
  EXPECT_EQ(mx.register_raw(p1::kPresentPosition), 0);
  ax.apply(at(-kPi));
  EXPECT_EQ(ax.register_raw(p1::kPresentPosition), 0);
  // 90 deg on an AX: 90 / (300 / 1024) = 307.2 units
  ax.apply(at(kPi / 2));
  EXPECT_EQ(ax.register_raw(p1::kPresentPosition), 512 + 307);
}

TEST(Protocol1ServoFeedback, SpeedMagnitudeAndDirectionBit) {
  auto rx = make_servo("RX-28");
  auto mx = make_servo("MX-28");
  ServoFeedback f = at(0.0);
  f.velocity_rad_s = 1.0;  // 9.549 rpm: 86.03 units of 0.111 rpm, 83.76 of 0.114 rpm
  rx.apply(f);
  mx.apply(f);
  EXPECT_EQ(rx.register_raw(p1::kPresentSpeed), 86);
  EXPECT_EQ(mx.register_raw(p1::kPresentSpeed), 84);

  f.velocity_rad_s = -1.0;  // CW: bit 10
  rx.apply(f);
  EXPECT_EQ(rx.register_raw(p1::kPresentSpeed), 1024 + 86);

  f.velocity_rad_s = 100.0;  // saturates at 1023
  rx.apply(f);
  EXPECT_EQ(rx.register_raw(p1::kPresentSpeed), 1023);
}

TEST(Protocol1ServoFeedback, LoadVoltageTemperature) {
  auto sut = make_servo("RX-64");
  ServoFeedback f = at(0.0);
  f.torque_ratio = -0.25;  // 255.75 -> 256, CW
  f.voltage_v = 14.8;
  f.temperature_c = 41.4;
  sut.apply(f);

  EXPECT_EQ(sut.register_raw(p1::kPresentLoad), 1024 + 256);
  EXPECT_EQ(sut.register_raw(p1::kPresentVoltage), 148);
  EXPECT_EQ(sut.register_raw(p1::kPresentTemperature), 41);
  f.torque_ratio = 0.5;
  sut.apply(f);
  EXPECT_EQ(sut.register_raw(p1::kPresentLoad), 512);
}

TEST(Protocol1ServoFeedback, MovingFlag) {
  auto sut = make_servo("RX-28");
  sut.apply(at(0.0));
  EXPECT_EQ(sut.register_raw(p1::kMoving), 0);

  ASSERT_EQ(transact(sut, make_packet(1, instruction::kWrite, {p1::kTorqueEnable, 1}))[4], 0);
  ASSERT_EQ(transact(sut, make_packet(1, instruction::kWrite, {p1::kGoalPosition, 0x58, 0x02}))[4], 0);  // 600
  sut.apply(at(0.0));
  EXPECT_EQ(sut.register_raw(p1::kMoving), 1);

  sut.apply(at((600 - 512) / sut.spec().servo.units_per_rad()));
  EXPECT_EQ(sut.register_raw(p1::kMoving), 0);
}

TEST(Protocol1ServoFeedback, MxCurrentAndRealtimeTick) {
  auto sut = make_servo("MX-64");
  ServoFeedback f = at(0.0);
  f.current_a = 2.05;  // 455.6 units of 4.5 mA
  f.sim_time_ns = 40'000'123'000;  // 40000 ms -> 40000 % 32768 = 7232
  sut.apply(f);

  EXPECT_EQ(sut.register_raw(p1::kCurrent), 2048 + 456);
  EXPECT_EQ(sut.register_raw(p1::kRealtimeTick), 7232);
}

// Condition bits and Alarm Shutdown.

TEST(Protocol1ServoConditions, OverheatingIsReportedAndShutsTorqueOff) {
  auto sut = make_servo("RX-28");
  ASSERT_EQ(transact(sut, make_packet(1, instruction::kWrite, {p1::kTorqueEnable, 1}))[4], 0);
  ServoFeedback hot = at(0.0);
  hot.temperature_c = 81.0;  // limit 80
  sut.apply(hot);

  // ~(01 + 02 + 04) = 0xF8
  EXPECT_EQ(transact(sut, make_packet(1, instruction::kPing)), (Bytes{0xFF, 0xFF, 0x01, 0x02, 0x04, 0xF8}));
  EXPECT_EQ(sut.register_raw(p1::kTorqueEnable), 0);
  EXPECT_FALSE(sut.command().torque_enabled);

  // Re-enabling while still hot does not stick.
  ASSERT_EQ(transact(sut, make_packet(1, instruction::kWrite, {p1::kTorqueEnable, 1}))[4], p1_error::kOverheating);
  EXPECT_FALSE(sut.command().torque_enabled);
  sut.apply(hot);
  EXPECT_EQ(sut.register_raw(p1::kTorqueEnable), 0);

  // Cooled down: the host enables torque again.
  sut.apply(at(0.0));
  EXPECT_EQ(transact(sut, make_packet(1, instruction::kPing)), (Bytes{0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC}));
  ASSERT_EQ(transact(sut, make_packet(1, instruction::kWrite, {p1::kTorqueEnable, 1}))[4], 0);
  sut.apply(at(0.0));
  EXPECT_TRUE(sut.command().torque_enabled);
}

TEST(Protocol1ServoConditions, InputVoltageIsReportedButNotInDefaultShutdownMask) {
  auto sut = make_servo("RX-28");
  ASSERT_EQ(transact(sut, make_packet(1, instruction::kWrite, {p1::kTorqueEnable, 1}))[4], 0);
  ServoFeedback f = at(0.0);
  f.voltage_v = 20.0;  // Max Voltage Limit 190 = 19.0 V
  sut.apply(f);

  EXPECT_EQ(transact(sut, make_packet(1, instruction::kPing)), (Bytes{0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB}));
  EXPECT_TRUE(sut.command().torque_enabled);
  f.voltage_v = 5.9;  // Min 60 = 6.0 V
  sut.apply(f);
  EXPECT_EQ(sut.conditions(), p1_error::kInputVoltage);
}

TEST(Protocol1ServoConditions, BlockedAtTheTorqueLimitIsOverloadAfterTheControllersTime) {
  // The firmware as a whole: the motor controller drives a joint blocked at 0 rad toward a far
  // goal at full duty (= Torque Limit); after its overload time the Overload bit appears.
  auto sut = make_servo("RX-64");
  ServoController controller(servo_controller_config("RX-64"));
  ASSERT_EQ(transact(sut, make_packet(1, instruction::kWrite, {p1::kGoalPosition, 0xFF, 0x03}))[4], 0);
  ASSERT_EQ(transact(sut, make_packet(1, instruction::kWrite, {p1::kTorqueEnable, 1}))[4], 0);
  ServoFeedback f = at(0.0);
  int overload_ms = 0;
  for (int ms = 1; ms <= 1500 && sut.conditions() == 0; ++ms) {
    const ControllerOutput out = controller.update(sut.command(), 0.0, 0.0, 0.001);
    f.overload = out.overload;
    f.torque_ratio = out.pwm_ratio;
    f.sim_time_ns = ms * 1'000'000LL;
    sut.apply(f);
    overload_ms = ms;
  }

  EXPECT_GE(overload_ms, 999);  // ServoControllerConfig::overload_time_s = 1 s (assumption)
  EXPECT_LE(overload_ms, 1001);
  // ~(01 + 02 + 20) = 0xDC
  EXPECT_EQ(transact(sut, make_packet(1, instruction::kPing)), (Bytes{0xFF, 0xFF, 0x01, 0x02, 0x20, 0xDC}));
  EXPECT_EQ(sut.register_raw(p1::kTorqueEnable), 0);  // Alarm Shutdown default 36 includes overload
}

TEST(Protocol1ServoConditions, ControllerOverloadCountsOnlyWithTorqueOn) {
  auto sut = make_servo("RX-64");
  ServoFeedback f = at(0.0);
  f.overload = true;
  sut.apply(f);
  EXPECT_EQ(sut.conditions(), 0);

  ASSERT_EQ(transact(sut, make_packet(1, instruction::kWrite, {p1::kTorqueEnable, 1}))[4], 0);
  sut.apply(f);
  EXPECT_EQ(sut.conditions(), p1_error::kOverload);
}

TEST(Protocol1ServoConditions, OverloadAndOverheatingTogetherAsInReference) {
  auto sut = make_servo("RX-64");
  ASSERT_EQ(transact(sut, make_packet(1, instruction::kWrite, {p1::kTorqueEnable, 1}))[4], 0);
  ServoFeedback f = at(0.0);
  f.torque_ratio = -1.0;
  f.overload = true;
  f.temperature_c = 85.0;
  sut.apply(f);

  // Reference §1.4 example: FF FF 01 02 24 D8 = ID 1, overload + overheating.
  EXPECT_EQ(transact(sut, make_packet(1, instruction::kPing)), (Bytes{0xFF, 0xFF, 0x01, 0x02, 0x24, 0xD8}));
}

TEST(Protocol1ServoConditions, ShutdownMaskZeroKeepsTorque) {
  auto sut = make_servo("RX-28");
  ASSERT_EQ(transact(sut, make_packet(1, instruction::kWrite, {p1::kAlarmShutdown, 0}))[4], 0);
  ASSERT_EQ(transact(sut, make_packet(1, instruction::kWrite, {p1::kTorqueEnable, 1}))[4], 0);
  ServoFeedback hot = at(0.0);
  hot.temperature_c = 100.0;
  sut.apply(hot);
  EXPECT_EQ(sut.conditions(), p1_error::kOverheating);
  EXPECT_TRUE(sut.command().torque_enabled);
}

// Registers -> command.

TEST(Protocol1ServoCommand, JointModeConversions) {
  auto sut = make_servo("RX-64");
  ASSERT_EQ(transact(sut, make_packet(1, instruction::kWrite, {p1::kTorqueEnable, 1}))[4], 0);
  // Goal 0x300 = 768, Moving Speed 100, Torque Limit 512.
  ASSERT_EQ(transact(sut, make_packet(1, instruction::kWrite, {p1::kGoalPosition, 0x00, 0x03, 100, 0, 0x00, 0x02}))[4], 0);
  const ServoCommand c = sut.command();

  EXPECT_TRUE(c.torque_enabled);
  EXPECT_FALSE(c.wheel_mode);
  EXPECT_NEAR(c.goal_position_rad, 256 * (300.0 / 1024.0) * kPi / 180.0, 1e-12);
  EXPECT_NEAR(c.moving_speed_rad_s, 100 * 0.111 * 2 * kPi / 60, 1e-12);
  EXPECT_NEAR(c.torque_limit_ratio, 512.0 / 1023.0, 1e-12);
  EXPECT_NEAR(c.min_position_rad, -512 * (300.0 / 1024.0) * kPi / 180.0, 1e-12);
  EXPECT_NEAR(c.max_position_rad, 511 * (300.0 / 1024.0) * kPi / 180.0, 1e-12);
  EXPECT_EQ(c.cw_compliance_slope_raw, 32);
  EXPECT_EQ(c.punch_raw, 32);
}

TEST(Protocol1ServoCommand, MovingSpeedZeroMeansNoLimit) {
  auto sut = make_servo("MX-28");
  EXPECT_EQ(sut.command().moving_speed_rad_s, 0.0);
  EXPECT_DOUBLE_EQ(sut.command().pid.kp, 32.0 / 8.0);  // default P Gain 32, Kp = P / 8
}

TEST(Protocol1ServoCommand, MxMultiTurn) {
  auto sut = make_servo("MX-28");
  ASSERT_EQ(transact(sut, make_packet(1, instruction::kWrite, {p1::kCwAngleLimit, 0xFF, 0x0F, 0xFF, 0x0F}))[4], 0);
  ASSERT_EQ(sut.mode(), ServoMode::kMultiTurn);

  // Goal -4096 + 2048 = -2048: one turn CW of 0 rad.
  EXPECT_EQ(transact(sut, make_packet(1, instruction::kWrite, {p1::kGoalPosition, 0x00, 0xF8}))[4], 0);
  EXPECT_TRUE(sut.command().multi_turn);
  EXPECT_NEAR(sut.command().goal_position_rad, -2 * kPi, 1e-12);

  sut.apply(at(4 * kPi));  // two turns CCW
  EXPECT_EQ(sut.register_raw(p1::kPresentPosition), 2048 + 8192);
}

TEST(Protocol1ServoCommand, MxGoalOutsideOneTurnIsARangeErrorInJointMode) {
  auto sut = make_servo("MX-106");
  EXPECT_EQ(transact(sut, make_packet(1, instruction::kWrite, {p1::kGoalPosition, 0x00, 0x10}))[4], p1_error::kRange);
}

TEST(Protocol1ServoCommand, MxGoalTorque) {
  auto sut = make_servo("MX-106");
  ASSERT_EQ(transact(sut, make_packet(1, instruction::kWrite, {p1::kTorqueCtrlModeEnable, 1, 0x00, 0x05}))[4], 0);
  const ServoCommand c = sut.command();
  EXPECT_TRUE(c.torque_control);
  // 0x500: CW, magnitude 256 x 4.5 mA = 1.152 A.
  EXPECT_NEAR(c.goal_current_a, -1.152, 1e-12);
}

}  // namespace
}  // namespace doppel::dynamixel
