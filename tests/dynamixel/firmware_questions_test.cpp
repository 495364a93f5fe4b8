// The two firmware questions of docs/devices.md 3.7, and the setup entry points robot files and
// the state directory use (Device::write_item, Device::eeprom, Device::restore_eeprom).
#include <gtest/gtest.h>

#include <vector>

#include "dynamixel/device_factory.h"
#include "dynamixel/protocol1_servo.h"
#include "dynamixel/protocol2_device.h"
#include "dynamixel/protocol2_factory.h"
#include "test_support.h"

namespace doppel::dynamixel {
namespace {

using testing::Bytes;
using testing::make_packet;
using testing::transact;

constexpr uint8_t kWrite = 0x03, kSyncWrite = 0x83;

Protocol1Servo make_servo(const char* model) { return Protocol1Servo(model_spec(model), 1, 1, 250); }

// (a) A Protocol 1.0 servo whose Goal Position is written with Torque Enable 0 switches the torque
// on: what ROBOTIS' DARwIn-OP framework (which never writes Torque Enable) relies on.
TEST(FirmwareQuestions, GoalPositionWriteSwitchesTorqueOnForEveryProtocol1Servo) {
  for (const char* model : {"AX-12A", "RX-28", "RX-64", "MX-28", "MX-64", "MX-106"}) {
    auto sut = make_servo(model);
    ASSERT_EQ(sut.register_raw(p1::kTorqueEnable), 0) << model;
    EXPECT_FALSE(sut.command().torque_enabled) << model;
    const uint16_t goal = sut.register_raw(p1::kPresentPosition);
    EXPECT_EQ(transact(sut, make_packet(1, kWrite, {p1::kGoalPosition, static_cast<uint8_t>(goal & 0xFF),
                                                    static_cast<uint8_t>(goal >> 8)})),
              (Bytes{0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC}))
        << model;
    EXPECT_EQ(sut.register_raw(p1::kTorqueEnable), 1) << model;
    EXPECT_TRUE(sut.command().torque_enabled) << model;
  }
}

TEST(FirmwareQuestions, AWriteOfTorqueEnable0WithTheGoalKeepsTheTorqueOff) {
  auto sut = make_servo("MX-28");
  // 24..31: Torque Enable 0, LED, D, I, P Gain, reserved 29, Goal Position 2048.
  transact(sut, make_packet(1, kWrite, {24, 0, 0, 0, 0, 32, 0, 0x00, 0x08}));
  EXPECT_EQ(sut.register_raw(p1::kGoalPosition), 2048);
  EXPECT_EQ(sut.register_raw(p1::kTorqueEnable), 0);
}

TEST(FirmwareQuestions, OtherItemsLeaveTheTorqueAlone) {
  auto sut = make_servo("RX-64");
  transact(sut, make_packet(1, kWrite, {p1::kMovingSpeed, 100, 0}));
  EXPECT_EQ(sut.register_raw(p1::kTorqueEnable), 0);
}

// The X series' Protocol 2.0 manual makes Torque Enable the only switch (reference §3.7).
TEST(FirmwareQuestions, AnXServoInProtocol2KeepsItsTorqueOffOnAGoalWrite) {
  BuiltDevice built = make_protocol2_device("XM430-W350", 1, 1000000);
  auto& sut = static_cast<Protocol2Device&>(*built.device);
  ASSERT_EQ(sut.write_item(x430::kGoalPosition, 2048), "");
  EXPECT_FALSE(sut.torque_enabled());
}

// ROBOTIS' DARwIn-OP framework SYNC WRITEs 26..31 to its MX-28s (D, I, P Gain, 0, Goal Position):
// the byte at 29 takes the write, so the goal arrives and the torque comes on.
TEST(FirmwareQuestions, TheDarwinOpSyncWriteFromDGainIsExecuted) {
  auto sut = make_servo("MX-28");
  Response response;
  sut.handle(make_packet(0xFE, kSyncWrite, {26, 6, 1, 0, 0, 32, 0, 0x00, 0x06}), response);
  EXPECT_FALSE(response.transmits);
  EXPECT_EQ(sut.register_raw(p1::kGoalPosition), 0x600);
  EXPECT_EQ(sut.register_raw(p1::kTorqueEnable), 1);
}

// (b) A WRITE covering an out-of-range item: Range Error, and nothing of the packet is stored.
TEST(FirmwareQuestions, AWriteCoveringAnOutOfRangeItemIsRefusedWhole) {
  auto sut = make_servo("AX-12A");
  // 26..33: Compliance Margins 5/5, Slopes 64/64, Goal Position 512, Moving Speed 1500 (> 1023 in joint mode).
  const Bytes status = transact(sut, make_packet(1, kWrite, {26, 5, 5, 64, 64, 0x00, 0x02, 0xDC, 0x05}));
  ASSERT_EQ(status.size(), 6u);
  EXPECT_EQ(status[4], p1_error::kRange);
  EXPECT_EQ(sut.register_raw(p1::kCwComplianceMargin), 1);
  EXPECT_EQ(sut.register_raw(p1::kCwComplianceSlope), 32);
  EXPECT_EQ(sut.register_raw(p1::kTorqueEnable), 0);
}

TEST(DeviceSetup, WriteItemChecksAsTheFirmwareDoes) {
  auto sut = make_servo("RX-64");
  EXPECT_EQ(sut.write_item(p1::kReturnDelayTime, 0), "");
  EXPECT_EQ(sut.return_delay_us(), 0u);
  EXPECT_NE(sut.write_item(p1::kStatusReturnLevel, 3).find("Range Error"), std::string::npos);
  EXPECT_NE(sut.write_item(31, 1).find("starts at address 31"), std::string::npos);
}

TEST(DeviceSetup, EepromAreaRoundTripsThroughRestore) {
  auto changed = make_servo("MX-28");
  ASSERT_EQ(changed.write_item(p1::kId, 9), "");
  ASSERT_EQ(changed.write_item(p1::kCwAngleLimit, 1000), "");
  // MX-28 EEPROM: addresses 0..22 (Resolution Divider is the last EEPROM item, reference §3.5).
  ASSERT_EQ(changed.eeprom().size(), 23u);
  const std::vector<uint8_t> saved(changed.eeprom().begin(), changed.eeprom().end());

  auto sut = make_servo("MX-28");
  EXPECT_EQ(sut.restore_eeprom(saved), "");
  EXPECT_EQ(sut.id(), 9);
  EXPECT_EQ(sut.register_raw(p1::kCwAngleLimit), 1000);
  EXPECT_EQ(sut.register_raw(p1::kTorqueLimit), sut.register_raw(p1::kMaxTorque));  // powered on again

  std::vector<uint8_t> foreign = saved;
  foreign[0] = 64;  // Model Number of an RX-64
  auto untouched = make_servo("MX-28");
  EXPECT_NE(untouched.restore_eeprom(foreign).find("Model Number (0) = 64 differs"), std::string::npos);
  EXPECT_EQ(untouched.id(), 1);
  EXPECT_NE(untouched.restore_eeprom(std::vector<uint8_t>(5)).find("5 EEPROM bytes"), std::string::npos);
}

TEST(DeviceSetup, Protocol2EepromKeepsTheProtocolType) {
  BuiltDevice changed = make_protocol2_device("XM430-W350", 1, 1000000);
  ASSERT_EQ(changed.device->write_item(x430::kProtocolType, 1), "");
  EXPECT_EQ(changed.device->protocol(), Protocol::kV1);
  const std::vector<uint8_t> saved(changed.device->eeprom().begin(), changed.device->eeprom().end());
  ASSERT_EQ(saved.size(), 64u);
  BuiltDevice sut = make_protocol2_device("XM430-W350", 1, 1000000);
  EXPECT_EQ(sut.device->restore_eeprom(saved), "");
  EXPECT_EQ(sut.device->protocol(), Protocol::kV1);
}

}  // namespace
}  // namespace doppel::dynamixel
