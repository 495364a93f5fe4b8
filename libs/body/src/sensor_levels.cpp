#include "body/sensor_levels.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numbers>
#include <stdexcept>

#include "dynamixel/control_table.h"
#include "dynamixel/darwin_boards.h"
#include "dynamixel/fumanoid_boards.h"
#include "dynamixel/opencr_board.h"
#include "dynamixel/protocol1_device.h"
#include "dynamixel/protocol2_device.h"
#include "dynamixel/protocol2_models.h"

namespace doppel::body {
namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;
constexpr double kDegToRad = std::numbers::pi / 180.0;
constexpr double kRpmToRadS = kTwoPi / 60.0;
// The "g" of the accelerometers' data sheets and e-Manual pages: standard gravity.
constexpr double kStandardGravityMS2 = 9.80665;

uint16_t u16(const DeviceTable& t, std::size_t a) { return static_cast<uint16_t>(t.bytes[a] | (t.bytes[a + 1] << 8)); }
int16_t i16(const DeviceTable& t, std::size_t a) { return static_cast<int16_t>(u16(t, a)); }
uint32_t u32(const DeviceTable& t, std::size_t a) {
  return static_cast<uint32_t>(t.bytes[a]) | static_cast<uint32_t>(t.bytes[a + 1]) << 8 |
         static_cast<uint32_t>(t.bytes[a + 2]) << 16 | static_cast<uint32_t>(t.bytes[a + 3]) << 24;
}
int32_t i32(const DeviceTable& t, std::size_t a) { return static_cast<int32_t>(u32(t, a)); }
float f32(const DeviceTable& t, std::size_t a) {
  const uint32_t bits = u32(t, a);
  float value = 0.0f;
  std::memcpy(&value, &bits, sizeof(value));
  return value;
}

// Protocol 1.0 Present Speed / Present Load (e-Manual AX-12A, MX-28 §2.4.20-21): bits 0..9 the
// magnitude, bit 10 the direction, 1 = CW (negative here).
double signed_direction(uint16_t raw) { return (raw & 0x400) != 0 ? -static_cast<double>(raw & 0x3FF) : raw & 0x3FF; }

levels::Vector3 vector3(double x, double y, double z) {
  levels::Vector3 v;
  v.set_x(x);
  v.set_y(y);
  v.set_z(z);
  return v;
}

void decode_p1_servo(const LevelsDevice& d, const DeviceTable& t, levels::ServoDecoded& out) {
  namespace p1 = dynamixel::p1;
  const dynamixel::ServoSpec& s = d.servo;
  const uint16_t position = u16(t, p1::kPresentPosition);
  // e-Manual MX-28 (Protocol 1.0) §2.4.5/2.4.19: both angle limits 4095 is multi-turn mode; then
  // Present Position is signed, -28672..28672, counted in units of Resolution Divider (22) after
  // Multi Turn Offset (20) is added. Otherwise 0..4095 (MX, 0.088 deg) or 0..1023 (AX/RX, 0.29 deg)
  // with the centre of the range (2048 / 512) at 0 rad.
  const bool multi_turn = s.family == dynamixel::ServoFamily::kMx && u16(t, p1::kCwAngleLimit) == 4095 &&
                          u16(t, p1::kCcwAngleLimit) == 4095;
  double counts = position;
  if (multi_turn) {
    const double divider = std::max<uint8_t>(1, t.bytes[p1::kResolutionDivider]);
    counts = (static_cast<int16_t>(position) - i16(t, p1::kMultiTurnOffset)) * divider;
    out.set_present_position_raw(static_cast<int16_t>(position));
  } else {
    out.set_present_position_raw(position);
  }
  out.set_present_position_rad((counts - s.position_center_raw) / s.units_per_rad());
  const uint16_t speed = u16(t, p1::kPresentSpeed);
  out.set_present_speed_raw(speed);
  out.set_present_speed_rad_s(signed_direction(speed) * s.speed_unit_rpm * kRpmToRadS);
  // Present Load: 0..1023 is 0..100 % of the maximum torque (e-Manual: "the unit is about 0.1 %").
  const uint16_t load = u16(t, p1::kPresentLoad);
  out.set_present_load_raw(load);
  out.set_present_load_ratio(signed_direction(load) / 1023.0);
  // Present Voltage: 0.1 V; Present Temperature: 1 deg C.
  out.set_present_voltage_raw(t.bytes[p1::kPresentVoltage]);
  out.set_present_voltage_v(t.bytes[p1::kPresentVoltage] * 0.1);
  out.set_present_temperature_raw(t.bytes[p1::kPresentTemperature]);
  out.set_present_temperature_c(t.bytes[p1::kPresentTemperature]);
  if (d.current_unit_a > 0.0) {
    // e-Manual MX-64 §2.4.27: I = 4.5 mA x (Current - 2048), + = CCW.
    out.set_present_current_a((static_cast<int>(u16(t, p1::kCurrent)) - 2048) * d.current_unit_a);
  }
}

void decode_p2_servo(const LevelsDevice& d, const DeviceTable& t, levels::ServoDecoded& out) {
  namespace x = dynamixel::x430;
  // e-Manual XM430-W350 §2.4.4/2.4.5: Drive Mode bit 0 reverses position, velocity and current;
  // Present Position = actual position + Homing Offset, 4096 pulses per turn, 2048 at the centre.
  const double dir = (t.bytes[x::kDriveMode] & x::kDriveReverse) != 0 ? -1.0 : 1.0;
  const int32_t position = i32(t, x::kPresentPosition);
  out.set_present_position_raw(position);
  const double counts = static_cast<double>(position) - i32(t, x::kHomingOffset) - d.servo.position_center_raw;
  out.set_present_position_rad(dir * counts / d.servo.units_per_rad());
  // Present Velocity: 0.229 rpm (speed_unit_rpm of the registry), signed.
  const int32_t velocity = i32(t, x::kPresentVelocity);
  out.set_present_speed_raw(velocity);
  out.set_present_speed_rad_s(dir * velocity * d.servo.speed_unit_rpm * kRpmToRadS);
  const int16_t load = i16(t, x::kPresentLoad);
  out.set_present_load_raw(load);
  if (d.current_unit_a > 0.0) {
    out.set_present_current_a(dir * load * d.current_unit_a);  // Present Current, e.g. 2.69 mA (XM430)
  } else {
    out.set_present_load_ratio(dir * load / 1000.0);  // Present Load (XL430): 0.1 %, -1000..1000
  }
  // Present Input Voltage: 0.1 V; Present Temperature: 1 deg C.
  out.set_present_voltage_raw(u16(t, x::kPresentInputVoltage));
  out.set_present_voltage_v(u16(t, x::kPresentInputVoltage) * dynamixel::kX430VoltageUnitV);
  out.set_present_temperature_raw(t.bytes[x::kPresentTemperature]);
  out.set_present_temperature_c(t.bytes[x::kPresentTemperature]);
}

}  // namespace

LevelsDevice levels_device(uint32_t bus, uint8_t id, const std::string& name, const std::string& model,
                           dynamixel::Protocol firmware, const dynamixel::Device& device) {
  LevelsDevice d;
  d.bus = bus;
  d.id = id;
  d.name = name;
  d.model = model;
  if (firmware == dynamixel::Protocol::kV2) {
    const dynamixel::P2ModelSpec& spec = dynamixel::p2_model_spec(model);
    switch (spec.kind) {
      case dynamixel::P2DeviceKind::kServo:
        d.codec = LevelsCodec::kP2Servo;
        d.servo = spec.servo;
        d.current_unit_a = spec.has_current ? spec.current_unit_a : 0.0;
        d.stall_torque_nm = spec.servo.motor != nullptr ? spec.servo.motor->stall_torque_nm : 0.0;
        return d;
      case dynamixel::P2DeviceKind::kBitbotsImu: d.codec = LevelsCodec::kBitbotsImu; return d;
      case dynamixel::P2DeviceKind::kOpenCr: d.codec = LevelsCodec::kOpenCr; return d;
      case dynamixel::P2DeviceKind::kBitFoot: {
        d.codec = LevelsCodec::kBitFoot;
        const auto* foot = dynamic_cast<const dynamixel::BitFoot*>(&device);
        if (foot == nullptr) throw std::invalid_argument("sensor levels: " + model + " " + name + " is not a BitFoot");
        d.foot_calibration = foot->calibration();
        return d;
      }
      case dynamixel::P2DeviceKind::kBitbotsCore: break;
    }
    throw std::invalid_argument("sensor levels: no decoder for " + model + " (" + name + ")");
  }
  const dynamixel::ModelSpec& spec = dynamixel::model_spec(model);
  switch (spec.kind) {
    case dynamixel::DeviceKind::kServo:
      d.codec = LevelsCodec::kP1Servo;
      d.servo = spec.servo;
      d.current_unit_a = dynamixel::find_register(spec.registers, dynamixel::p1::kCurrent) != nullptr ? 0.0045 : 0.0;
      d.stall_torque_nm = spec.servo.motor != nullptr ? spec.servo.motor->stall_torque_nm : 0.0;
      return d;
    case dynamixel::DeviceKind::kImu: d.codec = LevelsCodec::kFumanoidImu; return d;
    case dynamixel::DeviceKind::kFootBoard: d.codec = LevelsCodec::kFumanoidFoot; return d;
    case dynamixel::DeviceKind::kCm730: d.codec = LevelsCodec::kCm730; return d;
    case dynamixel::DeviceKind::kDarwinFsr: d.codec = LevelsCodec::kDarwinFsr; return d;
  }
  throw std::invalid_argument("sensor levels: no decoder for " + model + " (" + name + ")");
}

std::span<const uint8_t> device_table(const dynamixel::Device& device) {
  if (const auto* p1 = dynamic_cast<const dynamixel::Protocol1Device*>(&device)) return p1->table();
  if (const auto* p2 = dynamic_cast<const dynamixel::Protocol2Device*>(&device)) return p2->table();
  if (const auto* board = dynamic_cast<const dynamixel::BitbotsBoard*>(&device)) return board->table();
  if (const auto* opencr = dynamic_cast<const dynamixel::OpenCr*>(&device)) return opencr->table();
  throw std::invalid_argument("sensor levels: the control table of " + std::string(device.model_name()) +
                              " is not visible");
}

void copy_table(std::span<const uint8_t> table, bool powered, DeviceTable& out) noexcept {
  const std::size_t n = std::min(table.size(), out.bytes.size());
  std::memcpy(out.bytes.data(), table.data(), n);
  out.powered = powered;
}

void decode_servo(const LevelsDevice& device, const DeviceTable& table, levels::ServoDecoded& out) {
  if (device.codec == LevelsCodec::kP2Servo) {
    decode_p2_servo(device, table, out);
  } else {
    decode_p1_servo(device, table, out);
  }
}

void decode_imu(const LevelsDevice& device, const DeviceTable& t, levels::ImuDecoded& out) {
  switch (device.codec) {
    case LevelsCodec::kCm730: {
      // The CM-730's scales (dynamixel::Cm730): gyro and accelerometer are 10-bit, 512 at zero,
      // spanning -1600..1600 deg/s and -4..4 g. The gyro's axes are the accelerometer's turned 90 deg
      // about z (docs/devices.md, CM-730 axes): in the accelerometer's frame S, w = (Y, -X, Z).
      namespace c = dynamixel::cm730;
      const double deg_s = dynamixel::Cm730::kGyroDegSPerCount, g = dynamixel::Cm730::kAccelGPerCount;
      const double gx = (u16(t, c::kGyroX) - 512.0) * deg_s * kDegToRad;
      const double gy = (u16(t, c::kGyroY) - 512.0) * deg_s * kDegToRad;
      const double gz = (u16(t, c::kGyroZ) - 512.0) * deg_s * kDegToRad;
      *out.mutable_gyro_rad_s() = vector3(gy, -gx, gz);
      *out.mutable_accel_m_s2() = vector3((u16(t, c::kAccelX) - 512.0) * g * kStandardGravityMS2,
                                          (u16(t, c::kAccelY) - 512.0) * g * kStandardGravityMS2,
                                          (u16(t, c::kAccelZ) - 512.0) * g * kStandardGravityMS2);
      for (uint8_t a : {c::kGyroX, c::kGyroY, c::kGyroZ, c::kAccelX, c::kAccelY, c::kAccelZ}) out.add_raw(u16(t, a));
      out.set_has_orientation(false);
      return;
    }
    case LevelsCodec::kFumanoidImu: {
      // docs/devices.md, FUmanoid IMU: int16 angles in 0.1 mrad, gyro in 1 mrad/s, accelerometer in
      // 0.01 m/s^2.
      namespace f = dynamixel::fumanoid;
      out.set_has_orientation(true);
      out.set_pitch_rad(i16(t, f::kPitch) * 1e-4);
      out.set_roll_rad(i16(t, f::kRoll) * 1e-4);
      out.set_yaw_rad(i16(t, f::kYaw) * 1e-4);
      *out.mutable_gyro_rad_s() = vector3(i16(t, f::kGyroX) * 1e-3, i16(t, f::kGyroY) * 1e-3, i16(t, f::kGyroZ) * 1e-3);
      *out.mutable_accel_m_s2() =
          vector3(i16(t, f::kAccelX) * 1e-2, i16(t, f::kAccelY) * 1e-2, i16(t, f::kAccelZ) * 1e-2);
      for (uint8_t a : {f::kPitch, f::kRoll, f::kYaw, f::kGyroX, f::kGyroY, f::kGyroZ, f::kAccelX, f::kAccelY, f::kAccelZ}) {
        out.add_raw(i16(t, a));
      }
      return;
    }
    case LevelsCodec::kBitbotsImu: {
      // Reference §8.2 (bit-bots/bitbots_main, bitbots_ros_control imu): float32 rad/s, m/s^2 and
      // the orientation quaternion x, y, z, w; roll/pitch/yaw are its ZYX angles.
      namespace b = dynamixel::bitbots;
      *out.mutable_gyro_rad_s() = vector3(f32(t, b::kGyroX), f32(t, b::kGyroY), f32(t, b::kGyroZ));
      *out.mutable_accel_m_s2() = vector3(f32(t, b::kAccelX), f32(t, b::kAccelY), f32(t, b::kAccelZ));
      const double x = f32(t, b::kQuaternionX), y = f32(t, b::kQuaternionY), z = f32(t, b::kQuaternionZ),
                   w = f32(t, b::kQuaternionW);
      out.set_has_orientation(true);
      out.set_roll_rad(std::atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y)));
      out.set_pitch_rad(std::asin(std::clamp(2.0 * (w * y - z * x), -1.0, 1.0)));
      out.set_yaw_rad(std::atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z)));
      for (uint16_t a = b::kGyroX; a <= b::kQuaternionW; a = static_cast<uint16_t>(a + 4)) out.add_raw(i32(t, a));
      return;
    }
    case LevelsCodec::kOpenCr: {
      // ROBOTIS OP3 firmware (OpenCR opencr_op3) and open_cr_module: MPU-9250 gyro at 2000 deg/s
      // full scale (32800 / 2000 counts per deg/s), accelerometer at 2 g (16384 counts per g),
      // roll/pitch/yaw in 0.1 deg.
      namespace o = dynamixel::opencr;
      const double per_deg_s = 32800.0 / 2000.0, per_g = 32768.0 / 2.0;
      *out.mutable_gyro_rad_s() = vector3(i16(t, o::kGyroX) / per_deg_s * kDegToRad, i16(t, o::kGyroY) / per_deg_s * kDegToRad,
                                          i16(t, o::kGyroZ) / per_deg_s * kDegToRad);
      *out.mutable_accel_m_s2() = vector3(i16(t, o::kAccX) / per_g * kStandardGravityMS2,
                                          i16(t, o::kAccY) / per_g * kStandardGravityMS2,
                                          i16(t, o::kAccZ) / per_g * kStandardGravityMS2);
      out.set_has_orientation(true);
      out.set_roll_rad(i16(t, o::kRoll) * 0.1 * kDegToRad);
      out.set_pitch_rad(i16(t, o::kPitch) * 0.1 * kDegToRad);
      out.set_yaw_rad(i16(t, o::kYaw) * 0.1 * kDegToRad);
      for (uint16_t a = o::kGyroX; a <= o::kYaw; a = static_cast<uint16_t>(a + 2)) out.add_raw(i16(t, a));
      return;
    }
    default:
      return;
  }
}

void decode_foot(const LevelsDevice& device, const DeviceTable& t, std::array<double, 4>& force_n,
                 std::array<int64_t, 4>& raw) {
  for (std::size_t i = 0; i < 4; ++i) {
    switch (device.codec) {
      case LevelsCodec::kDarwinFsr:  // e-Manual (platform/op/references, FSR): FSR1..4 in 1/1000 N
        raw[i] = u16(t, dynamixel::darwin_fsr::kFsr1 + 2 * i);
        force_n[i] = static_cast<double>(raw[i]) * 0.001;
        break;
      case LevelsCodec::kFumanoidFoot:  // docs/devices.md, FUmanoid foot board: 0.01 N
        raw[i] = u16(t, dynamixel::fumanoid::kForceFrontLeft + 2 * i);
        force_n[i] = static_cast<double>(raw[i]) * 0.01;
        break;
      case LevelsCodec::kBitFoot: {
        // The driver's pressure_converter (reference §8.3): F = (raw - zero) x scale, raw as int32
        // counts or float32 depending on the firmware.
        const dynamixel::BitFootCalibration& c = device.foot_calibration;
        const double counts = c.float32 ? static_cast<double>(f32(t, dynamixel::bitbots::kSensor0 + 4 * i))
                                        : static_cast<double>(i32(t, dynamixel::bitbots::kSensor0 + 4 * i));
        raw[i] = static_cast<int64_t>(std::llround(counts));
        force_n[i] = (counts - c.zero_counts) * c.newton_per_count;
        break;
      }
      default:
        force_n[i] = 0.0;
        raw[i] = 0;
    }
  }
}

void append_bus_levels(const BusLevelsLayout& layout, const BusLevelsSample& sample, levels::SensorLevels& out) {
  out.set_sim_time_ns(std::max(out.sim_time_ns(), sample.sim_time_ns));
  for (std::size_t i = 0; i < layout.servos.size() && i < kLevelsMaxServos; ++i) {
    const LevelsDevice& d = layout.servos[i];
    levels::ServoLevels* s = out.add_servos();
    s->set_bus(d.bus);
    s->set_id(d.id);
    s->set_name(d.name);
    s->set_model(d.model);
    s->set_powered(sample.servo_tables[i].powered);
    s->set_sim_time_ns(sample.sim_time_ns);
    decode_servo(d, sample.servo_tables[i], *s->mutable_decoded());
    const dynamixel::ServoFeedback& truth = sample.servo_truth[i];
    levels::ServoTruth* t = s->mutable_truth();
    t->set_angle_rad(truth.position_rad);
    t->set_velocity_rad_s(truth.velocity_rad_s);
    t->set_torque_nm(truth.torque_nm);
    t->set_load_ratio(truth.torque_ratio);
    t->set_current_a(truth.current_a);
    t->set_temperature_c(truth.temperature_c);
    t->set_voltage_v(truth.voltage_v);
  }
  for (std::size_t i = 0; i < layout.imus.size() && i < kLevelsMaxBoards; ++i) {
    const LevelsDevice& d = layout.imus[i];
    levels::ImuLevels* m = out.add_imus();
    m->set_bus(d.bus);
    m->set_id(d.id);
    m->set_name(d.name);
    m->set_model(d.model);
    m->set_sim_time_ns(sample.sim_time_ns);
    decode_imu(d, sample.imu_tables[i], *m->mutable_decoded());
    const dynamixel::ImuFeedback& truth = sample.imu_truth[i];
    levels::ImuTruth* t = m->mutable_truth();
    t->set_roll_rad(truth.roll_rad);
    t->set_pitch_rad(truth.pitch_rad);
    t->set_yaw_rad(truth.yaw_rad);
    *t->mutable_angular_velocity_rad_s() = vector3(truth.w_WS_S_rad_s[0], truth.w_WS_S_rad_s[1], truth.w_WS_S_rad_s[2]);
    *t->mutable_specific_force_m_s2() = vector3(truth.a_WS_S_m_s2[0], truth.a_WS_S_m_s2[1], truth.a_WS_S_m_s2[2]);
  }
  for (std::size_t i = 0; i < layout.feet.size() && i < kLevelsMaxBoards; ++i) {
    const LevelsDevice& d = layout.feet[i];
    levels::FootLevels* f = out.add_feet();
    f->set_bus(d.bus);
    f->set_id(d.id);
    f->set_name(d.name);
    f->set_model(d.model);
    f->set_sim_time_ns(sample.sim_time_ns);
    std::array<double, 4> force{};
    std::array<int64_t, 4> raw{};
    decode_foot(d, sample.foot_tables[i], force, raw);
    for (std::size_t c = 0; c < 4; ++c) {
      f->add_decoded_force_n(force[c]);
      f->add_true_force_n(sample.foot_truth[i].force_n[c]);
      f->add_raw(raw[c]);
    }
  }
}

}  // namespace doppel::body
