// Bit-Bots boards: golden packets from shared/reference/dynamixel.md §8.7, quirks from §8.1.
#include "dynamixel/bitbots_boards.h"

#include <gtest/gtest.h>

#include <bit>
#include <variant>
#include <vector>

#include "dynamixel/bus_devices.h"
#include "dynamixel/protocol2.h"
#include "dynamixel/protocol2_factory.h"
#include "test_support.h"

namespace doppel::dynamixel {
namespace {

using testing::Bytes;
using testing::p2::instruction;
using testing::p2::parse;
using testing::p2::status;
using testing::p2::transact;

Bytes f32(float v) {
  const auto raw = std::bit_cast<uint32_t>(v);
  return {static_cast<uint8_t>(raw), static_cast<uint8_t>(raw >> 8), static_cast<uint8_t>(raw >> 16),
          static_cast<uint8_t>(raw >> 24)};
}

TEST(BitbotsImu, PingOfTheReference) {
  BitbotsImu sut(241, 6);
  EXPECT_EQ(transact(sut, {0xFF, 0xFF, 0xFD, 0x00, 0xF1, 0x03, 0x00, 0x01, 0x31, 0x8E}),
            (Bytes{0xFF, 0xFF, 0xFD, 0x00, 0xF1, 0x07, 0x00, 0x55, 0x00, 0xFF, 0xBA, 0x01, 0xCB, 0xD7}));
}

TEST(BitbotsImu, PerCycleReadLevelAndAtRest) {
  BitbotsImu sut(241, 6);
  ImuFeedback level;  // gyro 0, accel (0, 0, 9.80665), roll = pitch = yaw = 0
  sut.apply(level);
  Bytes expected = {0xFF, 0xFF, 0xFD, 0x00, 0xF1, 0x2C, 0x00, 0x55, 0x00};
  expected.insert(expected.end(), 20, 0x00);
  for (uint8_t b : {0x0A, 0xE8, 0x1C, 0x41}) expected.push_back(b);
  expected.insert(expected.end(), 12, 0x00);
  for (uint8_t b : {0x00, 0x00, 0x80, 0x3F, 0x2B, 0xEC}) expected.push_back(b);
  EXPECT_EQ(transact(sut, {0xFF, 0xFF, 0xFD, 0x00, 0xF1, 0x07, 0x00, 0x02, 0x24, 0x00, 0x28, 0x00, 0x2F, 0x7F}), expected);
}

TEST(BitbotsImu, QuaternionFollowsRollPitchYaw) {
  BitbotsImu sut(241, 6);
  ImuFeedback f;
  f.yaw_rad = 3.14159265358979323846 / 2.0;  // quarter turn about z: (0, 0, sin 45, cos 45)
  sut.apply(f);
  Bytes expected = f32(0.0f);
  for (Bytes b : {f32(0.0f), f32(0.70710678f), f32(0.70710678f)}) expected.insert(expected.end(), b.begin(), b.end());
  EXPECT_EQ(transact(sut, instruction(241, instruction::kRead, {60, 0, 16, 0})), status(241, 0, expected));
}

TEST(BitbotsImu, DriverInitReadsAndLedWriteOfTheReference) {
  BitbotsImu sut(241, 6);
  // READ 102 len 16: ranges 3 and 1, 104..107 unregistered, flags 0, accel gain 0.04, bias alpha 0.01.
  Bytes params = {3, 1, 0, 0, 0, 0, 0, 0};
  for (Bytes b : {f32(0.04f), f32(0.01f)}) params.insert(params.end(), b.begin(), b.end());
  EXPECT_EQ(transact(sut, {0xFF, 0xFF, 0xFD, 0x00, 0xF1, 0x07, 0x00, 0x02, 0x66, 0x00, 0x10, 0x00, 0x32, 0x47}),
            status(241, 0, params));
  // READ 118 len 28: the old firmware's calibration items, unregistered in the current one.
  EXPECT_EQ(transact(sut, {0xFF, 0xFF, 0xFD, 0x00, 0xF1, 0x07, 0x00, 0x02, 0x76, 0x00, 0x1C, 0x00, 0x34, 0x2F}),
            status(241, 0, Bytes(28, 0)));
  // LED2 = (76, 76, 76) plus an A byte on the unregistered address 21.
  EXPECT_EQ(transact(sut, {0xFF, 0xFF, 0xFD, 0x00, 0xF1, 0x09, 0x00, 0x03, 0x12, 0x00, 0x4C, 0x4C, 0x4C, 0xFF, 0x64, 0xCA}),
            status(241, 0));
  EXPECT_EQ(transact(sut, instruction(241, instruction::kRead, {18, 0, 4, 0})), status(241, 0, {76, 76, 76, 0}));
  // Buttons (76, 3): not pressed.
  EXPECT_EQ(transact(sut, {0xFF, 0xFF, 0xFD, 0x00, 0xF1, 0x07, 0x00, 0x02, 0x4C, 0x00, 0x03, 0x00, 0x3D, 0xA5}),
            status(241, 0, {0, 0, 0}));
}

TEST(BitbotsBoards, PartialItemsReadZeroAndAreNotWritten) {
  BitbotsImu sut(241, 6);
  // READ 38 len 2 cuts the gyro x float: 00 00 (§8.1 example).
  ImuFeedback spinning;
  spinning.w_WS_S_rad_s = {1.5, 0.0, 0.0};
  sut.apply(spinning);
  EXPECT_EQ(transact(sut, instruction(241, instruction::kRead, {38, 0, 2, 0})), status(241, 0, {0, 0}));
  // A write covering half of the accel-gain float changes nothing and still reports success.
  EXPECT_EQ(transact(sut, instruction(241, instruction::kWrite, {112, 0, 0x11, 0x22})), status(241, 0));
  EXPECT_EQ(transact(sut, instruction(241, instruction::kRead, {110, 0, 4, 0})), status(241, 0, f32(0.04f)));
  // The model number is read-only.
  EXPECT_EQ(transact(sut, instruction(241, instruction::kWrite, {0, 0, 0x34, 0x12})), status(241, 0));
  EXPECT_EQ(transact(sut, instruction(241, instruction::kRead, {0, 0, 2, 0})), status(241, 0, {0xFF, 0xBA}));
}

TEST(BitbotsBoards, OnlyUnicastPingReadWriteAreAnswered) {
  BitbotsImu sut(241, 6);
  EXPECT_TRUE(transact(sut, {0xFF, 0xFF, 0xFD, 0x00, 0xFE, 0x03, 0x00, 0x01, 0x31, 0x42}).empty());  // broadcast PING
  EXPECT_TRUE(transact(sut, instruction(0xFE, instruction::kSyncRead, {36, 0, 4, 0, 241})).empty());
  EXPECT_TRUE(transact(sut, instruction(0xFE, instruction::kWrite, {10, 0, 9})).empty());
  EXPECT_EQ(sut.table()[10], 0);  // broadcast WRITE not executed
  for (uint8_t inst : {instruction::kRegWrite, instruction::kAction, instruction::kFactoryReset, instruction::kReboot,
                       instruction::kClear, instruction::kControlTableBackup}) {
    EXPECT_TRUE(transact(sut, instruction(241, inst, {10, 0, 1})).empty()) << int(inst);
  }
  // Bad CRC: dropped without a status.
  EXPECT_TRUE(transact(sut, {0xFF, 0xFF, 0xFD, 0x00, 0xF1, 0x03, 0x00, 0x01, 0x31, 0x8F}).empty());
}

TEST(BitbotsBoards, IdAboveTheRangeIsADataRangeErrorAndBaudWriteRestartsSilently) {
  BitFoot sut(101, 4);
  EXPECT_EQ(transact(sut, instruction(101, instruction::kWrite, {7, 0, 253})), status(101, p2_error::kDataRange));
  EXPECT_EQ(sut.id(), 101);
  EXPECT_TRUE(transact(sut, instruction(101, instruction::kWrite, {8, 0, 6})).empty());
  EXPECT_EQ(sut.restarts(), 1u);
  EXPECT_EQ(sut.baud_bps(), 4000000u);
  EXPECT_EQ(transact(sut, instruction(101, instruction::kWrite, {7, 0, 102})), status(101, 0));
  EXPECT_EQ(sut.id(), 102);
}

TEST(BitFoot, PingAndReadOfTheReference) {
  BitFoot right(101, 4, {0.0, 1.0, false});
  BitFoot left(102, 4);
  EXPECT_EQ(transact(right, instruction(101, instruction::kPing)),
            (Bytes{0xFF, 0xFF, 0xFD, 0x00, 0x65, 0x07, 0x00, 0x55, 0x00, 0x00, 0x00, 0x01, 0x80, 0x84}));
  EXPECT_EQ(transact(left, instruction(102, instruction::kPing)),
            (Bytes{0xFF, 0xFF, 0xFD, 0x00, 0x66, 0x07, 0x00, 0x55, 0x00, 0x00, 0x00, 0x01, 0x8A, 0xB4}));
  FootFeedback f;
  f.force_n = {100000.0, -2000.0, 350000.0, 0.0};  // with zero 0 and 1 N per count: the counts themselves
  right.apply(f);
  EXPECT_EQ(transact(right, {0xFF, 0xFF, 0xFD, 0x00, 0x65, 0x07, 0x00, 0x02, 0x24, 0x00, 0x10, 0x00, 0x62, 0x2C}),
            (Bytes{0xFF, 0xFF, 0xFD, 0x00, 0x65, 0x14, 0x00, 0x55, 0x00, 0xA0, 0x86, 0x01, 0x00, 0x30, 0xF8, 0xFF, 0xFF,
                   0x30, 0x57, 0x05, 0x00, 0x00, 0x00, 0x00, 0x00, 0x9F, 0xA2}));
  // Left foot's request is golden too; it answers with its own ID.
  const Bytes reply = transact(left, {0xFF, 0xFF, 0xFD, 0x00, 0x66, 0x07, 0x00, 0x02, 0x24, 0x00, 0x10, 0x00, 0x68, 0x1C});
  ASSERT_EQ(reply.size(), 27u);
  EXPECT_EQ(reply[4], 0x66);
}

TEST(BitFoot, DefaultCalibrationInvertsThePressureConverter) {
  BitFoot sut(101, 4);
  FootFeedback f;
  f.force_n = {9.0, 0.0, 0.0, 0.0};
  sut.apply(f);
  // newton = (raw - zero) * scale  ->  raw = 1e7 + 9 / 3e-6 = 13 000 000.
  const Bytes reply = transact(sut, instruction(101, instruction::kRead, {36, 0, 4, 0}));
  EXPECT_EQ(reply, status(101, 0, {0x40, 0x5D, 0xC6, 0x00}));
}

TEST(BitFoot, Float32Option) {
  BitFoot sut(101, 4, {0.0, 1.0, true});
  FootFeedback f;
  f.force_n = {1.5, 0.0, 0.0, 0.0};
  sut.apply(f);
  EXPECT_EQ(transact(sut, instruction(101, instruction::kRead, {36, 0, 4, 0})), status(101, 0, f32(1.5f)));
}

TEST(BitbotsCore, PingAndDriverRead) {
  BitbotsCore sut(42, 4);
  EXPECT_EQ(transact(sut, instruction(42, instruction::kPing)), status(42, 0, {0xBA, 0xAB, 0x01}));
  sut.apply(14.8, 1.0);
  const Bytes reply = transact(sut, instruction(42, instruction::kRead, {23, 0, 27, 0}));
  ASSERT_EQ(reply.size(), 11u + 27u);
  const uint8_t* d = reply.data() + 9;  // address 23
  EXPECT_EQ(d[0], 1);                   // Power
  const auto u16 = [&](uint16_t address) { return d[address - 23] | (d[address - 23 + 1] << 8); };
  // Driver decoding: V = raw * 3.3 / 1024 * 6, A = (raw * 3.3 / 1024 - 2.5) / -0.066.
  EXPECT_NEAR(u16(bitbots::kVext) * 3.3 / 1024 * 6, 14.8, 0.02);
  EXPECT_NEAR(u16(bitbots::kVdxl) * 3.3 / 1024 * 6, 14.8, 0.02);
  EXPECT_NEAR((u16(bitbots::kCurrent) * 3.3 / 1024 - 2.5) / -0.066, 1.0, 0.05);
  // Power off: VDXL drops.
  EXPECT_EQ(transact(sut, instruction(42, instruction::kWrite, {23, 0, 0})), status(42, 0));
  sut.apply(14.8, 1.0);
  EXPECT_EQ(transact(sut, instruction(42, instruction::kRead, {32, 0, 2, 0})), status(42, 0, {0, 0}));
}

TEST(BitbotsBoards, FactoryGivesEachBoardItsRole) {
  const BuiltDevice imu = make_protocol2_device("BITBOTS-IMU", 241, 1000000);
  const BuiltDevice foot = make_protocol2_device("BITFOOT", 101, 1000000);
  const BuiltDevice core = make_protocol2_device("BITBOTS-CORE", 42, 2000000);

  EXPECT_EQ(std::get<SimulatedImu*>(imu.role), dynamic_cast<BitbotsImu*>(imu.device.get()));
  EXPECT_EQ(std::get<SimulatedFootBoard*>(foot.role), dynamic_cast<BitFoot*>(foot.device.get()));
  auto* board = dynamic_cast<BitbotsCore*>(core.device.get());
  ASSERT_NE(board, nullptr);
  ASSERT_EQ(std::get<SimulatedPowerBoard*>(core.role), board);
  // The power board's role takes the supply and the servos' current as one measurement.
  std::get<SimulatedPowerBoard*>(core.role)->apply(PowerFeedback{12.0, 2.0, 0});
  const auto u16 = [&](uint16_t address) { return board->table()[address] | (board->table()[address + 1] << 8); };
  EXPECT_NEAR(u16(bitbots::kVext) * 3.3 / 1024 * 6, 12.0, 0.02);
  EXPECT_NEAR((u16(bitbots::kCurrent) * 3.3 / 1024 - 2.5) / -0.066, 2.0, 0.05);
}

TEST(BitbotsBoards, BaudIndexSevenIsFiveMegabaudOnTheCore) {
  BitbotsCore core(42, 7);
  BitbotsImu imu(241, 7);
  EXPECT_EQ(core.baud_bps(), 5000000u);
  EXPECT_EQ(imu.baud_bps(), 4500000u);
}

TEST(BitbotsBoards, NotFoundByABroadcastPingNextToServos) {
  BitbotsImu imu(241, 6);
  BusDevices bus;
  bus.add(imu);
  EXPECT_TRUE(bus.dispatch(parse({0xFF, 0xFF, 0xFD, 0x00, 0xFE, 0x03, 0x00, 0x01, 0x31, 0x42}), 4000000).empty());
}

}  // namespace
}  // namespace doppel::dynamixel
