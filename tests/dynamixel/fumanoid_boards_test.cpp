#include "dynamixel/fumanoid_boards.h"

#include <gtest/gtest.h>

#include <numbers>

#include "test_support.h"

namespace doppel::dynamixel {
namespace {

using testing::Bytes;
using testing::make_packet;
using testing::transact;

constexpr int64_t kMs = 1'000'000;

ImuFeedback imu_at(int64_t t_ns, double pitch_rad) {
  ImuFeedback f;
  f.sim_time_ns = t_ns;
  f.pitch_rad = pitch_rad;
  return f;
}

int16_t as_int16(uint16_t raw) { return static_cast<int16_t>(raw); }

TEST(FumanoidImu, PingAndModelNumber) {
  FumanoidImu sut(100, 1, 250);
  // ~(0x64 + 0x02 + 0x00) = 0x99
  EXPECT_EQ(transact(sut, Bytes{0xFF, 0xFF, 0x64, 0x02, 0x01, 0x98}), (Bytes{0xFF, 0xFF, 0x64, 0x02, 0x00, 0x99}));
  // READ 0, 3: model 0x4649, firmware 1. ~(64 + 05 + 00 + 49 + 46 + 01) = ~0xF9 = 0x06
  EXPECT_EQ(transact(sut, make_packet(100, instruction::kRead, {0, 3})),
            (Bytes{0xFF, 0xFF, 0x64, 0x05, 0x00, 0x49, 0x46, 0x01, 0x06}));
}

TEST(FumanoidImu, LatchesAt50Hz) {
  FumanoidImu sut(100, 1, 250);
  ASSERT_EQ(sut.sample_period_ns(), 20 * kMs);

  sut.apply(imu_at(0, 0.1));
  EXPECT_EQ(as_int16(sut.register_raw(fumanoid::kPitch)), 1000);
  sut.apply(imu_at(10 * kMs, 0.2));
  sut.apply(imu_at(20 * kMs - 1, 0.25));
  EXPECT_EQ(as_int16(sut.register_raw(fumanoid::kPitch)), 1000);
  EXPECT_EQ(sut.register_raw(fumanoid::kSampleCounter), 1);

  sut.apply(imu_at(20 * kMs, 0.3));
  EXPECT_EQ(as_int16(sut.register_raw(fumanoid::kPitch)), 3000);
  EXPECT_EQ(sut.register_raw(fumanoid::kSampleCounter), 2);

  // Off-grid feed: the first sample at or after 40 ms is latched, the grid does not drift.
  sut.apply(imu_at(41 * kMs, 0.4));
  sut.apply(imu_at(59 * kMs, 0.5));
  EXPECT_EQ(as_int16(sut.register_raw(fumanoid::kPitch)), 4000);
  sut.apply(imu_at(60 * kMs, 0.6));
  EXPECT_EQ(as_int16(sut.register_raw(fumanoid::kPitch)), 6000);
}

TEST(FumanoidImu, SimulationResetLatchesAtOnce) {
  FumanoidImu sut(100, 1, 250);
  sut.apply(imu_at(500 * kMs, 0.1));
  sut.apply(imu_at(0, -0.1));
  EXPECT_EQ(as_int16(sut.register_raw(fumanoid::kPitch)), -1000);
}

TEST(FumanoidImu, UnitsSignsAndSaturation) {
  FumanoidImu sut(100, 1, 250);
  ImuFeedback f;
  f.roll_rad = -0.5;
  f.yaw_rad = 1.5 * std::numbers::pi;  // wraps to -pi/2
  f.w_WS_S_rad_s = {0.0125, -2.0, 100.0};
  f.a_WS_S_m_s2 = {-1.0, 0.004, 9.80665};
  sut.apply(f);

  EXPECT_EQ(as_int16(sut.register_raw(fumanoid::kRoll)), -5000);
  EXPECT_EQ(as_int16(sut.register_raw(fumanoid::kYaw)), -15708);
  EXPECT_EQ(as_int16(sut.register_raw(fumanoid::kGyroX)), 13);  // 12.5 mrad/s rounds away from zero
  EXPECT_EQ(as_int16(sut.register_raw(fumanoid::kGyroY)), -2000);
  EXPECT_EQ(as_int16(sut.register_raw(fumanoid::kGyroZ)), 32767);
  EXPECT_EQ(as_int16(sut.register_raw(fumanoid::kAccelX)), -100);
  EXPECT_EQ(as_int16(sut.register_raw(fumanoid::kAccelY)), 0);
  EXPECT_EQ(as_int16(sut.register_raw(fumanoid::kAccelZ)), 981);
}

TEST(FumanoidImu, ReadOfTheValueBlockIsLittleEndian) {
  FumanoidImu sut(100, 1, 250);
  ImuFeedback f;
  f.pitch_rad = 0.0256;  // 256 = 0x0100
  f.roll_rad = -0.0001;  // -1 = 0xFFFF
  f.a_WS_S_m_s2 = {0.0, 0.0, 0.0};
  sut.apply(f);

  // READ 26, 4 -> 00 01 FF FF; ~(64 + 06 + 00 + 00 + 01 + FF + FF) = ~0x69 (low byte) = 0x96
  EXPECT_EQ(transact(sut, make_packet(100, instruction::kRead, {26, 4})),
            (Bytes{0xFF, 0xFF, 0x64, 0x06, 0x00, 0x00, 0x01, 0xFF, 0xFF, 0x96}));
}

TEST(FumanoidImu, SamplePeriodIsWritable) {
  FumanoidImu sut(100, 1, 250);
  ASSERT_EQ(transact(sut, make_packet(100, instruction::kWrite, {fumanoid::kSamplePeriod, 5}))[4], 0);
  EXPECT_EQ(sut.sample_period_ns(), 5 * kMs);
  EXPECT_EQ(transact(sut, make_packet(100, instruction::kWrite, {fumanoid::kSamplePeriod, 0}))[4], p1_error::kRange);
}

TEST(FumanoidImu, SensorRegistersAreReadOnly) {
  FumanoidImu sut(100, 1, 250);
  EXPECT_EQ(transact(sut, make_packet(100, instruction::kWrite, {fumanoid::kPitch, 0, 0}))[4], p1_error::kRange);
}

TEST(FumanoidImu, RegWriteActionAndReset) {
  FumanoidImu sut(7, 1, 250);
  ASSERT_EQ(transact(sut, make_packet(7, instruction::kRegWrite, {fumanoid::kLed, 1}))[4], 0);
  EXPECT_EQ(sut.register_raw(fumanoid::kRegistered), 1);
  EXPECT_TRUE(transact(sut, make_packet(kBroadcastId, instruction::kAction)).empty());
  EXPECT_EQ(sut.register_raw(fumanoid::kLed), 1);

  // ~(07 + 02 + 00) = 0xF6: the status carries the old ID; the board's factory ID is 100.
  EXPECT_EQ(transact(sut, make_packet(7, instruction::kFactoryReset)), (Bytes{0xFF, 0xFF, 0x07, 0x02, 0x00, 0xF6}));
  EXPECT_EQ(sut.id(), 100);
  EXPECT_EQ(sut.register_raw(fumanoid::kLed), 0);
}

TEST(FumanoidImu, SyncWriteFindsItsBlock) {
  FumanoidImu sut(100, 1, 250);
  EXPECT_TRUE(transact(sut, make_packet(kBroadcastId, instruction::kSyncWrite, {fumanoid::kLed, 1, 1, 0, 100, 1})).empty());
  EXPECT_EQ(sut.register_raw(fumanoid::kLed), 1);
}

TEST(FumanoidFootBoard, ForcesInCentinewtonAndTotal) {
  FumanoidFootBoard sut(101, 1, 250);
  FootFeedback f;
  f.force_n = {10.0, 20.5, -3.0, 0.004};
  sut.apply(f);

  EXPECT_EQ(sut.register_raw(fumanoid::kForceFrontLeft), 1000);
  EXPECT_EQ(sut.register_raw(fumanoid::kForceFrontRight), 2050);
  EXPECT_EQ(sut.register_raw(fumanoid::kForceBackLeft), 0);
  EXPECT_EQ(sut.register_raw(fumanoid::kForceBackRight), 0);
  EXPECT_EQ(sut.register_raw(fumanoid::kForceTotal), 3050);
}

TEST(FumanoidFootBoard, SaturatesAt65535) {
  FumanoidFootBoard sut(101, 1, 250);
  FootFeedback f;
  f.force_n = {1000.0, 400.0, 400.0, 0.0};
  sut.apply(f);
  EXPECT_EQ(sut.register_raw(fumanoid::kForceFrontLeft), 65535);
  EXPECT_EQ(sut.register_raw(fumanoid::kForceTotal), 65535);
}

TEST(FumanoidFootBoard, LatchesEvery10ms) {
  FumanoidFootBoard sut(101, 1, 250);
  FootFeedback f;
  f.force_n = {1.0, 0.0, 0.0, 0.0};
  sut.apply(f);
  f.force_n[0] = 2.0;
  f.sim_time_ns = 9 * kMs;
  sut.apply(f);
  EXPECT_EQ(sut.register_raw(fumanoid::kForceFrontLeft), 100);
  f.sim_time_ns = 10 * kMs;
  sut.apply(f);
  EXPECT_EQ(sut.register_raw(fumanoid::kForceFrontLeft), 200);
}

TEST(FumanoidFootBoard, PingReadModel) {
  FumanoidFootBoard sut(101, 1, 250);
  // READ 0, 2: 0x4646; ~(65 + 04 + 00 + 46 + 46) = ~0xF5 = 0x0A
  EXPECT_EQ(transact(sut, make_packet(101, instruction::kRead, {0, 2})),
            (Bytes{0xFF, 0xFF, 0x65, 0x04, 0x00, 0x46, 0x46, 0x0A}));
}

TEST(FumanoidBoards, ConstructionRejectsBadConfig) {
  EXPECT_THROW(FumanoidImu(254, 1, 250), std::invalid_argument);
  EXPECT_THROW(FumanoidFootBoard(1, 255, 250), std::invalid_argument);
}

}  // namespace
}  // namespace doppel::dynamixel
