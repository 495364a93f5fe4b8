#include "dynamixel/models.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>
#include <variant>

#include "dynamixel/device_factory.h"
#include "dynamixel/fumanoid_boards.h"
#include "dynamixel/model_registry.h"
#include "dynamixel/protocol1_servo.h"

namespace doppel::dynamixel {
namespace {

constexpr double kPi = std::numbers::pi;
double rpm_to_rad_s(double rpm) { return rpm * 2 * kPi / 60; }

TEST(Models, ModelNumbersOfReference) {
  EXPECT_EQ(model_spec("AX-12A").model_number, 12);
  EXPECT_EQ(model_spec("RX-28").model_number, 28);
  EXPECT_EQ(model_spec("RX-64").model_number, 64);
  EXPECT_EQ(model_spec("MX-28").model_number, 29);
  EXPECT_EQ(model_spec("MX-64").model_number, 310);
  EXPECT_EQ(model_spec("MX-106").model_number, 320);
}

TEST(Models, BoardModelNumbersCollideWithNoKnownDevice) {
  // Reference §3.1 and §8 (BitFoot 0, DARwIn FSR 340, IMU 0xBAFF, CM-730 0x7300, OpenCR 0x7400).
  for (uint16_t taken : {0, 12, 28, 64, 29, 30, 310, 311, 320, 321, 1020, 1030, 1060, 340, 0xBAFF, 0x7300, 0x7400}) {
    EXPECT_NE(model_spec("FUMANOID-IMU").model_number, taken);
    EXPECT_NE(model_spec("FUMANOID-FOOT").model_number, taken);
  }
  EXPECT_NE(kFumanoidImuModelNumber, kFumanoidFootModelNumber);
}

TEST(Models, UnknownNameThrowsListingKnownNames) {
  try {
    (void)model_spec("AX-18A");
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    for (const char* name : {"AX-12A", "RX-28", "RX-64", "MX-28", "MX-64", "MX-106", "FUMANOID-IMU", "FUMANOID-FOOT",
                             "CM-730", "DARWIN-FSR"}) {
      EXPECT_NE(what.find(name), std::string::npos) << name;
    }
    EXPECT_NE(what.find("AX-18A"), std::string::npos);
  }
  EXPECT_EQ(known_models().size(), 10u);
}

TEST(Models, OnlyMxAndBoardsUnderstandBulkRead) {
  EXPECT_FALSE(model_spec("AX-12A").bulk_read);
  EXPECT_FALSE(model_spec("RX-28").bulk_read);
  EXPECT_FALSE(model_spec("RX-64").bulk_read);
  EXPECT_TRUE(model_spec("MX-28").bulk_read);
  EXPECT_TRUE(model_spec("MX-64").bulk_read);
  EXPECT_TRUE(model_spec("MX-106").bulk_read);
  EXPECT_TRUE(model_spec("FUMANOID-IMU").bulk_read);
  EXPECT_TRUE(model_spec("FUMANOID-FOOT").bulk_read);
}

TEST(Models, PositionAndSpeedUnits) {
  const ServoSpec& ax = model_spec("AX-12A").servo;
  const ServoSpec& mx = model_spec("MX-106").servo;
  // 1024 units over 300 deg; 4096 units over 360 deg.
  EXPECT_NEAR(ax.units_per_rad(), 1024 / (300 * kPi / 180), 1e-9);
  EXPECT_NEAR(mx.units_per_rad(), 4096 / (2 * kPi), 1e-9);
  EXPECT_EQ(ax.position_center_raw, 512);
  EXPECT_EQ(mx.position_center_raw, 2048);
  EXPECT_DOUBLE_EQ(ax.speed_unit_rpm, 0.111);
  EXPECT_DOUBLE_EQ(mx.speed_unit_rpm, 0.114);
}

// The registry's motor entries: what the physics simulates (body/motor_params.h) and the firmware's
// current control computes with (servo_controller_config). Golden values: reference §5 and the
// thesis' Table 7.
struct DatasheetRow {
  const char* name;
  double volts, no_load_rpm, stall_nm, stall_a, gear;
};
constexpr DatasheetRow kDatasheet[] = {
    {"AX-12A", 12.0, 59, 1.5, 1.5, 254},      {"RX-28", 18.5, 85, 3.7, 1.9, 193},
    {"RX-64", 18.5, 64, 5.3, 2.6, 200},       {"MX-28", 12.0, 55, 2.5, 1.4, 193},
    {"MX-64", 12.0, 63, 6.0, 4.1, 200},       {"MX-106", 12.0, 45, 8.4, 5.2, 225},
    {"XM430-W350", 12.0, 46, 4.1, 2.3, 353.5}, {"XL430-W250", 12.0, 61, 1.5, 1.4, 258.5},
    // e-Manual X540 comparison table at 12 V; gear ratio of the XH540-V pages.
    {"XH540-W270", 12.0, 39, 9.9, 4.9, 272.5}, {"XH540-W150", 12.0, 70, 7.1, 4.9, 152.3},
};

TEST(Models, EveryServoHasTheDatasheetPointOfReference) {
  for (const DatasheetRow& row : kDatasheet) {
    const MotorSpec& m = *servo_spec(row.name).motor;
    EXPECT_DOUBLE_EQ(m.rated_voltage_v, row.volts) << row.name;
    EXPECT_DOUBLE_EQ(m.no_load_speed_rpm, row.no_load_rpm) << row.name;
    EXPECT_DOUBLE_EQ(m.stall_torque_nm, row.stall_nm) << row.name;
    EXPECT_DOUBLE_EQ(m.stall_current_a, row.stall_a) << row.name;
    EXPECT_DOUBLE_EQ(m.gear_ratio, row.gear) << row.name;
  }
}

TEST(Models, EveryServoModelOfBothProtocolsHasAMotor) {
  std::size_t servos = 0;
  for (const ModelSpec* m : known_models()) {
    if (m->kind != DeviceKind::kServo) continue;
    ++servos;
    ASSERT_NE(m->servo.motor, nullptr) << m->name;
    EXPECT_GT(m->servo.motor->torque_constant_nm_a, 0.0) << m->name;
  }
  for (const P2ModelSpec* m : known_p2_models()) {
    if (m->kind != P2DeviceKind::kServo) continue;
    ++servos;
    ASSERT_NE(m->servo.motor, nullptr) << m->name;
    EXPECT_GT(m->servo.motor->torque_constant_nm_a, 0.0) << m->name;
  }
  EXPECT_EQ(servos, 13u);
  EXPECT_EQ(find_servo_spec("FUMANOID-IMU"), nullptr);
  EXPECT_EQ(find_servo_spec("CM-730"), nullptr);
  EXPECT_EQ(find_servo_spec("OPEN-CR"), nullptr);
  EXPECT_EQ(find_servo_spec("BITBOTS-CORE"), nullptr);
  EXPECT_THROW((void)servo_spec("AX-18A"), std::invalid_argument);
}

TEST(Models, MxKeepsItsMotorUnderProtocol2Firmware) {
  EXPECT_EQ(p2_model_spec("MX-28(2.0)").servo.motor, model_spec("MX-28").servo.motor);
  EXPECT_EQ(p2_model_spec("MX-64(2.0)").servo.motor, model_spec("MX-64").servo.motor);
  EXPECT_EQ(p2_model_spec("MX-106(2.0)").servo.motor, model_spec("MX-106").servo.motor);
}

TEST(Models, ThesisTable7ConstantsForRx) {
  const MotorSpec& rx64 = *model_spec("RX-64").servo.motor;
  const MotorSpec& rx28 = *model_spec("RX-28").servo.motor;
  EXPECT_DOUBLE_EQ(rx64.back_emf_v_s_rad, 2.82);
  EXPECT_DOUBLE_EQ(rx64.resistance_ohm, 0.75);
  EXPECT_DOUBLE_EQ(rx64.torque_constant_nm_a, 3.2);
  EXPECT_DOUBLE_EQ(rx28.back_emf_v_s_rad, 2.02);
  EXPECT_DOUBLE_EQ(rx28.resistance_ohm, 0.8);
  EXPECT_DOUBLE_EQ(rx28.torque_constant_nm_a, 1.9);
  // Table 7's ke gives the RX-64's no-load speed within 6 % of the datasheet's (docs/physics.md).
  EXPECT_NEAR(18.5 / rx64.back_emf_v_s_rad, rpm_to_rad_s(64.0), 0.06 * rpm_to_rad_s(64.0));
}

TEST(Models, DerivedMotorsReproduceTheirDatasheetPoint) {
  for (const DatasheetRow& row : kDatasheet) {
    if (std::string(row.name).starts_with("RX")) continue;  // Table 7, above
    const MotorSpec& m = *servo_spec(row.name).motor;
    // Stall: only the armature limits the current, tau = kt V / R = the datasheet's stall torque.
    EXPECT_NEAR(m.torque_constant_nm_a * row.volts / m.resistance_ohm, row.stall_nm, 1e-9) << row.name;
    EXPECT_NEAR(row.volts / m.resistance_ohm, row.stall_a, 1e-9) << row.name;
    // No load: the motor's torque just balances the gear friction at the datasheet speed.
    const double w = rpm_to_rad_s(row.no_load_rpm);
    EXPECT_NEAR(m.torque_constant_nm_a * (row.volts - m.back_emf_v_s_rad * w) / m.resistance_ohm,
                m.friction_nm + m.viscous_friction_nm_s_rad * w, 1e-9)
        << row.name;
  }
}

TEST(Models, GearFrictionAssumption) {
  // docs/physics.md: Coulomb 2 % of the stall torque, viscous another 2 % at the no-load speed.
  const MotorSpec& rx64 = *model_spec("RX-64").servo.motor;
  EXPECT_NEAR(rx64.friction_nm, 0.106, 1e-12);
  EXPECT_NEAR(rx64.viscous_friction_nm_s_rad * rpm_to_rad_s(64.0), 0.106, 1e-12);
}

TEST(Models, DerivedConstantsOfAx12a) {
  const MotorSpec& m = *model_spec("AX-12A").servo.motor;
  // 12 V, 59 rpm, 1.5 N m at 1.5 A (reference §5): R = 12 V / 1.5 A, kt = 1.5 N m / 1.5 A.
  EXPECT_NEAR(m.resistance_ohm, 8.0, 1e-12);
  EXPECT_NEAR(m.torque_constant_nm_a, 1.0, 1e-12);
  // ke = (V - R (Fc + Fv w) / kt) / w with Fc = Fv w = 0.03 N m: (12 - 8 x 0.06) / 6.1785 rad/s.
  EXPECT_NEAR(m.back_emf_v_s_rad, (12.0 - 0.48) / rpm_to_rad_s(59.0), 1e-12);
}

TEST(Baud, RegisterToRate) {
  EXPECT_EQ(p1_baud_bps(1, false), 1000000u);
  EXPECT_EQ(p1_baud_bps(3, false), 500000u);
  EXPECT_EQ(p1_baud_bps(16, false), 117647u);
  EXPECT_EQ(p1_baud_bps(34, false), 57142u);
  EXPECT_EQ(p1_baud_bps(207, false), 9615u);
  EXPECT_EQ(p1_baud_bps(254, false), 7843u);
  EXPECT_EQ(p1_baud_bps(250, true), 2250000u);
  EXPECT_EQ(p1_baud_bps(251, true), 2500000u);
  EXPECT_EQ(p1_baud_bps(252, true), 3000000u);
  EXPECT_EQ(p1_baud_bps(250, false), 7968u);
}

TEST(Baud, RateToRegister) {
  EXPECT_EQ(p1_baud_register(1000000, model_spec("RX-64")), 1);
  EXPECT_EQ(p1_baud_register(57600, model_spec("RX-64")), 34);
  EXPECT_EQ(p1_baud_register(115200, model_spec("AX-12A")), 16);
  EXPECT_EQ(p1_baud_register(9600, model_spec("AX-12A")), 207);
  EXPECT_EQ(p1_baud_register(3000000, model_spec("MX-28")), 252);
  EXPECT_THROW(p1_baud_register(3000000, model_spec("RX-28")), std::invalid_argument);
  EXPECT_THROW(p1_baud_register(1500000, model_spec("MX-28")), std::invalid_argument);
  EXPECT_THROW(p1_baud_register(0, model_spec("MX-28")), std::invalid_argument);
}

TEST(DeviceFactory, BuildsTheRightTypes) {
  auto servo = make_protocol1_device("RX-64", 2, 1000000);
  auto imu = make_protocol1_device("FUMANOID-IMU", 100, 1000000, 0);
  auto foot = make_protocol1_device("FUMANOID-FOOT", 101, 57600);

  auto* rx64 = dynamic_cast<Protocol1Servo*>(servo.device.get());
  ASSERT_NE(rx64, nullptr);
  EXPECT_EQ(std::get<SimulatedServo*>(servo.role), rx64);
  EXPECT_EQ(servo.device->id(), 2);
  EXPECT_EQ(servo.device->baud_bps(), 1000000u);
  EXPECT_EQ(servo.device->return_delay_us(), 500u);
  EXPECT_EQ(servo.device->model_name(), "RX-64");
  auto* fumanoid_imu = dynamic_cast<FumanoidImu*>(imu.device.get());
  ASSERT_NE(fumanoid_imu, nullptr);
  EXPECT_EQ(std::get<SimulatedImu*>(imu.role), fumanoid_imu);
  EXPECT_EQ(imu.device->return_delay_us(), 0u);
  auto* foot_board = dynamic_cast<FumanoidFootBoard*>(foot.device.get());
  ASSERT_NE(foot_board, nullptr);
  EXPECT_EQ(std::get<SimulatedFootBoard*>(foot.role), foot_board);
  EXPECT_EQ(foot.device->baud_bps(), 57142u);
}

TEST(DeviceFactory, RejectsBadConfig) {
  EXPECT_THROW(make_protocol1_device("XM430-W350", 1, 1000000), std::invalid_argument);
  EXPECT_THROW(make_protocol1_device("RX-64", 254, 1000000), std::invalid_argument);
  EXPECT_THROW(make_protocol1_device("RX-64", 1, 300), std::invalid_argument);
  EXPECT_THROW(make_protocol1_device("RX-64", 1, 1000000, 255), std::invalid_argument);
}

}  // namespace
}  // namespace doppel::dynamixel
