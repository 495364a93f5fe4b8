#include "dynamixel/models.h"

#include <array>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "model_tables.h"

namespace doppel::dynamixel {

namespace {

using A = Access;
constexpr Area kE = Area::kEeprom;
constexpr Area kR = Area::kRam;
constexpr A kRO = A::kRead;
constexpr A kRW = A::kReadWrite;

// Factory defaults that differ between AX-12A, RX-28 and RX-64 (reference §3.4, e-Manual column).
struct AxRxDefaults {
  uint16_t model_number;
  uint8_t firmware_version;
  uint8_t baud_raw;
  uint8_t temperature_limit;
  uint8_t max_voltage_limit;
};

constexpr std::array<RegisterSpec, 35> axrx_table(AxRxDefaults d) {
  return {{
      {"Model Number", 0, 2, kRO, kE, d.model_number, 0, 0xFFFF},
      {"Firmware Version", 2, 1, kRO, kE, d.firmware_version, 0, 255},
      {"ID", 3, 1, kRW, kE, 1, 0, 253},
      {"Baud Rate", 4, 1, kRW, kE, d.baud_raw, 0, 254},
      {"Return Delay Time", 5, 1, kRW, kE, 250, 0, 254},
      {"CW Angle Limit", 6, 2, kRW, kE, 0, 0, 1023},
      {"CCW Angle Limit", 8, 2, kRW, kE, 1023, 0, 1023},
      {"Temperature Limit", 11, 1, kRW, kE, d.temperature_limit, 0, 150},
      {"Min Voltage Limit", 12, 1, kRW, kE, 60, 50, 250},
      {"Max Voltage Limit", 13, 1, kRW, kE, d.max_voltage_limit, 50, 250},
      {"Max Torque", 14, 2, kRW, kE, 1023, 0, 1023},
      {"Status Return Level", 16, 1, kRW, kE, 2, 0, 2},
      {"Alarm LED", 17, 1, kRW, kE, 36, 0, 127},
      {"Alarm Shutdown", 18, 1, kRW, kE, 36, 0, 127},
      {"Reserved", 19, 1, kRW, kE, 0, 0, 1},
      {"Down Calibration", 20, 2, kRO, kE, 0, 0, 0xFFFF},
      {"Up Calibration", 22, 2, kRO, kE, 0, 0, 0xFFFF},
      {"Torque Enable", 24, 1, kRW, kR, 0, 0, 1},
      {"LED", 25, 1, kRW, kR, 0, 0, 1},
      {"CW Compliance Margin", 26, 1, kRW, kR, 1, 0, 254},
      {"CCW Compliance Margin", 27, 1, kRW, kR, 1, 0, 254},
      {"CW Compliance Slope", 28, 1, kRW, kR, 32, 1, 254},
      {"CCW Compliance Slope", 29, 1, kRW, kR, 32, 1, 254},
      {"Goal Position", 30, 2, kRW, kR, 512, 0, 1023},
      {"Moving Speed", 32, 2, kRW, kR, 0, 0, 2047},
      {"Torque Limit", 34, 2, kRW, kR, 1023, 0, 1023},
      {"Present Position", 36, 2, kRO, kR, 512, 0, 1023},
      {"Present Speed", 38, 2, kRO, kR, 0, 0, 2047},
      {"Present Load", 40, 2, kRO, kR, 0, 0, 2047},
      {"Present Voltage", 42, 1, kRO, kR, 0, 0, 255},
      {"Present Temperature", 43, 1, kRO, kR, 0, 0, 255},
      {"Registered", 44, 1, kRO, kR, 0, 0, 1},
      {"Moving", 46, 1, kRO, kR, 0, 0, 1},
      {"Lock", 47, 1, kRW, kR, 0, 0, 1},
      {"Punch", 48, 2, kRW, kR, 32, 32, 1023},
  }};
}

constexpr auto kAx12aTable = axrx_table({12, 24, 1, 70, 140});
constexpr auto kRx28Table = axrx_table({28, 8, 34, 80, 190});
constexpr auto kRx64Table = axrx_table({64, 8, 34, 80, 190});

// MX-28/64/106 with Protocol 1.0 firmware (reference §3.5). `current_items`: MX-64/106 have
// Current, Torque Ctrl Mode Enable and Goal Torque; `drive_mode`: MX-106 only.
struct MxDefaults {
  uint16_t model_number;
  uint8_t max_voltage_limit;
};

constexpr RegisterSpec kMxDriveMode{"Drive Mode", 10, 1, kRW, kE, 0, 0, 3};
constexpr std::array<RegisterSpec, 3> kMxCurrentItems{{
    {"Current", 68, 2, kRW, kR, 0, 0, 4095},
    {"Torque Ctrl Mode Enable", 70, 1, kRW, kR, 0, 0, 1},
    {"Goal Torque", 71, 2, kRW, kR, 0, 0, 2047},
}};
constexpr uint8_t kMxFirmwareVersion = 41;

constexpr std::array<RegisterSpec, 35> mx_common(MxDefaults d) {
  return {{
      {"Model Number", 0, 2, kRO, kE, d.model_number, 0, 0xFFFF},
      {"Firmware Version", 2, 1, kRO, kE, kMxFirmwareVersion, 0, 255},
      {"ID", 3, 1, kRW, kE, 1, 0, 253},
      {"Baud Rate", 4, 1, kRW, kE, 34, 0, 254},
      {"Return Delay Time", 5, 1, kRW, kE, 250, 0, 254},
      {"CW Angle Limit", 6, 2, kRW, kE, 0, 0, 4095},
      {"CCW Angle Limit", 8, 2, kRW, kE, 4095, 0, 4095},
      {"Temperature Limit", 11, 1, kRW, kE, 80, 0, 150},
      {"Min Voltage Limit", 12, 1, kRW, kE, 60, 50, 250},
      {"Max Voltage Limit", 13, 1, kRW, kE, d.max_voltage_limit, 50, 250},
      {"Max Torque", 14, 2, kRW, kE, 1023, 0, 1023},
      {"Status Return Level", 16, 1, kRW, kE, 2, 0, 2},
      {"Alarm LED", 17, 1, kRW, kE, 36, 0, 127},
      {"Alarm Shutdown", 18, 1, kRW, kE, 36, 0, 127},
      {"Multi Turn Offset", 20, 2, kRW, kE, 0, -24576, 24576, true},
      {"Resolution Divider", 22, 1, kRW, kE, 1, 1, 4},
      {"Torque Enable", 24, 1, kRW, kR, 0, 0, 1},
      {"LED", 25, 1, kRW, kR, 0, 0, 1},
      {"D Gain", 26, 1, kRW, kR, 0, 0, 254},
      {"I Gain", 27, 1, kRW, kR, 0, 0, 254},
      {"P Gain", 28, 1, kRW, kR, 32, 0, 254},
      // Signed so that multi-turn goals fit; Protocol1Servo narrows it to 0..4095 outside multi-turn.
      {"Goal Position", 30, 2, kRW, kR, 2048, -28672, 28672, true},
      {"Moving Speed", 32, 2, kRW, kR, 0, 0, 2047},
      {"Torque Limit", 34, 2, kRW, kR, 1023, 0, 1023},
      {"Present Position", 36, 2, kRO, kR, 2048, -32768, 32767, true},
      {"Present Speed", 38, 2, kRO, kR, 0, 0, 2047},
      {"Present Load", 40, 2, kRO, kR, 0, 0, 2047},
      {"Present Voltage", 42, 1, kRO, kR, 0, 0, 255},
      {"Present Temperature", 43, 1, kRO, kR, 0, 0, 255},
      {"Registered", 44, 1, kRO, kR, 0, 0, 1},
      {"Moving", 46, 1, kRO, kR, 0, 0, 1},
      {"Lock", 47, 1, kRW, kR, 0, 0, 1},
      {"Punch", 48, 2, kRW, kR, 0, 0, 1023},
      {"Realtime Tick", 50, 2, kRO, kR, 0, 0, 32767},
      {"Goal Acceleration", 73, 1, kRW, kR, 0, 0, 254},
  }};
}

// Inserts `extra` (ascending) into `base` (ascending) keeping address order.
template <std::size_t N, std::size_t M>
constexpr std::array<RegisterSpec, N + M> merged(const std::array<RegisterSpec, N>& base,
                                                 const std::array<RegisterSpec, M>& extra) {
  std::array<RegisterSpec, N + M> out{};
  std::size_t i = 0;
  std::size_t j = 0;
  for (std::size_t k = 0; k < N + M; ++k) {
    if (j == M || (i < N && base[i].address < extra[j].address)) {
      out[k] = base[i++];
    } else {
      out[k] = extra[j++];
    }
  }
  return out;
}

constexpr auto kMx28Table = mx_common({29, 160});
// MX-64 Max Voltage Limit: the e-Manual prints 240 (its siblings 160); reference §6 flags it. Kept as printed.
constexpr auto kMx64Table = merged(mx_common({310, 240}), kMxCurrentItems);
constexpr auto kMx106Table =
    merged(merged(mx_common({320, 160}), kMxCurrentItems), std::array<RegisterSpec, 1>{kMxDriveMode});

// Doppel's FUmanoid boards: a servo-like header, then the latched sensor values (docs/devices.md).
constexpr std::array<RegisterSpec, 11> board_header(uint16_t model_number, uint8_t default_id,
                                                    uint8_t sample_period_ms) {
  return {{
      {"Model Number", fumanoid::kModelNumber, 2, kRO, kE, model_number, 0, 0xFFFF},
      {"Firmware Version", fumanoid::kFirmwareVersion, 1, kRO, kE, 1, 0, 255},
      {"ID", fumanoid::kId, 1, kRW, kE, default_id, 0, 253},
      {"Baud Rate", fumanoid::kBaudRate, 1, kRW, kE, 1, 0, 254},
      {"Return Delay Time", fumanoid::kReturnDelayTime, 1, kRW, kE, 250, 0, 254},
      {"Sample Period", fumanoid::kSamplePeriod, 1, kRW, kE, sample_period_ms, 1, 255},
      {"Status Return Level", fumanoid::kStatusReturnLevel, 1, kRW, kE, 2, 0, 2},
      {"LED", fumanoid::kLed, 1, kRW, kR, 0, 0, 1},
      {"Registered", fumanoid::kRegistered, 1, kRO, kR, 0, 0, 1},
      {"Lock", fumanoid::kLock, 1, kRW, kR, 0, 0, 1},
      {"Sample Counter", fumanoid::kSampleCounter, 2, kRO, kR, 0, 0, 0xFFFF},
  }};
}

constexpr std::array<RegisterSpec, 9> kImuValues{{
    {"Pitch", fumanoid::kPitch, 2, kRO, kR, 0, -32768, 32767, true},
    {"Roll", fumanoid::kRoll, 2, kRO, kR, 0, -32768, 32767, true},
    {"Yaw", fumanoid::kYaw, 2, kRO, kR, 0, -32768, 32767, true},
    {"Gyro X", fumanoid::kGyroX, 2, kRO, kR, 0, -32768, 32767, true},
    {"Gyro Y", fumanoid::kGyroY, 2, kRO, kR, 0, -32768, 32767, true},
    {"Gyro Z", fumanoid::kGyroZ, 2, kRO, kR, 0, -32768, 32767, true},
    {"Accel X", fumanoid::kAccelX, 2, kRO, kR, 0, -32768, 32767, true},
    {"Accel Y", fumanoid::kAccelY, 2, kRO, kR, 0, -32768, 32767, true},
    {"Accel Z", fumanoid::kAccelZ, 2, kRO, kR, 0, -32768, 32767, true},
}};
constexpr std::array<RegisterSpec, 5> kFootValues{{
    {"Force Front Left", fumanoid::kForceFrontLeft, 2, kRO, kR, 0, 0, 0xFFFF},
    {"Force Front Right", fumanoid::kForceFrontRight, 2, kRO, kR, 0, 0, 0xFFFF},
    {"Force Back Left", fumanoid::kForceBackLeft, 2, kRO, kR, 0, 0, 0xFFFF},
    {"Force Back Right", fumanoid::kForceBackRight, 2, kRO, kR, 0, 0, 0xFFFF},
    {"Force Total", fumanoid::kForceTotal, 2, kRO, kR, 0, 0, 0xFFFF},
}};
constexpr auto kImuTable = merged(board_header(kFumanoidImuModelNumber, 100, 20), kImuValues);
constexpr auto kFootTable = merged(board_header(kFumanoidFootModelNumber, 101, 10), kFootValues);

constexpr double deg_to_rad(double deg) { return deg * std::numbers::pi / 180.0; }

// A Protocol 1.0 servo of `family` with the DC-motor constants of its datasheet point at `volts`
// (detail::with_datasheet_motor).
constexpr ServoSpec derived_servo(ServoFamily family, double volts, double no_load_rpm, double stall_n_m,
                                  double stall_a, double gear, double mass_kg) {
  ServoSpec s;
  s.family = family;
  const bool mx = family == ServoFamily::kMx;
  s.position_max_raw = mx ? 4095 : 1023;
  s.position_center_raw = mx ? 2048 : 512;
  s.position_span_rad = deg_to_rad(mx ? 360.0 : 300.0);
  s.speed_unit_rpm = mx ? 0.114 : 0.111;
  return detail::with_datasheet_motor(s, volts, no_load_rpm, stall_n_m, stall_a, gear, mass_kg);
}

// RX-28 and RX-64 take ke and kt from thesis Table 7. Its resistances (0.8 and 0.75 ohm) are a
// decimal slip: its own derivation (15 V / 2 A) gives 7.5 ohm, and only R ~ 8 / 7.5 ohm reproduces
// the stall torque (kt * V / R) the datasheet gives; 0.75 ohm would give ten times that.
constexpr ServoSpec thesis_servo(ServoSpec s, double ke, double r, double kt) {
  s.ke_v_s_per_rad = ke;
  s.resistance_ohm = r;
  s.kt_n_m_per_a = kt;
  return s;
}

// Masses: RX from reference §5; AX-12A and MX (T versions) from the e-Manual product pages.
const ModelSpec kAx12a{"AX-12A", 12, 24, DeviceKind::kServo, kAx12aTable, 50, false, false,
                       derived_servo(ServoFamily::kAxRx, 12.0, 59.0, 1.5, 1.5, 254.0, 0.0546)};
const ModelSpec kRx28{"RX-28", 28, 8, DeviceKind::kServo, kRx28Table, 50, false, false,
                      thesis_servo(derived_servo(ServoFamily::kAxRx, 18.5, 85.0, 3.7, 1.9, 193.0, 0.072),
                                   2.02, 8.0, 1.9)};
const ModelSpec kRx64{"RX-64", 64, 8, DeviceKind::kServo, kRx64Table, 50, false, false,
                      thesis_servo(derived_servo(ServoFamily::kAxRx, 18.5, 64.0, 5.3, 2.6, 200.0, 0.125),
                                   2.82, 7.5, 3.2)};
const ModelSpec kMx28{"MX-28", 29, kMxFirmwareVersion, DeviceKind::kServo, kMx28Table, 74, true, true,
                      derived_servo(ServoFamily::kMx, 12.0, 55.0, 2.5, 1.4, 193.0, 0.072)};
const ModelSpec kMx64{"MX-64", 310, kMxFirmwareVersion, DeviceKind::kServo, kMx64Table, 74, true, true,
                      derived_servo(ServoFamily::kMx, 12.0, 63.0, 6.0, 4.1, 200.0, 0.126)};
const ModelSpec kMx106{"MX-106", 320, kMxFirmwareVersion, DeviceKind::kServo, kMx106Table, 74, true, true,
                       derived_servo(ServoFamily::kMx, 12.0, 45.0, 8.4, 5.2, 225.0, 0.153)};
const ModelSpec kFumanoidImu{"FUMANOID-IMU", kFumanoidImuModelNumber, 1, DeviceKind::kImu, kImuTable, 50, true,
                             false, {}};
const ModelSpec kFumanoidFoot{"FUMANOID-FOOT", kFumanoidFootModelNumber, 1, DeviceKind::kFootBoard, kFootTable, 50,
                              true, false, {}};

const std::array<const ModelSpec*, 8> kModels{&kAx12a, &kRx28, &kRx64, &kMx28, &kMx64, &kMx106, &kFumanoidImu,
                                              &kFumanoidFoot};

}  // namespace

const RegisterSpec* find_register(std::span<const RegisterSpec> registers, uint8_t address) noexcept {
  return detail::register_containing(registers, address);
}

const ModelSpec& model_spec(std::string_view name) {
  for (const ModelSpec* m : kModels) {
    if (m->name == name) {
      return *m;
    }
  }
  throw std::invalid_argument("unknown Dynamixel model \"" + std::string(name) +
                              "\"; known models: " + detail::model_names(known_models()));
}

std::span<const ModelSpec* const> known_models() noexcept { return kModels; }

uint32_t p1_baud_bps(uint8_t raw, bool mx_codes) noexcept {
  if (mx_codes) {
    switch (raw) {
      case 250:
        return 2250000;
      case 251:
        return 2500000;
      case 252:
        return 3000000;
      default:
        break;
    }
  }
  return 2000000u / (raw + 1u);
}

uint8_t p1_baud_register(uint32_t bps, const ModelSpec& model) {
  int best = -1;
  double best_error = 0.0;
  // Value 0 (2 Mbps) is listed for the MX series only (reference §3.2); AX/RX top out at 1 Mbps.
  for (int raw = model.mx_baud_codes ? 0 : 1; raw <= 254; ++raw) {
    const double rate = p1_baud_bps(static_cast<uint8_t>(raw), model.mx_baud_codes);
    const double error = std::abs(rate - bps) / static_cast<double>(bps == 0 ? 1 : bps);
    if (best < 0 || error < best_error) {
      best = raw;
      best_error = error;
    }
  }
  if (bps == 0 || best_error > 0.03) {
    throw std::invalid_argument(std::string(model.name) + " cannot run at " + std::to_string(bps) +
                                " bps: no Baud Rate register value within 3 %");
  }
  return static_cast<uint8_t>(best);
}

}  // namespace doppel::dynamixel
