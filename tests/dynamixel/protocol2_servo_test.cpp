// X-series servos (XM430-W350, XL430-W250) on Protocol 2.0. Golden bytes come from
// shared/reference/dynamixel.md §2.2-2.7; where the reference has no worked packet, the expected
// status is built with the reference's framing (§2.1) from the values the reference gives (§3.7).
#include "dynamixel/protocol2_servo.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "dynamixel/bus_devices.h"
#include "dynamixel/protocol2.h"
#include "test_support.h"

namespace doppel::dynamixel {
namespace {

using testing::Bytes;
using testing::le;
using testing::p2::instruction;
using testing::p2::parse;
using testing::p2::status;
using testing::p2::transact;
using testing::p2::write_params;

constexpr double kUnitsPerRad = 4096.0 / (2.0 * std::numbers::pi);

double rad_of(int32_t present) { return (present - 2048) / kUnitsPerRad; }

class XmServo : public ::testing::Test {
 protected:
  XmServo() : sut(p2_model_spec("XM430-W350"), 1, 3, 0) {}
  Bytes write(uint16_t address, int64_t value, int size) {
    return transact(sut, instruction(1, instruction::kWrite, write_params(address, value, size)));
  }
  Bytes read(uint16_t address, uint16_t length) {
    return transact(sut, instruction(1, instruction::kRead, {static_cast<uint8_t>(address & 0xFF),
                                                             static_cast<uint8_t>(address >> 8),
                                                             static_cast<uint8_t>(length & 0xFF),
                                                             static_cast<uint8_t>(length >> 8)}));
  }
  Protocol2Servo sut;
};

TEST(XSeriesModels, PingAnswersOfTheReference) {
  // §2.2: XM430-W350 model 1020 fw 45, XL430-W250 model 1060 fw 45.
  Protocol2Servo xm(p2_model_spec("XM430-W350"), 1, 3, 0);
  Protocol2Servo xl(p2_model_spec("XL430-W250"), 1, 3, 0);
  const Bytes ping = {0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x03, 0x00, 0x01, 0x19, 0x4E};
  EXPECT_EQ(transact(xm, ping), (Bytes{0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x07, 0x00, 0x55, 0x00, 0xFC, 0x03, 0x2D, 0x17, 0x43}));
  EXPECT_EQ(transact(xl, ping), (Bytes{0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x07, 0x00, 0x55, 0x00, 0x24, 0x04, 0x2D, 0xF4, 0xDF}));
}

TEST(XSeriesModels, FactoryDefaultsOfTheReference) {
  Protocol2Servo xm(p2_model_spec("XM430-W350"), 1, 1, 250);
  Protocol2Servo xl(p2_model_spec("XL430-W250"), 1, 1, 250);
  struct Row {
    uint16_t address;
    int64_t xm;
    int64_t xl;
  };
  const Row rows[] = {{x430::kModelNumber, 1020, 1060},  {x430::kBaudRate, 1, 1},          {x430::kReturnDelayTime, 250, 250},
                      {x430::kOperatingMode, 3, 3},      {x430::kSecondaryId, 255, 255},   {x430::kProtocolType, 2, 2},
                      {x430::kMovingThreshold, 10, 10},  {x430::kTemperatureLimit, 80, 72}, {x430::kMaxVoltageLimit, 160, 140},
                      {x430::kMinVoltageLimit, 95, 60},  {x430::kPwmLimit, 885, 885},      {x430::kVelocityLimit, 200, 415},
                      {x430::kMaxPositionLimit, 4095, 4095}, {x430::kMinPositionLimit, 0, 0}, {x430::kShutdown, 52, 52},
                      {x430::kStatusReturnLevel, 2, 2},  {x430::kVelocityIGain, 1920, 1000}, {x430::kVelocityPGain, 100, 100},
                      {x430::kPositionDGain, 0, 4000},   {x430::kPositionPGain, 800, 640}, {x430::kIndirectAddress1, 224, 224},
                      {x430::kIndirectAddress29, 634, 634}};
  for (const Row& r : rows) {
    EXPECT_EQ(xm.register_value(r.address), r.xm) << r.address;
    EXPECT_EQ(xl.register_value(r.address), r.xl) << r.address;
  }
  EXPECT_EQ(xm.register_value(x430::kCurrentLimit), 1193);
  EXPECT_EQ(xl.register_value(x430::kAccelerationLimit), 32767);
}

TEST_F(XmServo, ReadPresentPositionOfTheReference) {
  // §2.4: READ 132, 4 bytes -> 166.
  Protocol2Servo at166(p2_model_spec("XM430-W350"), 1, 3, 0, rad_of(166));
  EXPECT_EQ(transact(at166, {0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x07, 0x00, 0x02, 0x84, 0x00, 0x04, 0x00, 0x1D, 0x15}),
            (Bytes{0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x08, 0x00, 0x55, 0x00, 0xA6, 0x00, 0x00, 0x00, 0x8C, 0xC0}));
}

TEST_F(XmServo, WriteGoalPositionOfTheReference) {
  EXPECT_EQ(transact(sut, {0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x09, 0x00, 0x03, 0x74, 0x00, 0x00, 0x02, 0x00, 0x00, 0xCA, 0x89}),
            (Bytes{0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x04, 0x00, 0x55, 0x00, 0xA1, 0x0C}));
  EXPECT_EQ(sut.register_value(x430::kGoalPosition), 512);
}

TEST_F(XmServo, RegWriteWaitsForAction) {
  // §2.4: REG WRITE Goal Velocity (104) = 200, then ACTION.
  ASSERT_EQ(transact(sut, {0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x09, 0x00, 0x04, 0x68, 0x00, 0xC8, 0x00, 0x00, 0x00, 0xAE, 0x8E}),
            status(1, 0));
  EXPECT_EQ(sut.register_value(x430::kRegisteredInstruction), 1);
  EXPECT_EQ(sut.register_value(x430::kGoalVelocity), 0);
  EXPECT_EQ(transact(sut, {0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x03, 0x00, 0x05, 0x02, 0xCE}), status(1, 0));
  EXPECT_EQ(sut.register_value(x430::kGoalVelocity), 200);
  EXPECT_EQ(sut.register_value(x430::kRegisteredInstruction), 0);
}

TEST_F(XmServo, ActionWithoutRegWriteIsAnInstructionError) {
  EXPECT_EQ(transact(sut, {0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x03, 0x00, 0x05, 0x02, 0xCE}), status(1, p2_error::kInstruction));
}

TEST_F(XmServo, UndefinedInstructionIsAnInstructionError) {
  EXPECT_EQ(transact(sut, instruction(1, 0x07)), status(1, p2_error::kInstruction));
}

TEST_F(XmServo, BadCrcIsAnsweredWithCrcErrorAndNotExecuted) {
  Bytes wire = {0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x09, 0x00, 0x03, 0x74, 0x00, 0x00, 0x02, 0x00, 0x00, 0xCA, 0x88};
  EXPECT_EQ(transact(sut, wire), status(1, p2_error::kCrc));
  EXPECT_NE(sut.register_value(x430::kGoalPosition), 512);
  EXPECT_EQ(sut.counters().bad_checksums, 1u);
}

TEST_F(XmServo, DataRangeError) {
  EXPECT_EQ(write(x430::kGoalVelocity, 2000, 4), status(1, p2_error::kDataRange));     // item range +-1023
  EXPECT_EQ(write(x430::kOperatingMode, 2, 1), status(1, p2_error::kDataRange));       // no mode 2
  EXPECT_EQ(write(x430::kDriveMode, 2, 1), status(1, p2_error::kDataRange));           // bit 1 undefined
}

TEST_F(XmServo, DataLengthErrorForAPartialItem) {
  // §2.5: 2 bytes into a 4-byte item.
  EXPECT_EQ(write(x430::kGoalPosition, 512, 2), status(1, p2_error::kDataLength));
  EXPECT_EQ(transact(sut, instruction(1, instruction::kRead, {0x84, 0x00})), status(1, p2_error::kDataLength));
}

TEST_F(XmServo, DataLimitError) {
  ASSERT_EQ(write(x430::kMaxPositionLimit, 3000, 4), status(1, 0));
  EXPECT_EQ(write(x430::kGoalPosition, 3001, 4), status(1, p2_error::kDataLimit));
  EXPECT_EQ(write(x430::kGoalPosition, 3000, 4), status(1, 0));
  EXPECT_EQ(write(x430::kGoalVelocity, 201, 4), status(1, p2_error::kDataLimit));  // Velocity Limit 200
  EXPECT_EQ(write(x430::kGoalVelocity, -200, 4), status(1, 0));
  ASSERT_EQ(write(x430::kPwmLimit, 500, 2), status(1, 0));
  EXPECT_EQ(write(x430::kGoalPwm, 501, 2), status(1, p2_error::kDataLimit));
  EXPECT_EQ(write(x430::kGoalCurrent, -1193, 2), status(1, 0));
}

TEST_F(XmServo, AccessErrors) {
  EXPECT_EQ(write(x430::kModelNumber, 1, 2), status(1, p2_error::kAccess));          // read-only
  EXPECT_EQ(write(14, 0, 1), status(1, p2_error::kAccess));                          // reserved
  EXPECT_EQ(read(660, 3), status(1, p2_error::kAccess));                             // past the table, no data
  ASSERT_EQ(write(x430::kTorqueEnable, 1, 1), status(1, 0));
  EXPECT_EQ(write(x430::kReturnDelayTime, 0, 1), status(1, p2_error::kAccess));      // EEPROM locked by torque
  EXPECT_EQ(sut.register_value(x430::kReturnDelayTime), 0);                          // (was 0 already)
  EXPECT_EQ(write(x430::kVelocityLimit, 100, 4), status(1, p2_error::kAccess));
  EXPECT_EQ(sut.register_value(x430::kVelocityLimit), 200);
  ASSERT_EQ(write(x430::kTorqueEnable, 0, 1), status(1, 0));
  EXPECT_EQ(write(x430::kVelocityLimit, 100, 4), status(1, 0));
}

TEST_F(XmServo, ReservedBytesInsideTheTableReadZero) {
  EXPECT_EQ(read(13, 8), status(1, 0, {2, 0, 0, 0, 0, 0, 0, 0}));  // Protocol Type, 14..19 reserved, Homing 20
}

// The firmware reads its encoder at boot: Goal Position starts at the present position, so
// enabling the torque holds a joint where it stands. In Doppel the body's initial pose arrives
// with the first measurement after power-on (a robot file's initial_deg).
TEST_F(XmServo, GoalStartsAtTheFirstMeasuredPosition) {
  ServoFeedback standing;
  standing.position_rad = -64.3 * 3.14159265358979 / 180.0;  // -731.6 units from 2048
  standing.voltage_v = 12.0;
  sut.apply(standing);
  EXPECT_EQ(sut.register_value(x430::kPresentPosition), 1316);
  EXPECT_EQ(sut.register_value(x430::kGoalPosition), 1316);
  ASSERT_EQ(write(x430::kTorqueEnable, 1, 1), status(1, 0));
  EXPECT_NEAR(sut.command().goal_position_rad, standing.position_rad, 0.002);
  // Only the first measurement: later ones leave the goal alone.
  standing.position_rad = 0.0;
  sut.apply(standing);
  EXPECT_EQ(sut.register_value(x430::kGoalPosition), 1316);
}

TEST(XSeriesModels, AGoalWrittenBeforeTheFirstMeasurementWins) {
  Protocol2Servo xm(p2_model_spec("XM430-W350"), 1, 3, 0);
  ASSERT_EQ(transact(xm, instruction(1, instruction::kWrite, write_params(x430::kGoalPosition, 3000, 4))), status(1, 0));
  ServoFeedback at;
  at.position_rad = 0.5;
  at.voltage_v = 12.0;
  xm.apply(at);
  EXPECT_EQ(xm.register_value(x430::kGoalPosition), 3000);
}

TEST_F(XmServo, AlertBitWhileAHardwareErrorIsLatched) {
  ServoFeedback hot;
  hot.position_rad = 0.0;
  hot.voltage_v = 12.0;
  hot.temperature_c = 81.0;  // Temperature Limit 80; Shutdown 52 includes overheating
  ASSERT_EQ(write(x430::kTorqueEnable, 1, 1), status(1, 0));
  sut.apply(hot);
  EXPECT_EQ(sut.hardware_error(), x430::kOverheatingError);
  EXPECT_FALSE(sut.torque_enabled());
  EXPECT_EQ(transact(sut, instruction(1, instruction::kPing)), status(1, 0x80, {0xFC, 0x03, 0x2D}));
  EXPECT_EQ(write(x430::kModelNumber, 0, 2), status(1, 0x80 | p2_error::kAccess));
  // Cool again: still latched; torque cannot come back until REBOOT.
  hot.temperature_c = 30.0;
  sut.apply(hot);
  EXPECT_EQ(write(x430::kTorqueEnable, 1, 1), status(1, 0x80));
  EXPECT_FALSE(sut.torque_enabled());
  EXPECT_FALSE(sut.command().torque_enabled);
  EXPECT_EQ(transact(sut, {0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x03, 0x00, 0x08, 0x2F, 0x4E}), status(1, 0x80));  // REBOOT
  EXPECT_EQ(sut.hardware_error(), 0);
  EXPECT_EQ(write(x430::kTorqueEnable, 1, 1), status(1, 0));
  EXPECT_TRUE(sut.torque_enabled());
}

TEST_F(XmServo, ConditionsOutsideShutdownDoNotLatch) {
  ServoFeedback low;
  low.voltage_v = 9.0;  // below Min Voltage Limit 9.5 V; Shutdown 52 has no input-voltage bit
  sut.apply(low);
  EXPECT_EQ(sut.hardware_error(), 0);
  ASSERT_EQ(write(x430::kShutdown, 53, 1), status(1, 0));
  sut.apply(low);
  EXPECT_EQ(sut.hardware_error(), x430::kInputVoltageError);
}

TEST_F(XmServo, ControllerOverloadLatchesWithTorqueOn) {
  // Overload is the motor controller's (ServoFeedback.overload); Shutdown 52 includes it (§3.7).
  ServoFeedback blocked;
  blocked.overload = true;
  sut.apply(blocked);
  EXPECT_EQ(sut.hardware_error(), 0);  // torque off: the controller's flag does not count
  ASSERT_EQ(write(x430::kTorqueEnable, 1, 1), status(1, 0));

  sut.apply(blocked);

  EXPECT_EQ(sut.hardware_error(), x430::kOverloadError);
  EXPECT_FALSE(sut.torque_enabled());
  EXPECT_EQ(transact(sut, instruction(1, instruction::kPing)), status(1, 0x80, {0xFC, 0x03, 0x2D}));
}

TEST_F(XmServo, StatusReturnLevel) {
  ASSERT_EQ(write(x430::kStatusReturnLevel, 1, 1), status(1, 0));  // answered under the old level
  EXPECT_TRUE(write(x430::kLed, 1, 1).empty());
  EXPECT_EQ(read(x430::kLed, 1), status(1, 0, {1}));
  ASSERT_TRUE(write(x430::kStatusReturnLevel, 0, 1).empty());
  EXPECT_TRUE(read(x430::kLed, 1).empty());
  EXPECT_EQ(transact(sut, instruction(1, instruction::kPing)), status(1, 0, {0xFC, 0x03, 0x2D}));
}

TEST_F(XmServo, IdChangeAnswersWithTheOldId) {
  EXPECT_EQ(write(x430::kId, 5, 1), status(1, 0));
  EXPECT_EQ(sut.id(), 5);
  EXPECT_TRUE(transact(sut, instruction(1, instruction::kPing)).empty());
}

TEST_F(XmServo, FactoryResetOptions) {
  ASSERT_EQ(write(x430::kId, 7, 1), status(1, 0));
  ASSERT_EQ(transact(sut, instruction(7, instruction::kWrite, write_params(x430::kReturnDelayTime, 10, 1))), status(7, 0));
  // 0x02: all except ID and baud.
  EXPECT_EQ(transact(sut, instruction(7, instruction::kFactoryReset, {0x02})), status(7, 0));
  EXPECT_EQ(sut.id(), 7);
  EXPECT_EQ(sut.register_value(x430::kBaudRate), 3);
  EXPECT_EQ(sut.register_value(x430::kReturnDelayTime), 250);
  // 0x01: all except ID (baud back to 57 600).
  EXPECT_EQ(transact(sut, instruction(7, instruction::kFactoryReset, {0x01})), status(7, 0));
  EXPECT_EQ(sut.id(), 7);
  EXPECT_EQ(sut.register_value(x430::kBaudRate), 1);
  // Broadcast 0xFF is ignored; unicast 0xFF resets the ID to 1; other options are out of range.
  EXPECT_TRUE(transact(sut, instruction(0xFE, instruction::kFactoryReset, {0xFF})).empty());
  EXPECT_EQ(sut.id(), 7);
  EXPECT_EQ(transact(sut, instruction(7, instruction::kFactoryReset, {0x03})), status(7, p2_error::kDataRange));
}

TEST_F(XmServo, FactoryResetAllOfTheReferenceLayout) {
  // §2.4 FACTORY RESET ID 1 option 0x01.
  EXPECT_EQ(transact(sut, {0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x04, 0x00, 0x06, 0x01, 0xA1, 0xE6}), status(1, 0));
  EXPECT_EQ(transact(sut, instruction(1, instruction::kFactoryReset, {0xFF})), status(1, 0));
  EXPECT_EQ(sut.id(), 1);
  EXPECT_EQ(sut.register_value(x430::kBaudRate), 1);
}

TEST_F(XmServo, ClearMultiTurnFoldsPresentPositionAndFailsWhileMoving) {
  // §2.4 CLEAR ID 1.
  const Bytes clear = {0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x08, 0x00, 0x10, 0x01, 0x44, 0x58, 0x4C, 0x22, 0xB1, 0xDC};
  ASSERT_EQ(write(x430::kOperatingMode, x430::kExtendedPositionMode, 1), status(1, 0));
  ServoFeedback turned;
  turned.position_rad = rad_of(2048 + 3 * 4096 + 100);
  turned.voltage_v = 12.0;
  turned.velocity_rad_s = 1.0;  // 41.7 units > Moving Threshold 10
  sut.apply(turned);
  EXPECT_EQ(sut.register_value(x430::kPresentPosition), 2048 + 3 * 4096 + 100);
  EXPECT_EQ(transact(sut, clear), status(1, p2_error::kResultFail));
  turned.velocity_rad_s = 0.0;
  sut.apply(turned);
  EXPECT_EQ(transact(sut, clear), status(1, 0));
  sut.apply(turned);
  EXPECT_EQ(sut.register_value(x430::kPresentPosition), 2048 + 100);
  EXPECT_EQ(transact(sut, instruction(1, instruction::kClear, {0x02, 0x45, 0x52, 0x43, 0x4C})), status(1, p2_error::kDataRange));
}

TEST_F(XmServo, ControlTableBackupStoreAndRestore) {
  const Bytes store = {0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x08, 0x00, 0x20, 0x01, 0x43, 0x54, 0x52, 0x4C, 0x16, 0xF5};
  const Bytes restore = {0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x08, 0x00, 0x20, 0x02, 0x43, 0x54, 0x52, 0x4C, 0x9E, 0xF5};
  EXPECT_EQ(transact(sut, restore), status(1, p2_error::kResultFail));  // nothing stored yet
  ASSERT_EQ(write(x430::kVelocityLimit, 100, 4), status(1, 0));
  EXPECT_EQ(transact(sut, store), status(1, 0));
  EXPECT_TRUE(sut.has_backup());
  ASSERT_EQ(write(x430::kVelocityLimit, 50, 4), status(1, 0));
  ASSERT_EQ(write(x430::kTorqueEnable, 1, 1), status(1, 0));
  EXPECT_EQ(transact(sut, restore), status(1, p2_error::kResultFail));  // torque on
  ASSERT_EQ(write(x430::kTorqueEnable, 0, 1), status(1, 0));
  EXPECT_EQ(transact(sut, restore), status(1, 0));
  EXPECT_EQ(sut.register_value(x430::kVelocityLimit), 100);
}

TEST_F(XmServo, OperatingModeChangeResetsProfileAndGoalLimits) {
  ASSERT_EQ(write(x430::kProfileVelocity, 100, 4), status(1, 0));
  ASSERT_EQ(write(x430::kProfileAcceleration, 10, 4), status(1, 0));
  ASSERT_EQ(write(x430::kGoalPwm, 100, 2), status(1, 0));
  ASSERT_EQ(write(x430::kOperatingMode, x430::kVelocityMode, 1), status(1, 0));
  EXPECT_EQ(sut.register_value(x430::kProfileVelocity), 0);
  EXPECT_EQ(sut.register_value(x430::kProfileAcceleration), 0);
  EXPECT_EQ(sut.register_value(x430::kGoalPwm), 885);
  EXPECT_EQ(sut.register_value(x430::kGoalCurrent), 1193);
}

TEST(XSeriesModels, XlHasNoCurrentModes) {
  Protocol2Servo xl(p2_model_spec("XL430-W250"), 1, 3, 0);
  EXPECT_EQ(transact(xl, instruction(1, instruction::kWrite, write_params(x430::kOperatingMode, 0, 1))),
            status(1, p2_error::kDataRange));
  EXPECT_EQ(transact(xl, instruction(1, instruction::kWrite, write_params(x430::kOperatingMode, 16, 1))), status(1, 0));
  EXPECT_EQ(transact(xl, instruction(1, instruction::kWrite, write_params(x430::kGoalCurrent, 0, 2))),
            status(1, p2_error::kAccess));
}

TEST_F(XmServo, CommandFollowsTheOperatingMode) {
  ASSERT_EQ(write(x430::kGoalPosition, 3072, 4), status(1, 0));
  ASSERT_EQ(write(x430::kTorqueEnable, 1, 1), status(1, 0));
  ServoCommand c = sut.command();
  EXPECT_TRUE(c.torque_enabled);
  EXPECT_FALSE(c.wheel_mode);
  EXPECT_NEAR(c.goal_position_rad, std::numbers::pi / 2.0, 1e-9);
  EXPECT_NEAR(c.min_position_rad, -std::numbers::pi, 1e-9);
  EXPECT_NEAR(c.max_position_rad, rad_of(4095), 1e-9);
  // Profile Velocity 0: limited by Velocity Limit 200 x 0.229 rpm.
  EXPECT_NEAR(c.moving_speed_rad_s, 200 * 0.229 * 2 * std::numbers::pi / 60, 1e-9);
  ASSERT_EQ(write(x430::kProfileVelocity, 100, 4), status(1, 0));
  ASSERT_EQ(write(x430::kProfileAcceleration, 50, 4), status(1, 0));
  c = sut.command();
  EXPECT_NEAR(c.moving_speed_rad_s, 100 * 0.229 * 2 * std::numbers::pi / 60, 1e-9);
  EXPECT_NEAR(c.goal_acceleration_rad_s2, 50 * 214.577 * 2 * std::numbers::pi / 3600, 1e-9);

  ASSERT_EQ(write(x430::kTorqueEnable, 0, 1), status(1, 0));
  ASSERT_EQ(write(x430::kOperatingMode, x430::kVelocityMode, 1), status(1, 0));
  ASSERT_EQ(write(x430::kGoalVelocity, -100, 4), status(1, 0));
  c = sut.command();
  EXPECT_TRUE(c.wheel_mode);
  EXPECT_NEAR(c.moving_speed_rad_s, -100 * 0.229 * 2 * std::numbers::pi / 60, 1e-9);
  // Velocity PI from Velocity P/I Gain 100 / 1920 (§3.7 defaults): KvP = P / 128, KvI = I / 65536
  // per 1 ms cycle.
  EXPECT_TRUE(c.velocity_control);
  EXPECT_NEAR(c.velocity_pi.kp, 100.0 / 128.0, 1e-12);
  EXPECT_NEAR(c.velocity_pi.ki, 1920.0 / 65536.0 * 1000.0, 1e-9);

  ASSERT_EQ(write(x430::kOperatingMode, x430::kCurrentMode, 1), status(1, 0));
  ASSERT_EQ(write(x430::kGoalCurrent, 428, 2), status(1, 0));  // 428 x 2.69 mA = 1.151 A = half of 2.3 A
  c = sut.command();
  EXPECT_TRUE(c.torque_control);
  EXPECT_NEAR(c.goal_current_a, 428 * 0.00269, 1e-9);

  ASSERT_EQ(write(x430::kOperatingMode, x430::kExtendedPositionMode, 1), status(1, 0));
  ASSERT_EQ(write(x430::kGoalPosition, 2048 + 2 * 4096, 4), status(1, 0));
  c = sut.command();
  EXPECT_TRUE(c.multi_turn);
  EXPECT_NEAR(c.goal_position_rad, 4 * std::numbers::pi, 1e-9);
}

TEST_F(XmServo, CommandCarriesThePositionGainsInControllerUnits) {
  ASSERT_EQ(write(x430::kPositionPGain, 1600, 2), status(1, 0));
  ASSERT_EQ(write(x430::kPositionIGain, 64, 2), status(1, 0));
  ASSERT_EQ(write(x430::kPositionDGain, 32, 2), status(1, 0));

  const ServoCommand c = sut.command();

  // e-Manual: Kp = P / 128, Ki = I / 65536, Kd = D / 16.
  EXPECT_DOUBLE_EQ(c.pid.kp, 1600.0 / 128.0);
  EXPECT_DOUBLE_EQ(c.pid.ki, 64.0 / 65536.0);
  EXPECT_DOUBLE_EQ(c.pid.kd, 32.0 / 16.0);
}

TEST_F(XmServo, ApplyFillsPresentItemsInXUnits) {
  ServoFeedback f;
  f.position_rad = std::numbers::pi / 2.0;
  f.velocity_rad_s = -100 * 0.229 * 2 * std::numbers::pi / 60;
  f.torque_ratio = 0.5;
  f.current_a = 1.15;
  f.voltage_v = 12.3;
  f.temperature_c = 41.0;
  f.sim_time_ns = 40'000'000'000;
  sut.apply(f);
  EXPECT_EQ(sut.register_value(x430::kPresentPosition), 3072);
  EXPECT_EQ(sut.register_value(x430::kPresentVelocity), -100);
  EXPECT_EQ(sut.register_value(x430::kPresentCurrent), 428);  // 1.15 A / 2.69 mA
  EXPECT_EQ(sut.register_value(x430::kPresentInputVoltage), 123);
  EXPECT_EQ(sut.register_value(x430::kPresentTemperature), 41);
  EXPECT_EQ(sut.register_value(x430::kRealtimeTick), 40000 % 32768);
  EXPECT_EQ(sut.register_value(x430::kMoving), 1);
}

TEST_F(XmServo, MovingStatusReportsProfileAndInPosition) {
  ASSERT_EQ(write(x430::kGoalPosition, 3072, 4), status(1, 0));
  ASSERT_EQ(write(x430::kTorqueEnable, 1, 1), status(1, 0));
  ServoFeedback f;
  f.voltage_v = 12.0;
  sut.apply(f);
  EXPECT_EQ(sut.register_value(x430::kMovingStatus), x430::kProfileOngoing);  // step profile (PV 0)
  ASSERT_EQ(write(x430::kProfileVelocity, 100, 4), status(1, 0));
  sut.apply(f);
  EXPECT_EQ(sut.register_value(x430::kMovingStatus), x430::kProfileOngoing | x430::kProfileRectangular);
  ASSERT_EQ(write(x430::kProfileAcceleration, 10, 4), status(1, 0));
  sut.apply(f);
  EXPECT_EQ(sut.register_value(x430::kMovingStatus) & 0x30, x430::kProfileTrapezoidal);
  f.position_rad = std::numbers::pi / 2.0;
  sut.apply(f);
  EXPECT_EQ(sut.register_value(x430::kMovingStatus) & 0x03, x430::kInPosition);
}

TEST_F(XmServo, TorqueOnInPositionModeRebasesToOneTurn) {
  ServoFeedback f;
  f.voltage_v = 12.0;
  f.position_rad = rad_of(2048 + 4096 + 5);  // turned by hand past one turn with torque off
  sut.apply(f);
  EXPECT_EQ(sut.register_value(x430::kPresentPosition), 2048 + 4096 + 5);
  ASSERT_EQ(write(x430::kTorqueEnable, 1, 1), status(1, 0));
  sut.apply(f);
  EXPECT_EQ(sut.register_value(x430::kPresentPosition), 2048 + 5);
}

TEST_F(XmServo, BusWatchdogStopsTheServoAndLocksGoals) {
  ServoFeedback f;
  f.voltage_v = 12.0;
  f.sim_time_ns = 1'000'000'000;
  sut.apply(f);
  ASSERT_EQ(write(x430::kBusWatchdog, 5, 1), status(1, 0));  // 100 ms
  ASSERT_EQ(write(x430::kTorqueEnable, 1, 1), status(1, 0));
  ASSERT_EQ(write(x430::kGoalPosition, 3072, 4), status(1, 0));
  f.sim_time_ns += 90'000'000;
  sut.apply(f);
  EXPECT_FALSE(sut.watchdog_tripped());
  f.sim_time_ns += 110'000'000;
  sut.apply(f);
  EXPECT_TRUE(sut.watchdog_tripped());
  EXPECT_EQ(read(x430::kBusWatchdog, 1), status(1, 0, {0xFF}));  // reads -1
  EXPECT_NEAR(sut.command().goal_position_rad, 0.0, 1e-9);    // stopped where it was
  EXPECT_EQ(write(x430::kGoalPosition, 2048, 4), status(1, p2_error::kDataRange));
  EXPECT_EQ(write(x430::kBusWatchdog, 0, 1), status(1, 0));
  EXPECT_EQ(write(x430::kGoalPosition, 2048, 4), status(1, 0));
}

TEST_F(XmServo, IndirectAddressingMirrorsTheTarget) {
  // Indirect Address 1..4 -> Goal Position (116..119), Indirect Address 5 -> LED (65).
  for (uint16_t n = 0; n < 4; ++n) {
    ASSERT_EQ(write(static_cast<uint16_t>(x430::kIndirectAddress1 + 2 * n), x430::kGoalPosition + n, 2), status(1, 0));
  }
  ASSERT_EQ(write(x430::kIndirectAddress1 + 8, x430::kLed, 2), status(1, 0));
  EXPECT_EQ(transact(sut, instruction(1, instruction::kWrite, {0xE0, 0x00, 0x00, 0x0C, 0x00, 0x00, 0x01})), status(1, 0));
  EXPECT_EQ(sut.register_value(x430::kGoalPosition), 3072);
  EXPECT_EQ(sut.register_value(x430::kLed), 1);
  EXPECT_EQ(read(x430::kIndirectData1, 5), status(1, 0, {0x00, 0x0C, 0x00, 0x00, 0x01}));
  // Properties are inherited: half an item is a length error, an out-of-limit goal a limit error.
  EXPECT_EQ(transact(sut, instruction(1, instruction::kWrite, {0xE0, 0x00, 0x00, 0x0C})), status(1, p2_error::kDataLength));
  EXPECT_EQ(transact(sut, instruction(1, instruction::kWrite, {0xE0, 0x00, 0x00, 0x10, 0x00, 0x00})),
            status(1, p2_error::kDataLimit));
  // Second block: Indirect Address 29 -> Present Temperature (read-only through it too).
  ASSERT_EQ(write(x430::kIndirectAddress29, x430::kPresentTemperature, 2), status(1, 0));
  EXPECT_EQ(transact(sut, instruction(1, instruction::kWrite, {0x7A, 0x02, 0x05})), status(1, p2_error::kAccess));
  EXPECT_EQ(write(x430::kIndirectAddress1, 63, 2), status(1, p2_error::kDataRange));  // targets 64..661
}

TEST_F(XmServo, SecondaryIdExecutesSilentlyAndNotIntoEeprom) {
  ASSERT_EQ(write(x430::kSecondaryId, 100, 1), status(1, 0));
  EXPECT_TRUE(transact(sut, instruction(100, instruction::kWrite, write_params(x430::kLed, 1, 1))).empty());
  EXPECT_EQ(sut.register_value(x430::kLed), 1);
  EXPECT_TRUE(transact(sut, instruction(100, instruction::kWrite, write_params(x430::kReturnDelayTime, 9, 1))).empty());
  EXPECT_EQ(sut.register_value(x430::kReturnDelayTime), 0);
}

// Bus-level instructions, with several servos behind BusDevices.
class XmBus : public ::testing::Test {
 protected:
  XmBus() {
    for (auto* s : {&s3, &s1, &s7, &s2, &s4}) {
      bus.add(*s);
    }
  }
  Bytes dispatch(const Bytes& wire) {
    Bytes out;
    for (const OutgoingStatus& s : bus.dispatch(parse(wire), 1000000)) {
      out.insert(out.end(), s.packet->bytes.begin(), s.packet->bytes.begin() + s.packet->size);
    }
    return out;
  }
  const P2ModelSpec& xm = p2_model_spec("XM430-W350");
  Protocol2Servo s1{xm, 1, 3, 0, rad_of(166)};
  Protocol2Servo s2{xm, 2, 3, 0, rad_of(2079)};
  Protocol2Servo s3{xm, 3, 3, 0, rad_of(166)};
  Protocol2Servo s4{xm, 4, 3, 0, rad_of(1023)};
  Protocol2Servo s7{xm, 7, 3, 0, rad_of(2079)};
  BusDevices bus;
};

TEST_F(XmBus, BroadcastPingIsAnsweredInIdOrder) {
  const auto statuses = bus.dispatch(parse({0xFF, 0xFF, 0xFD, 0x00, 0xFE, 0x03, 0x00, 0x01, 0x31, 0x42}), 1000000);
  ASSERT_EQ(statuses.size(), 5u);
  const uint8_t ids[] = {1, 2, 3, 4, 7};
  const int64_t idle_slots[] = {0, 0, 0, 0, 2};  // IDs 5 and 6 are missing: 3 ms each
  for (std::size_t i = 0; i < 5; ++i) {
    const Bytes got(statuses[i].packet->bytes.begin(), statuses[i].packet->bytes.begin() + statuses[i].packet->size);
    EXPECT_EQ(got, status(ids[i], 0, {0xFC, 0x03, 0x2D}));
    EXPECT_EQ(statuses[i].extra_delay_ns, idle_slots[i] * 3'000'000);
    EXPECT_EQ(statuses[i].after_previous, i > 0);
    EXPECT_FALSE(statuses[i].collision);
  }
}

TEST_F(XmBus, SyncReadOfTheReference) {
  // §2.4: SYNC READ IDs 1, 2, address 132, 4 bytes; ID 2's reply is golden (2079).
  const Bytes reply = dispatch({0xFF, 0xFF, 0xFD, 0x00, 0xFE, 0x09, 0x00, 0x82, 0x84, 0x00, 0x04, 0x00, 0x01, 0x02, 0xCE, 0xFA});
  Bytes expected = {0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x08, 0x00, 0x55, 0x00, 0xA6, 0x00, 0x00, 0x00, 0x8C, 0xC0};
  const Bytes id2 = {0xFF, 0xFF, 0xFD, 0x00, 0x02, 0x08, 0x00, 0x55, 0x00, 0x1F, 0x08, 0x00, 0x00, 0xBA, 0xBE};
  expected.insert(expected.end(), id2.begin(), id2.end());
  EXPECT_EQ(reply, expected);
}

TEST_F(XmBus, SyncWriteOfTheReference) {
  EXPECT_TRUE(dispatch({0xFF, 0xFF, 0xFD, 0x00, 0xFE, 0x11, 0x00, 0x83, 0x74, 0x00, 0x04, 0x00, 0x01, 0x96, 0x00, 0x00,
                        0x00, 0x02, 0xAA, 0x00, 0x00, 0x00, 0x82, 0x87})
                  .empty());
  EXPECT_EQ(s1.register_value(x430::kGoalPosition), 150);
  EXPECT_EQ(s2.register_value(x430::kGoalPosition), 170);
}

TEST_F(XmBus, BulkReadOfTheReference) {
  // §2.4: ID 1 Present Input Voltage (144, 2 B) = 119, ID 2 Present Temperature (146, 1 B) = 36.
  ServoFeedback f1;
  f1.position_rad = rad_of(166);
  f1.voltage_v = 11.9;
  s1.apply(f1);
  ServoFeedback f2;
  f2.position_rad = rad_of(2079);
  f2.temperature_c = 36.0;
  s2.apply(f2);
  const Bytes reply = dispatch({0xFF, 0xFF, 0xFD, 0x00, 0xFE, 0x0D, 0x00, 0x92, 0x01, 0x90, 0x00, 0x02, 0x00, 0x02,
                                0x92, 0x00, 0x01, 0x00, 0x1A, 0x05});
  EXPECT_EQ(reply, (Bytes{0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x06, 0x00, 0x55, 0x00, 0x77, 0x00, 0xC3, 0x69,
                          0xFF, 0xFF, 0xFD, 0x00, 0x02, 0x05, 0x00, 0x55, 0x00, 0x24, 0x8B, 0xA9}));
}

TEST_F(XmBus, BulkWriteOfTheReference) {
  // §2.4: ID 1 Max Voltage Limit (32, 2 B) = 160, ID 2 Temperature Limit (31, 1 B) = 80.
  ASSERT_EQ(s1.spec().name, "XM430-W350");
  EXPECT_TRUE(dispatch({0xFF, 0xFF, 0xFD, 0x00, 0xFE, 0x10, 0x00, 0x93, 0x01, 0x20, 0x00, 0x02, 0x00, 0xA0, 0x00, 0x02,
                        0x1F, 0x00, 0x01, 0x00, 0x50, 0xB7, 0x68})
                  .empty());
  EXPECT_EQ(s1.register_value(x430::kMaxVoltageLimit), 160);
  EXPECT_EQ(s2.register_value(x430::kTemperatureLimit), 80);
}

TEST_F(XmBus, FastSyncReadOfTheReference) {
  // §2.7: IDs 3, 7, 4 at 132, 4 B: 166, 2079, 1023.
  const auto statuses = bus.dispatch(
      parse({0xFF, 0xFF, 0xFD, 0x00, 0xFE, 0x0A, 0x00, 0x8A, 0x84, 0x00, 0x04, 0x00, 0x03, 0x07, 0x04, 0x20, 0xF2}), 1000000);
  Bytes reply;
  for (const OutgoingStatus& s : statuses) {
    reply.insert(reply.end(), s.packet->bytes.begin(), s.packet->bytes.begin() + s.packet->size);
  }
  EXPECT_EQ(reply, (Bytes{0xFF, 0xFF, 0xFD, 0x00, 0xFE, 0x19, 0x00, 0x55, 0x00, 0x03, 0xA6, 0x00, 0x00, 0x00, 0x84, 0x08,
                          0x00, 0x07, 0x1F, 0x08, 0x00, 0x00, 0x16, 0xCA, 0x00, 0x04, 0xFF, 0x03, 0x00, 0x00, 0xD1, 0x9E}));
  ASSERT_EQ(statuses.size(), 3u);
  EXPECT_FALSE(statuses[0].continues_previous);
  EXPECT_TRUE(statuses[1].continues_previous);
  EXPECT_TRUE(statuses[2].continues_previous);
}

TEST_F(XmBus, FastBulkReadOfTheReference) {
  // §2.7: ID 3 (132, 4 B) = 166, ID 7 Present PWM (124, 2 B) = 421, ID 4 Present Temperature (146, 1 B) = 31.
  ServoFeedback f7;
  f7.position_rad = rad_of(2079);
  f7.torque_ratio = 421.0 / 885.0;
  s7.apply(f7);
  ServoFeedback f4;
  f4.position_rad = rad_of(1023);
  f4.temperature_c = 31.0;
  s4.apply(f4);
  EXPECT_EQ(dispatch({0xFF, 0xFF, 0xFD, 0x00, 0xFE, 0x12, 0x00, 0x9A, 0x03, 0x84, 0x00, 0x04, 0x00, 0x07, 0x7C, 0x00, 0x02,
                      0x00, 0x04, 0x92, 0x00, 0x01, 0x00, 0xDA, 0x2D}),
            (Bytes{0xFF, 0xFF, 0xFD, 0x00, 0xFE, 0x14, 0x00, 0x55, 0x00, 0x03, 0xA6, 0x00, 0x00, 0x00, 0x67, 0xA4,
                   0x00, 0x07, 0xA5, 0x01, 0x24, 0x74, 0x00, 0x04, 0x1F, 0xD9, 0xC1}));
}

TEST_F(XmBus, ChainStopsAtAnAbsentDevice) {
  // SYNC READ IDs 1, 9 (absent), 2: ID 2 never gets its cue (docs/devices.md).
  const Bytes reply = dispatch(instruction(0xFE, instruction::kSyncRead, {0x84, 0x00, 0x04, 0x00, 1, 9, 2}));
  EXPECT_EQ(reply, status(1, 0, {0xA6, 0x00, 0x00, 0x00}));
  EXPECT_EQ(bus.counters().broken_chains, 1u);
}

TEST_F(XmBus, SyncAndBulkInstructionsToOneIdAreInstructionErrors) {
  EXPECT_EQ(dispatch(instruction(1, instruction::kSyncRead, {0x84, 0x00, 0x04, 0x00, 1})), status(1, p2_error::kInstruction));
}

TEST_F(XmBus, BroadcastReadIsNotAnswered) {
  EXPECT_TRUE(dispatch(instruction(0xFE, instruction::kRead, {0x84, 0x00, 0x04, 0x00})).empty());
}

TEST_F(XmBus, Protocol1PacketsAreIgnored) {
  InstructionPacket p1;
  p1.protocol = Protocol::kV1;
  p1.id = 1;
  p1.instruction = instruction::kPing;
  EXPECT_TRUE(bus.dispatch(p1, 1000000).empty());
}

}  // namespace
}  // namespace doppel::dynamixel
