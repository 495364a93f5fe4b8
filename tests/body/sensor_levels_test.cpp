// Sensor levels (body/sensor_levels.h): a device's registers, set by its firmware model from a
// known measurement, decode back to that measurement within one register unit, and the raw values
// are those the manuals' units give (golden values worked out by hand in the comments).

#include "body/sensor_levels.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <variant>

#include "dynamixel/device_factory.h"
#include "dynamixel/protocol2_factory.h"

namespace doppel::body {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kG = 9.80665;

struct Built {
  dynamixel::BuiltDevice device;
  LevelsDevice levels;
};

Built build(const std::string& model, dynamixel::Protocol firmware, uint8_t id = 1) {
  dynamixel::BuiltDevice device = firmware == dynamixel::Protocol::kV2
                                      ? dynamixel::make_protocol2_device(model, id, 1'000'000)
                                      : dynamixel::make_protocol1_device(model, id, 1'000'000);
  LevelsDevice levels = levels_device(0, id, "dev", model, firmware, *device.device);
  return {std::move(device), std::move(levels)};
}

DeviceTable table_of(const dynamixel::Device& device) {
  DeviceTable table;
  copy_table(device_table(device), true, table);
  return table;
}

dynamixel::ServoFeedback servo_feedback(double position_rad, double velocity_rad_s, double ratio) {
  dynamixel::ServoFeedback f;
  f.position_rad = position_rad;
  f.velocity_rad_s = velocity_rad_s;
  f.torque_ratio = ratio;
  f.voltage_v = 12.0;
  f.temperature_c = 40.0;
  return f;
}

TEST(SensorLevels, Mx28DecodesPresentRegistersWithinOneUnit) {
  Built b = build("MX-28", dynamixel::Protocol::kV1);
  std::get<dynamixel::SimulatedServo*>(b.device.role)->apply(servo_feedback(0.5, -1.0, 0.3));
  levels::ServoDecoded d;
  decode_servo(b.levels, table_of(*b.device.device), d);
  // e-Manual MX-28: 0.088 deg (2 pi / 4096 rad) per unit, 2048 at the centre: 2048 + 325.95 -> 2374.
  EXPECT_EQ(d.present_position_raw(), 2374);
  EXPECT_NEAR(d.present_position_rad(), 0.5, 2 * kPi / 4096);
  // 1 rad/s = 9.549 rpm = 83.8 units of 0.114 rpm -> 84, CW (negative) sets bit 10: 1108.
  EXPECT_EQ(d.present_speed_raw(), 84 | 0x400);
  EXPECT_NEAR(d.present_speed_rad_s(), -1.0, 0.114 * 2 * kPi / 60);
  // 30 % of 1023 -> 307, CCW.
  EXPECT_EQ(d.present_load_raw(), 307);
  EXPECT_NEAR(d.present_load_ratio(), 0.3, 1.0 / 1023);
  EXPECT_EQ(d.present_voltage_raw(), 120);
  EXPECT_DOUBLE_EQ(d.present_voltage_v(), 12.0);
  EXPECT_DOUBLE_EQ(d.present_temperature_c(), 40.0);
  EXPECT_FALSE(d.has_present_current_a()) << "the MX-28 has no current register";
}

TEST(SensorLevels, Ax12aDecodesItsThreeHundredDegreeRange) {
  Built b = build("AX-12A", dynamixel::Protocol::kV1);
  std::get<dynamixel::SimulatedServo*>(b.device.role)->apply(servo_feedback(-0.3, 0.0, -0.5));
  levels::ServoDecoded d;
  decode_servo(b.levels, table_of(*b.device.device), d);
  // 1024 units over 300 deg: 195.57 per rad; -0.3 rad = -58.7 -> 512 - 59 = 453.
  EXPECT_EQ(d.present_position_raw(), 453);
  EXPECT_NEAR(d.present_position_rad(), -0.3, 300.0 / 1024 * kPi / 180);
  EXPECT_EQ(d.present_load_raw(), 512 | 0x400);  // 0.5 x 1023 = 511.5 -> 512, CW
  EXPECT_NEAR(d.present_load_ratio(), -0.5, 1.0 / 1023);
}

TEST(SensorLevels, Mx64DecodesItsCurrent) {
  Built b = build("MX-64", dynamixel::Protocol::kV1);
  dynamixel::ServoFeedback f = servo_feedback(0.0, 0.0, 0.1);
  f.current_a = -0.9;  // e-Manual MX-64: I = 4.5 mA x (Current - 2048): 2048 - 200 = 1848
  std::get<dynamixel::SimulatedServo*>(b.device.role)->apply(f);
  levels::ServoDecoded d;
  decode_servo(b.levels, table_of(*b.device.device), d);
  ASSERT_TRUE(d.has_present_current_a());
  EXPECT_NEAR(d.present_current_a(), -0.9, 1e-9);
}

TEST(SensorLevels, Xm430DecodesThroughReverseModeAndHomingOffset) {
  Built b = build("XM430-W350", dynamixel::Protocol::kV2);
  ASSERT_EQ(b.device.device->write_item(10, 1), "");     // Drive Mode: reverse
  ASSERT_EQ(b.device.device->write_item(20, 1024), "");  // Homing Offset
  dynamixel::ServoFeedback f = servo_feedback(0.25, 2.0, 0.0);
  f.current_a = 0.5;
  std::get<dynamixel::SimulatedServo*>(b.device.role)->apply(f);
  levels::ServoDecoded d;
  decode_servo(b.levels, table_of(*b.device.device), d);
  // 0.25 rad = 162.97 -> 163 pulses, reversed: 2048 - 163 + 1024 = 2909.
  EXPECT_EQ(d.present_position_raw(), 2909);
  EXPECT_NEAR(d.present_position_rad(), 0.25, 2 * kPi / 4096);
  // 2 rad/s = 19.10 rpm = 83.4 units of 0.229 rpm -> -83 reversed.
  EXPECT_EQ(d.present_speed_raw(), -83);
  EXPECT_NEAR(d.present_speed_rad_s(), 2.0, 0.229 * 2 * kPi / 60);
  // XM430-W350 Present Current: 2.69 mA per unit: 0.5 A = 185.9 -> -186 reversed.
  EXPECT_EQ(d.present_load_raw(), -186);
  ASSERT_TRUE(d.has_present_current_a());
  EXPECT_NEAR(d.present_current_a(), 0.5, 0.00269);
  EXPECT_DOUBLE_EQ(d.present_voltage_v(), 12.0);
}

dynamixel::ImuFeedback imu_feedback() {
  dynamixel::ImuFeedback f;
  f.roll_rad = 0.1;
  f.pitch_rad = -0.2;
  f.yaw_rad = 0.3;
  f.w_WS_S_rad_s = {0.5, -0.2, 0.1};
  f.a_WS_S_m_s2 = {1.0, -2.0, kG};
  return f;
}

void expect_vector(const levels::Vector3& v, const std::array<double, 3>& want, double tolerance) {
  EXPECT_NEAR(v.x(), want[0], tolerance);
  EXPECT_NEAR(v.y(), want[1], tolerance);
  EXPECT_NEAR(v.z(), want[2], tolerance);
}

TEST(SensorLevels, Cm730DecodesTenBitGyroAndAccelerometerInTheSensorFrame) {
  Built b = build("CM-730", dynamixel::Protocol::kV1, 200);
  const dynamixel::ImuFeedback f = imu_feedback();
  std::get<dynamixel::SimulatedController*>(b.device.role)->apply(f);
  levels::ImuDecoded d;
  decode_imu(b.levels, table_of(*b.device.device), d);
  EXPECT_FALSE(d.has_orientation());
  // Raw in register order Gyro X, Y, Z, Acc X, Y, Z. Gyro X = -w.y = 11.46 deg/s / (1600/512) = 3.7 -> 516;
  // Acc Z = 1 g / (4/512 g) = 128 -> 640.
  ASSERT_EQ(d.raw_size(), 6);
  EXPECT_EQ(d.raw(0), 516);
  EXPECT_EQ(d.raw(5), 640);
  expect_vector(d.gyro_rad_s(), f.w_WS_S_rad_s, 1600.0 / 512 * kPi / 180);
  expect_vector(d.accel_m_s2(), f.a_WS_S_m_s2, 4.0 / 512 * kG);
  EXPECT_DOUBLE_EQ(d.accel_m_s2().z(), kG);
}

TEST(SensorLevels, FumanoidImuDecodesAnglesRatesAndSpecificForce) {
  Built b = build("FUMANOID-IMU", dynamixel::Protocol::kV1, 100);
  const dynamixel::ImuFeedback f = imu_feedback();
  std::get<dynamixel::SimulatedImu*>(b.device.role)->apply(f);
  levels::ImuDecoded d;
  decode_imu(b.levels, table_of(*b.device.device), d);
  ASSERT_TRUE(d.has_orientation());
  EXPECT_DOUBLE_EQ(d.pitch_rad(), -0.2);  // -2000 x 0.1 mrad
  EXPECT_NEAR(d.roll_rad(), 0.1, 0.5e-4);
  EXPECT_NEAR(d.yaw_rad(), 0.3, 0.5e-4);
  expect_vector(d.gyro_rad_s(), f.w_WS_S_rad_s, 0.5e-3);
  EXPECT_DOUBLE_EQ(d.accel_m_s2().z(), 9.81);  // 981 x 0.01 m/s^2
}

TEST(SensorLevels, OpenCrDecodesMpu9250Counts) {
  Built b = build("OPEN-CR", dynamixel::Protocol::kV2, 200);
  const dynamixel::ImuFeedback f = imu_feedback();
  std::get<dynamixel::SimulatedController*>(b.device.role)->apply(f);
  levels::ImuDecoded d;
  decode_imu(b.levels, table_of(*b.device.device), d);
  // Acc Z: 1 g = 16384 counts; Gyro X: 0.5 rad/s = 28.65 deg/s x 16.4 = 469.8 -> 470; roll 5.73 deg -> 57.
  ASSERT_EQ(d.raw_size(), 9);
  EXPECT_EQ(d.raw(0), 470);
  EXPECT_EQ(d.raw(5), 16384);
  EXPECT_EQ(d.raw(6), 57);
  expect_vector(d.gyro_rad_s(), f.w_WS_S_rad_s, 1.0 / 16.4 * kPi / 180);
  expect_vector(d.accel_m_s2(), f.a_WS_S_m_s2, kG / 16384);
  EXPECT_NEAR(d.roll_rad(), 0.1, 0.1 * kPi / 180);
  EXPECT_NEAR(d.pitch_rad(), -0.2, 0.1 * kPi / 180);
}

TEST(SensorLevels, BitbotsImuDecodesFloatsAndTheQuaternionsAngles) {
  Built b = build("BITBOTS-IMU", dynamixel::Protocol::kV2, 241);
  const dynamixel::ImuFeedback f = imu_feedback();
  std::get<dynamixel::SimulatedImu*>(b.device.role)->apply(f);
  levels::ImuDecoded d;
  decode_imu(b.levels, table_of(*b.device.device), d);
  EXPECT_NEAR(d.roll_rad(), 0.1, 1e-6);  // float32 quaternion
  EXPECT_NEAR(d.pitch_rad(), -0.2, 1e-6);
  EXPECT_NEAR(d.yaw_rad(), 0.3, 1e-6);
  expect_vector(d.gyro_rad_s(), f.w_WS_S_rad_s, 1e-6);
  expect_vector(d.accel_m_s2(), f.a_WS_S_m_s2, 1e-5);
}

TEST(SensorLevels, FootBoardsDecodeEachCellInNewtons) {
  dynamixel::FootFeedback f;
  f.force_n = {10.0, 0.3, 2.5, 1.0};
  std::array<double, 4> force{};
  std::array<int64_t, 4> raw{};

  Built fsr = build("DARWIN-FSR", dynamixel::Protocol::kV1, 111);
  std::get<dynamixel::SimulatedFootBoard*>(fsr.device.role)->apply(f);
  decode_foot(fsr.levels, table_of(*fsr.device.device), force, raw);
  // 1 mN per unit; 0.3 N is below the FSR's smallest load (0.493 N) and reads 0.
  EXPECT_EQ(raw, (std::array<int64_t, 4>{10000, 0, 2500, 1000}));
  EXPECT_DOUBLE_EQ(force[0], 10.0);
  EXPECT_DOUBLE_EQ(force[1], 0.0);

  Built fumanoid = build("FUMANOID-FOOT", dynamixel::Protocol::kV1, 101);
  std::get<dynamixel::SimulatedFootBoard*>(fumanoid.device.role)->apply(f);
  decode_foot(fumanoid.levels, table_of(*fumanoid.device.device), force, raw);
  EXPECT_EQ(raw, (std::array<int64_t, 4>{1000, 30, 250, 100}));  // 0.01 N
  EXPECT_DOUBLE_EQ(force[1], 0.3);

  Built bitfoot = build("BITFOOT", dynamixel::Protocol::kV2, 101);
  std::get<dynamixel::SimulatedFootBoard*>(bitfoot.device.role)->apply(f);
  decode_foot(bitfoot.levels, table_of(*bitfoot.device.device), force, raw);
  // Default calibration: 1e7 counts at no load, 3e-6 N per count: 10 N = 1e7 + 3333333.
  EXPECT_EQ(raw[0], 13333333);
  for (std::size_t i = 0; i < 4; ++i) EXPECT_NEAR(force[i], f.force_n[i], 3e-6);
}

TEST(SensorLevels, APowerBoardHasNoDecoder) {
  dynamixel::BuiltDevice core = dynamixel::make_protocol2_device("BITBOTS-CORE", 42, 1'000'000);
  EXPECT_THROW(levels_device(0, 42, "core", "BITBOTS-CORE", dynamixel::Protocol::kV2, *core.device),
               std::invalid_argument);
}

TEST(SensorLevels, AppendPutsDecodedBesideTruthPerDevice) {
  Built servo = build("MX-28", dynamixel::Protocol::kV1, 7);
  Built imu = build("CM-730", dynamixel::Protocol::kV1, 200);
  BusLevelsSample sample;
  sample.sequence = 1;
  sample.sim_time_ns = 5'000'000;
  sample.servo_truth[0] = servo_feedback(-1.2, 0.4, 0.05);
  sample.servo_truth[0].torque_nm = 0.125;
  std::get<dynamixel::SimulatedServo*>(servo.device.role)->apply(sample.servo_truth[0]);
  copy_table(device_table(*servo.device.device), true, sample.servo_tables[0]);
  sample.imu_truth[0] = imu_feedback();
  std::get<dynamixel::SimulatedController*>(imu.device.role)->apply(sample.imu_truth[0]);
  copy_table(device_table(*imu.device.device), true, sample.imu_tables[0]);
  BusLevelsLayout layout;
  layout.servos.push_back(servo.levels);
  layout.imus.push_back(imu.levels);

  levels::SensorLevels out;
  append_bus_levels(layout, sample, out);
  ASSERT_EQ(out.servos_size(), 1);
  const levels::ServoLevels& s = out.servos(0);
  EXPECT_EQ(s.id(), 7u);
  EXPECT_EQ(s.model(), "MX-28");
  EXPECT_EQ(s.sim_time_ns(), 5'000'000);
  EXPECT_DOUBLE_EQ(s.truth().angle_rad(), -1.2);
  EXPECT_DOUBLE_EQ(s.truth().torque_nm(), 0.125);
  EXPECT_NEAR(s.decoded().present_position_rad(), s.truth().angle_rad(), 2 * kPi / 4096);
  ASSERT_EQ(out.imus_size(), 1);
  EXPECT_DOUBLE_EQ(out.imus(0).truth().specific_force_m_s2().z(), kG);
  EXPECT_NEAR(out.imus(0).decoded().accel_m_s2().z(), kG, 4.0 / 512 * kG);
  EXPECT_EQ(out.sim_time_ns(), 5'000'000);
  EXPECT_EQ(out.feet_size(), 0);
}

}  // namespace
}  // namespace doppel::body
