// XH540-W270 and XH540-W150 through the model registry. Golden values: the e-Manual pages
// dxl/x/xh540-w270 and dxl/x/xh540-w150 (control tables) and the X540 comparison table
// (stall torque, current and no-load speed at 12 V).
#include <gtest/gtest.h>

#include <variant>

#include "dynamixel/model_registry.h"
#include "dynamixel/protocol2_factory.h"
#include "dynamixel/protocol2_servo.h"
#include "test_support.h"

namespace doppel::dynamixel {
namespace {

using testing::Bytes;
using testing::p2::instruction;
using testing::p2::status;
using testing::p2::transact;

const P2RegisterSpec& item(const P2ModelSpec& spec, uint16_t address) {
  const P2RegisterSpec* r = find_p2_register(spec.registers, address);
  EXPECT_NE(r, nullptr) << address;
  static const P2RegisterSpec kNone{};
  return r != nullptr ? *r : kNone;
}

TEST(Xh540, ModelNumbersAndTheirControlTables) {
  const P2ModelSpec& w270 = p2_model_spec("XH540-W270");
  const P2ModelSpec& w150 = p2_model_spec("XH540-W150");
  EXPECT_EQ(w270.model_number, 1100);
  EXPECT_EQ(w150.model_number, 1110);
  for (const P2ModelSpec* spec : {&w270, &w150}) {
    EXPECT_EQ(item(*spec, 32).default_raw, 160);  // Max Voltage Limit, 95..160
    EXPECT_EQ(item(*spec, 34).default_raw, 95);
    EXPECT_EQ(item(*spec, 34).min_raw, 95);
    EXPECT_EQ(item(*spec, 38).default_raw, 2047);  // Current Limit, 2.69 mA
    EXPECT_EQ(item(*spec, 38).max_raw, 2047);
    EXPECT_DOUBLE_EQ(spec->current_unit_a, 0.00269);
    EXPECT_EQ(item(*spec, 31).default_raw, 80);  // Temperature Limit
    EXPECT_EQ(item(*spec, 76).default_raw, 1920);
    EXPECT_EQ(item(*spec, 78).default_raw, 100);
    EXPECT_EQ(item(*spec, 84).default_raw, 800);  // Position P Gain
    for (uint16_t a : {56, 57, 58}) {             // External Port Mode 1..3
      EXPECT_EQ(item(*spec, a).default_raw, 3);
      EXPECT_EQ(item(*spec, a).max_raw, 3);
      EXPECT_EQ(item(*spec, a).area, Area::kEeprom);
    }
    for (uint16_t a : {152, 154, 156}) {  // External Port Data 1..3
      EXPECT_EQ(item(*spec, a).size, 2);
      EXPECT_EQ(item(*spec, a).access, Access::kReadWrite);
    }
    EXPECT_EQ(find_p2_register(spec->registers, 40), nullptr);  // no Acceleration Limit
    EXPECT_EQ(spec->operating_modes, 0b1'0000'0000'0011'1011u);  // 0, 1, 3, 4, 5, 16
  }
  EXPECT_EQ(item(w270, 44).default_raw, 167);  // Velocity Limit
  EXPECT_EQ(item(w150, 44).default_raw, 300);
  EXPECT_NE(find_p2_register(w270.registers, 60), nullptr);  // Startup Configuration: W270 page only
  EXPECT_EQ(find_p2_register(w150.registers, 60), nullptr);
}

TEST(Xh540, MotorFromTheDatasheet) {
  const MotorSpec& w270 = *servo_spec("XH540-W270").motor;
  EXPECT_DOUBLE_EQ(w270.stall_torque_nm, 9.9);
  EXPECT_DOUBLE_EQ(w270.stall_current_a, 4.9);
  EXPECT_DOUBLE_EQ(w270.no_load_speed_rpm, 39.0);
  EXPECT_DOUBLE_EQ(w270.gear_ratio, 272.5);
  EXPECT_DOUBLE_EQ(w270.resistance_ohm, 12.0 / 4.9);
  EXPECT_DOUBLE_EQ(w270.torque_constant_nm_a, 9.9 / 4.9);
  const MotorSpec& w150 = *servo_spec("XH540-W150").motor;
  EXPECT_DOUBLE_EQ(w150.stall_torque_nm, 7.1);
  EXPECT_DOUBLE_EQ(w150.no_load_speed_rpm, 70.0);
  EXPECT_DOUBLE_EQ(w150.gear_ratio, 152.3);
  // At stall the motor model gives the datasheet torque: kt x V / R.
  EXPECT_NEAR(w150.torque_constant_nm_a * w150.rated_voltage_v / w150.resistance_ohm, 7.1, 1e-9);
}

TEST(Xh540, PingReadAndWriteOverTheCodec) {
  BuiltDevice d = make_protocol2_device("XH540-W270", 13, 4'000'000, 0);
  ASSERT_NE(std::get<SimulatedServo*>(d.role), nullptr);
  Device& sut = *d.device;
  // 1100 = 0x044C, firmware 45.
  EXPECT_EQ(transact(sut, instruction(13, instruction::kPing)), status(13, 0, {0x4C, 0x04, 45}));
  // Velocity Limit 167 read back; Current Limit write above 2047 is a Data Range error.
  EXPECT_EQ(transact(sut, instruction(13, instruction::kRead, {44, 0, 4, 0})), status(13, 0, {167, 0, 0, 0}));
  EXPECT_EQ(transact(sut, instruction(13, instruction::kWrite, {38, 0, 0x00, 0x08})), status(13, 0x04));
  EXPECT_EQ(transact(sut, instruction(13, instruction::kWrite, {38, 0, 0xE8, 0x03})), status(13, 0));
  EXPECT_EQ(transact(sut, instruction(13, instruction::kRead, {38, 0, 2, 0})), status(13, 0, {0xE8, 0x03}));
  EXPECT_EQ(transact(sut, instruction(13, instruction::kWrite, {56, 0, 4})), status(13, 0x04));  // Port Mode 0..3
}

}  // namespace
}  // namespace doppel::dynamixel
