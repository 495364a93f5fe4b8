#include "dynamixel/models.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>
#include <variant>

#include "dynamixel/device_factory.h"
#include "dynamixel/fumanoid_boards.h"
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
    for (const char* name : {"AX-12A", "RX-28", "RX-64", "MX-28", "MX-64", "MX-106", "FUMANOID-IMU", "FUMANOID-FOOT"}) {
      EXPECT_NE(what.find(name), std::string::npos) << name;
    }
    EXPECT_NE(what.find("AX-18A"), std::string::npos);
  }
  EXPECT_EQ(known_models().size(), 8u);
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

TEST(Models, GearRatiosOfReference) {
  EXPECT_EQ(model_spec("AX-12A").servo.gear_ratio, 254);
  EXPECT_EQ(model_spec("RX-28").servo.gear_ratio, 193);
  EXPECT_EQ(model_spec("RX-64").servo.gear_ratio, 200);
  EXPECT_EQ(model_spec("MX-28").servo.gear_ratio, 193);
  EXPECT_EQ(model_spec("MX-64").servo.gear_ratio, 200);
  EXPECT_EQ(model_spec("MX-106").servo.gear_ratio, 225);
}

TEST(Models, ThesisMotorConstantsForRx) {
  const ServoSpec& rx64 = model_spec("RX-64").servo;
  const ServoSpec& rx28 = model_spec("RX-28").servo;
  EXPECT_DOUBLE_EQ(rx64.ke_v_s_per_rad, 2.82);
  EXPECT_DOUBLE_EQ(rx64.kt_n_m_per_a, 3.2);
  EXPECT_DOUBLE_EQ(rx28.ke_v_s_per_rad, 2.02);
  EXPECT_DOUBLE_EQ(rx28.kt_n_m_per_a, 1.9);
}

TEST(Models, MotorModelReproducesDatasheetPoint) {
  for (const ModelSpec* m : known_models()) {
    if (m->kind != DeviceKind::kServo) {
      continue;
    }
    const ServoSpec& s = m->servo;
    const double v = s.nominal_voltage_v;
    // No load: back-EMF takes the whole supply. Stall: tau = kt * V / R.
    const double no_load_rad_s = v / s.ke_v_s_per_rad;
    const double stall_n_m = s.kt_n_m_per_a * v / s.resistance_ohm;
    EXPECT_NEAR(no_load_rad_s, rpm_to_rad_s(s.no_load_speed_rpm), 0.05 * rpm_to_rad_s(s.no_load_speed_rpm)) << m->name;
    // Exact for the derived models; the thesis' RX constants (fitted at 15 V) stay within 1.5x.
    EXPECT_GT(stall_n_m, s.stall_torque_n_m / 1.5) << m->name;
    EXPECT_LT(stall_n_m, s.stall_torque_n_m * 1.5) << m->name;
  }
}

TEST(Models, DerivedConstantsOfAx12a) {
  const ServoSpec& s = model_spec("AX-12A").servo;
  // 12 V, 59 rpm, 1.5 N m at 1.5 A (reference §5).
  EXPECT_NEAR(s.ke_v_s_per_rad, 12.0 / rpm_to_rad_s(59.0), 1e-12);
  EXPECT_NEAR(s.resistance_ohm, 8.0, 1e-12);
  EXPECT_NEAR(s.kt_n_m_per_a, 1.0, 1e-12);
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
