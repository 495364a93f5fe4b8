#include "dynamixel/model_registry.h"

#include <array>
#include <numbers>
#include <stdexcept>
#include <string>

#include "model_tables.h"

namespace doppel::dynamixel {

namespace {

// Control tables of the Protocol 1.0 firmware.

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

constexpr std::array<RegisterSpec, 36> mx_common(MxDefaults d) {
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
      // Undocumented byte that takes any write: ROBOTIS' DARwIn-OP framework SYNC WRITEs 26..31
      // (D, I, P Gain, 0 here, Goal Position) to its MX-28s every 8 ms (docs/devices.md 3.7).
      {"Reserved", 29, 1, kRW, kR, 0, 0, 255},
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

// DARwIn-OP CM-730 (firmware 19 = 0x13, the image cm730_0x13.hex the framework ships): the
// framework's CM730.h gives the addresses, the e-Manual's CM-730 table (platform/op/references)
// the access and initial values; ranges of writable registers are Doppel's (docs/devices.md).
constexpr uint16_t kCm730ModelNumber = 0x7300;  // e-Manual: Model Number(L) 0, (H) 0x73
constexpr std::array<RegisterSpec, 30> kCm730Table{{
    {"Model Number", cm730::kModelNumber, 2, kRO, kE, kCm730ModelNumber, 0, 0xFFFF},
    {"Firmware Version", cm730::kFirmwareVersion, 1, kRO, kE, 0x13, 0, 255},
    {"ID", cm730::kId, 1, kRW, kE, 200, 0, 253},
    {"Baud Rate", cm730::kBaudRate, 1, kRW, kE, 1, 0, 254},
    {"Return Delay Time", cm730::kReturnDelayTime, 1, kRW, kE, 0, 0, 254},
    {"Status Return Level", cm730::kStatusReturnLevel, 1, kRW, kE, 2, 0, 2},
    {"Dynamixel Power", cm730::kDxlPower, 1, kRW, kR, 0, 0, 1},
    {"LED Panel", cm730::kLedPanel, 1, kRW, kR, 0, 0, 7},
    {"LED 5 (Head)", cm730::kLedHead, 2, kRW, kR, 0, 0, 0x7FFF},
    {"LED 6 (Eye)", cm730::kLedEye, 2, kRW, kR, 0, 0, 0x7FFF},
    {"Button", cm730::kButton, 1, kRO, kR, 0, 0, 3},
    {"Gyro Z", cm730::kGyroZ, 2, kRO, kR, 512, 0, 1023},
    {"Gyro Y", cm730::kGyroY, 2, kRO, kR, 512, 0, 1023},
    {"Gyro X", cm730::kGyroX, 2, kRO, kR, 512, 0, 1023},
    {"ACC X", cm730::kAccelX, 2, kRO, kR, 512, 0, 1023},
    {"ACC Y", cm730::kAccelY, 2, kRO, kR, 512, 0, 1023},
    {"ACC Z", cm730::kAccelZ, 2, kRO, kR, 512, 0, 1023},
    {"Present Voltage", cm730::kVoltage, 1, kRO, kR, 0, 0, 255},
    {"MIC 1", cm730::kLeftMic, 2, kRO, kR, 0, 0, 1023},
    {"ADC 2", 53, 2, kRO, kR, 0, 0, 1023},
    {"ADC 3", 55, 2, kRO, kR, 0, 0, 1023},
    {"ADC 4", 57, 2, kRO, kR, 0, 0, 1023},
    {"ADC 5", 59, 2, kRO, kR, 0, 0, 1023},
    {"ADC 6", 61, 2, kRO, kR, 0, 0, 1023},
    {"ADC 7", 63, 2, kRO, kR, 0, 0, 1023},
    {"ADC 8", 65, 2, kRO, kR, 0, 0, 1023},
    {"MIC 2", cm730::kRightMic, 2, kRO, kR, 0, 0, 1023},
    {"ADC 10", 69, 2, kRO, kR, 0, 0, 1023},
    {"ADC 11", 71, 2, kRO, kR, 0, 0, 1023},
    {"ADC 12", 73, 2, kRO, kR, 0, 0, 1023},
}};
constexpr std::array<RegisterSpec, 3> kCm730LastAdcs{{
    {"ADC 13", 75, 2, kRO, kR, 0, 0, 1023},
    {"ADC 14", 77, 2, kRO, kR, 0, 0, 1023},
    {"ADC 15", 79, 2, kRO, kR, 0, 0, 1023},
}};
constexpr auto kCm730FullTable = merged(kCm730Table, kCm730LastAdcs);

// DARwIn-OP FSR foot board (firmware 17 = 0x11): FSR.h addresses, e-Manual FSR table.
constexpr uint16_t kDarwinFsrModelNumber = 0x0154;  // e-Manual: Model Number(L) 0x54, (H) 0x01
constexpr std::array<RegisterSpec, 17> kDarwinFsrTable{{
    {"Model Number", darwin_fsr::kModelNumber, 2, kRO, kE, kDarwinFsrModelNumber, 0, 0xFFFF},
    {"Firmware Version", darwin_fsr::kFirmwareVersion, 1, kRO, kE, 0x11, 0, 255},
    {"ID", darwin_fsr::kId, 1, kRW, kE, 100, 0, 253},
    {"Baud Rate", darwin_fsr::kBaudRate, 1, kRW, kE, 34, 0, 254},
    {"Return Delay Time", darwin_fsr::kReturnDelayTime, 1, kRW, kE, 250, 0, 254},
    {"Status Return Level", darwin_fsr::kStatusReturnLevel, 1, kRW, kE, 2, 0, 2},
    {"Operating Mode", darwin_fsr::kOperatingMode, 1, kRW, kE, 0, 0, 255},
    {"LED", darwin_fsr::kLed, 1, kRW, kR, 0, 0, 1},
    {"FSR1", darwin_fsr::kFsr1, 2, kRO, kR, 0, 0, 0xFFFF},
    {"FSR2", darwin_fsr::kFsr2, 2, kRO, kR, 0, 0, 0xFFFF},
    {"FSR3", darwin_fsr::kFsr3, 2, kRO, kR, 0, 0, 0xFFFF},
    {"FSR4", darwin_fsr::kFsr4, 2, kRO, kR, 0, 0, 0xFFFF},
    {"FSR_Central_X", darwin_fsr::kFsrX, 1, kRO, kR, 255, 0, 255},
    {"FSR_Central_Y", darwin_fsr::kFsrY, 1, kRO, kR, 255, 0, 255},
    {"Present Voltage", darwin_fsr::kPresentVoltage, 1, kRO, kR, 0, 0, 255},
    {"Registered", darwin_fsr::kRegistered, 1, kRO, kR, 0, 0, 1},
    {"Lock", darwin_fsr::kLock, 1, kRW, kR, 0, 0, 1},
}};

// Control tables of the Protocol 2.0 firmware.

// Factory values and items that differ between the X-series models (reference §3.7) and the
// MX(2.0) firmware tables (§3.6, "X-series layout with" these differences).
struct XDefaults {
  uint16_t model_number;
  uint8_t firmware_version;
  int32_t current_limit;           // 0: no Current Limit (38) / Goal Current (102); 126 is Present Load
  bool acceleration_limit;         // Acceleration Limit (40)
  bool startup_configuration;      // Startup Configuration (60): X fw >= 45 only
  uint8_t temperature_limit;
  int32_t max_voltage;
  int32_t min_voltage;
  int32_t voltage_floor;        // range of both voltage limits
  int32_t voltage_ceiling;
  int32_t velocity_limit;
  int32_t velocity_i_gain;
  int32_t position_d_gain;
  int32_t position_p_gain;
};

constexpr std::size_t kMaxItems = 192;  // 53 items + 112 indirect items

struct XTable {
  std::array<P2RegisterSpec, kMaxItems> items{};
  std::size_t count = 0;
  constexpr void add(const P2RegisterSpec& r) { items[count++] = r; }
};

constexpr int32_t kGoalPositionLimit = 1048575;  // extended / current-based position modes
constexpr int32_t kHomingLimit = 1044479;

// `external_ports`: External Port Mode 1-3 (56-58) and Data 1-3 (152-156) of the X540 tables.
constexpr XTable x_table(XDefaults d, bool external_ports = false) {
  XTable t;
  t.add({"Model Number", x430::kModelNumber, 2, kRO, kE, d.model_number, 0, 0xFFFF});
  t.add({"Model Information", x430::kModelInformation, 4, kRO, kE, 0, 0, 0x7FFFFFFF});
  t.add({"Firmware Version", x430::kFirmwareVersion, 1, kRO, kE, d.firmware_version, 0, 255});
  t.add({"ID", x430::kId, 1, kRW, kE, 1, 0, 252});
  t.add({"Baud Rate", x430::kBaudRate, 1, kRW, kE, 1, 0, 7});
  t.add({"Return Delay Time", x430::kReturnDelayTime, 1, kRW, kE, 250, 0, 254});
  t.add({"Drive Mode", x430::kDriveMode, 1, kRW, kE, 0, 0, 255});  // bits checked per model
  t.add({"Operating Mode", x430::kOperatingMode, 1, kRW, kE, x430::kPositionMode, 0, 16});
  t.add({"Secondary(Shadow) ID", x430::kSecondaryId, 1, kRW, kE, 255, 0, 255});
  t.add({"Protocol Type", x430::kProtocolType, 1, kRW, kE, x430::kProtocolType2, x430::kProtocolType1,
         x430::kProtocolType2});
  t.add({"Homing Offset", x430::kHomingOffset, 4, kRW, kE, 0, -kHomingLimit, kHomingLimit, true});
  t.add({"Moving Threshold", x430::kMovingThreshold, 4, kRW, kE, 10, 0, 1023});
  t.add({"Temperature Limit", x430::kTemperatureLimit, 1, kRW, kE, d.temperature_limit, 0, 100});
  t.add({"Max Voltage Limit", x430::kMaxVoltageLimit, 2, kRW, kE, d.max_voltage, d.voltage_floor, d.voltage_ceiling});
  t.add({"Min Voltage Limit", x430::kMinVoltageLimit, 2, kRW, kE, d.min_voltage, d.voltage_floor, d.voltage_ceiling});
  t.add({"PWM Limit", x430::kPwmLimit, 2, kRW, kE, 885, 0, 885});
  if (d.current_limit != 0) {
    t.add({"Current Limit", x430::kCurrentLimit, 2, kRW, kE, d.current_limit, 0, d.current_limit});
  }
  if (d.acceleration_limit) {
    t.add({"Acceleration Limit", x430::kAccelerationLimit, 4, kRW, kE, 32767, 0, 32767});
  }
  t.add({"Velocity Limit", x430::kVelocityLimit, 4, kRW, kE, d.velocity_limit, 0, 1023});
  t.add({"Max Position Limit", x430::kMaxPositionLimit, 4, kRW, kE, 4095, 0, 4095});
  t.add({"Min Position Limit", x430::kMinPositionLimit, 4, kRW, kE, 0, 0, 4095});
  if (external_ports) {
    for (uint16_t n = 0; n < 3; ++n) {
      t.add({"External Port Mode", static_cast<uint16_t>(56 + n), 1, kRW, kE, 3, 0, 3});
    }
  }
  if (d.startup_configuration) {
    t.add({"Startup Configuration", x430::kStartupConfiguration, 1, kRW, kE, 0, 0, 3});
  }
  t.add({"Shutdown", x430::kShutdown, 1, kRW, kE, 52, 0, 255});
  t.add({"Torque Enable", x430::kTorqueEnable, 1, kRW, kR, 0, 0, 1});
  t.add({"LED", x430::kLed, 1, kRW, kR, 0, 0, 1});
  t.add({"Status Return Level", x430::kStatusReturnLevel, 1, kRW, kR, 2, 0, 2});
  t.add({"Registered Instruction", x430::kRegisteredInstruction, 1, kRO, kR, 0, 0, 1});
  t.add({"Hardware Error Status", x430::kHardwareErrorStatus, 1, kRO, kR, 0, 0, 255});
  t.add({"Velocity I Gain", x430::kVelocityIGain, 2, kRW, kR, d.velocity_i_gain, 0, 16383});
  t.add({"Velocity P Gain", x430::kVelocityPGain, 2, kRW, kR, 100, 0, 16383});
  t.add({"Position D Gain", x430::kPositionDGain, 2, kRW, kR, d.position_d_gain, 0, 16383});
  t.add({"Position I Gain", x430::kPositionIGain, 2, kRW, kR, 0, 0, 16383});
  t.add({"Position P Gain", x430::kPositionPGain, 2, kRW, kR, d.position_p_gain, 0, 16383});
  t.add({"Feedforward 2nd Gain", x430::kFeedforward2ndGain, 2, kRW, kR, 0, 0, 16383});
  t.add({"Feedforward 1st Gain", x430::kFeedforward1stGain, 2, kRW, kR, 0, 0, 16383});
  t.add({"Bus Watchdog", x430::kBusWatchdog, 1, kRW, kR, 0, 0, 127});
  t.add({"Goal PWM", x430::kGoalPwm, 2, kRW, kR, 885, -885, 885, true});
  if (d.current_limit != 0) {
    t.add({"Goal Current", x430::kGoalCurrent, 2, kRW, kR, d.current_limit, -d.current_limit, d.current_limit, true});
  }
  t.add({"Goal Velocity", x430::kGoalVelocity, 4, kRW, kR, 0, -1023, 1023, true});
  t.add({"Profile Acceleration", x430::kProfileAcceleration, 4, kRW, kR, 0, 0, 32767});
  t.add({"Profile Velocity", x430::kProfileVelocity, 4, kRW, kR, 0, 0, 32767});
  t.add({"Goal Position", x430::kGoalPosition, 4, kRW, kR, 2048, -kGoalPositionLimit, kGoalPositionLimit, true});
  t.add({"Realtime Tick", x430::kRealtimeTick, 2, kRO, kR, 0, 0, 32767});
  t.add({"Moving", x430::kMoving, 1, kRO, kR, 0, 0, 1});
  t.add({"Moving Status", x430::kMovingStatus, 1, kRO, kR, 0, 0, 255});
  t.add({"Present PWM", x430::kPresentPwm, 2, kRO, kR, 0, -32768, 32767, true});
  t.add({d.current_limit != 0 ? "Present Current" : "Present Load", x430::kPresentCurrent, 2, kRO, kR, 0, -32768, 32767, true});
  t.add({"Present Velocity", x430::kPresentVelocity, 4, kRO, kR, 0, INT32_MIN, INT32_MAX, true});
  t.add({"Present Position", x430::kPresentPosition, 4, kRO, kR, 2048, INT32_MIN, INT32_MAX, true});
  t.add({"Velocity Trajectory", x430::kVelocityTrajectory, 4, kRO, kR, 0, INT32_MIN, INT32_MAX, true});
  t.add({"Position Trajectory", x430::kPositionTrajectory, 4, kRO, kR, 0, INT32_MIN, INT32_MAX, true});
  t.add({"Present Input Voltage", x430::kPresentInputVoltage, 2, kRO, kR, 0, 0, 0xFFFF});
  t.add({"Present Temperature", x430::kPresentTemperature, 1, kRO, kR, 0, 0, 255});
  if (external_ports) {
    for (uint16_t n = 0; n < 3; ++n) {
      t.add({"External Port Data", static_cast<uint16_t>(152 + 2 * n), 2, kRW, kR, 0, 0, 0xFFFF});
    }
  }
  // Indirect Address n holds a target address (64..661), Indirect Data n mirrors that byte.
  for (uint16_t n = 0; n < x430::kIndirectSlots; ++n) {
    t.add({"Indirect Address", static_cast<uint16_t>(x430::kIndirectAddress1 + 2 * n), 2, kRW, kR,
           x430::kIndirectData1 + n, x430::kEepromEnd, x430::kTableBytes - 1});
  }
  for (uint16_t n = 0; n < x430::kIndirectSlots; ++n) {
    t.add({"Indirect Data", static_cast<uint16_t>(x430::kIndirectData1 + n), 1, kRW, kR, 0, 0, 255});
  }
  for (uint16_t n = 0; n < x430::kIndirectSlots; ++n) {
    t.add({"Indirect Address", static_cast<uint16_t>(x430::kIndirectAddress29 + 2 * n), 2, kRW, kR,
           x430::kIndirectData29 + n, x430::kEepromEnd, x430::kTableBytes - 1});
  }
  for (uint16_t n = 0; n < x430::kIndirectSlots; ++n) {
    t.add({"Indirect Data", static_cast<uint16_t>(x430::kIndirectData29 + n), 1, kRW, kR, 0, 0, 255});
  }
  return t;
}

// Firmware 45: the first X430 firmware with FAST reads, CONTROL TABLE BACKUP and Startup Configuration.
constexpr uint8_t kXFirmware = 45;
// MX(2.0) firmware (assumption, not measured): late enough for CLEAR and the broadcast FACTORY
// RESET rule (fw >= 42, §2.4); FAST reads, BACKUP and Startup Configuration are documented for X
// (and P) firmware only, so the MX(2.0) models have none of them.
constexpr uint8_t kMx2Firmware = 44;

// XM430-W350: newest e-Manual table (fw >= 42: Velocity Limit 200; no Acceleration Limit).
constexpr XTable kXm430Table = x_table({1020, kXFirmware, 1193, false, true, 80, 160, 95, 95, 160, 200, 1920, 0, 800});
// XL430-W250 (reference §3.7 column).
constexpr XTable kXl430Table = x_table({1060, kXFirmware, 0, true, true, 72, 140, 60, 60, 140, 415, 1000, 4000, 640});
// XH540-W270 / -W150 (e-Manual xh540-w270, xh540-w150 control tables): model numbers 1100 / 1110,
// Current Limit 2047 (2.69 mA), Velocity Limit 167 / 300, voltage limits 95..160, gains as XM430 but
// Position P 800. The W270 page lists Startup Configuration (fw >= 45, so FAST reads and BACKUP);
// the W150 page does not, so that model gets the older firmware's feature set (docs/devices.md).
constexpr XTable kXh540W270Table =
    x_table({1100, kXFirmware, 2047, false, true, 80, 160, 95, 95, 160, 167, 1920, 0, 800}, true);
constexpr XTable kXh540W150Table =
    x_table({1110, kMx2Firmware, 2047, false, false, 80, 160, 95, 95, 160, 300, 1920, 0, 800}, true);
// MX(2.0) (reference §3.6): Min/Max Voltage 95/160, Acceleration Limit 32767, Velocity I/P 1920/100,
// Position D/I/P 0/0/850; Temperature Limit 80 as the X430 tables (§3.6 lists no change).
constexpr XTable kMx28V2Table = x_table({30, kMx2Firmware, 0, true, false, 80, 160, 95, 95, 160, 380, 1920, 0, 850});
constexpr XTable kMx64V2Table = x_table({311, kMx2Firmware, 1941, true, false, 80, 160, 95, 95, 160, 435, 1920, 0, 850});
constexpr XTable kMx106V2Table = x_table({321, kMx2Firmware, 2047, true, false, 80, 160, 95, 95, 160, 360, 1920, 0, 850});

// Motors. A datasheet point (reference §5 unless said otherwise) and the constants derived from it.
// Gear friction and the thermal constants are assumptions (no datasheet gives them, docs/physics.md):
// Coulomb friction 2 % of the stall torque and viscous friction another 2 % of it at the no-load
// speed; thermal constants such that a stall at the full Torque Limit passes the 80 C limit within
// about a minute while holding a standing pose warms a motor by only a few kelvin.

constexpr double kRpm = 2.0 * std::numbers::pi / 60.0;
constexpr double kFrictionShare = 0.02;

struct Datasheet {
  double volts;
  double no_load_rpm;
  double stall_nm;
  double stall_a;
  double gear;
  double mass_kg;
};

struct Thermal {
  double resistance_k_w;
  double time_constant_s;
};

constexpr MotorSpec with_datasheet(Datasheet d, Thermal t) {
  MotorSpec m;
  m.rated_voltage_v = d.volts;
  m.no_load_speed_rpm = d.no_load_rpm;
  m.stall_torque_nm = d.stall_nm;
  m.stall_current_a = d.stall_a;
  m.gear_ratio = d.gear;
  m.mass_kg = d.mass_kg;
  m.friction_nm = kFrictionShare * d.stall_nm;
  m.viscous_friction_nm_s_rad = kFrictionShare * d.stall_nm / (d.no_load_rpm * kRpm);
  m.thermal_resistance_k_w = t.resistance_k_w;
  m.thermal_time_constant_s = t.time_constant_s;
  return m;
}

// ke, R, kt from the datasheet point as the thesis does for the RX-64 (section 4.2.1.2): at stall
// only the armature limits the current, R = V / I_stall, kt = tau_stall / I_stall; ke such that the
// motor reaches the datasheet no-load speed against its own gear friction,
// kt (V - ke w) / R = Coulomb + viscous w.
constexpr MotorSpec datasheet_motor(Datasheet d, Thermal t) {
  MotorSpec m = with_datasheet(d, t);
  const double w = d.no_load_rpm * kRpm;
  m.resistance_ohm = d.volts / d.stall_a;
  m.torque_constant_nm_a = d.stall_nm / d.stall_a;
  m.back_emf_v_s_rad =
      (d.volts - m.resistance_ohm * (m.friction_nm + m.viscous_friction_nm_s_rad * w) / m.torque_constant_nm_a) / w;
  return m;
}

// ke, R, kt as printed in the thesis' Table 7. Its R looks like a decimal slip (its own 15 V / 2 A
// gives 7.5 ohm); it is kept and the Torque Limit caps the torque at the datasheet stall torque
// (docs/physics.md, "Why a cap"). A robot file may override R.
constexpr MotorSpec table7_motor(Datasheet d, double ke, double r, double kt, Thermal t) {
  MotorSpec m = with_datasheet(d, t);
  m.back_emf_v_s_rad = ke;
  m.resistance_ohm = r;
  m.torque_constant_nm_a = kt;
  return m;
}

// AX-12A: 12 V, 59 rpm, 1.5 N m at 1.5 A, 254:1; 54.6 g (e-Manual product page).
constexpr MotorSpec kAx12aMotor = datasheet_motor({12.0, 59.0, 1.5, 1.5, 254.0, 0.0546}, {30.0, 40.0});
// RX-28: 18.5 V, 85 rpm, 3.7 N m at 1.9 A, 193:1, 72 g; ke 2.02, R 0.8, kt 1.9 from thesis Table 7.
constexpr MotorSpec kRx28Motor = table7_motor({18.5, 85.0, 3.7, 1.9, 193.0, 0.072}, 2.02, 0.8, 1.9, {50.0, 50.0});
// RX-64: 18.5 V, 64 rpm, 5.3 N m at 2.6 A, 200:1, 125 g; ke 2.82, R 0.75, kt 3.2 from thesis Table 7.
constexpr MotorSpec kRx64Motor = table7_motor({18.5, 64.0, 5.3, 2.6, 200.0, 0.125}, 2.82, 0.75, 3.2, {60.0, 60.0});
// MX-28(T): 12 V, 55 rpm, 2.5 N m at 1.4 A, 193:1; 72 g (e-Manual). Same motor under both firmwares.
constexpr MotorSpec kMx28Motor = datasheet_motor({12.0, 55.0, 2.5, 1.4, 193.0, 0.072}, {30.0, 50.0});
// MX-64(T): 12 V, 63 rpm, 6.0 N m at 4.1 A, 200:1; 126 g (e-Manual).
constexpr MotorSpec kMx64Motor = datasheet_motor({12.0, 63.0, 6.0, 4.1, 200.0, 0.126}, {12.0, 60.0});
// MX-106(T): 12 V, 45 rpm, 8.4 N m at 5.2 A, 225:1; 153 g (e-Manual).
constexpr MotorSpec kMx106Motor = datasheet_motor({12.0, 45.0, 8.4, 5.2, 225.0, 0.153}, {10.0, 70.0});
// XM430-W350: 12 V, 46 rpm, 4.1 N m at 2.3 A, 353.5:1; 82 g (e-Manual).
constexpr MotorSpec kXm430W350Motor = datasheet_motor({12.0, 46.0, 4.1, 2.3, 353.5, 0.082}, {18.0, 60.0});
// XH540-W270: 12 V, 39 rpm, 9.9 N m at 4.9 A (e-Manual X540 comparison table); 272.5:1 and 165 g
// from the e-Manual's XH540-V270 page (same X540 case and gear train; the W page's spec table is an
// include the sources did not show).
constexpr MotorSpec kXh540W270Motor = datasheet_motor({12.0, 39.0, 9.9, 4.9, 272.5, 0.165}, {8.0, 80.0});
// XH540-W150: 12 V, 70 rpm, 7.1 N m at 4.9 A (same table); 152.3:1 and 165 g (XH540-V150 page).
constexpr MotorSpec kXh540W150Motor = datasheet_motor({12.0, 70.0, 7.1, 4.9, 152.3, 0.165}, {8.0, 80.0});
// XL430-W250: 12 V, 61 rpm, 1.5 N m, 258.5:1; stall current 1.4 A at 12 V and 57.2 g from the
// e-Manual product page (reference §5 gives torque and speed only).
constexpr MotorSpec kXl430W250Motor = datasheet_motor({12.0, 61.0, 1.5, 1.4, 258.5, 0.0572}, {30.0, 40.0});

// Firmware units and control laws.

constexpr double deg_to_rad(double deg) { return deg * std::numbers::pi / 180.0; }

// AX/RX (reference §3.4): 1024 units over 300 deg, Moving Speed 0.111 rpm, compliance control.
constexpr ServoSpec axrx_servo(const MotorSpec& motor) {
  return ServoSpec{ServoFamily::kAxRx, ControlLaw::kCompliance, 1023, 512, deg_to_rad(300.0), 0.111, 1023.0, &motor};
}
// MX with Protocol 1.0 firmware (§3.5): 4096 units per turn, 0.114 rpm, PID (Kp = P / 8, e-Manual).
// The e-Manual gives no output scale of that PID. Rhoban measured it on MX-64 and MX-106 with an
// oscilloscope: duty = 0.158 x P x error in rad (Rhoban/bam, bam/dynamixel/actuator.py at 1b5a1ce,
// MXActuator error_gain; the Protocol 1.0 P Gain register 28 written raw). So Kp x error reaches
// full duty at 4096 / 2 pi / (8 x 0.158) = 515.8 output units: P 32 gives full duty at 129 units
// (11.3 deg). The MX-28 runs the same firmware family; Doppel assumes it alike (docs/devices.md).
constexpr double kMxDutyPerRadAndP = 0.158;
constexpr double kMxPidFullScale = 4096.0 / (2.0 * std::numbers::pi) / (8.0 * kMxDutyPerRadAndP);
constexpr ServoSpec mx_servo(const MotorSpec& motor) {
  return ServoSpec{ServoFamily::kMx, ControlLaw::kPid, 4095, 2048, deg_to_rad(360.0), 0.114, kMxPidFullScale, &motor};
}
// X series and MX(2.0) (§3.6, §3.7): 4096 pulses per turn, 0.229 rpm, PID with PWM 885 = full duty.
constexpr ServoSpec x_servo(const MotorSpec& motor) {
  return ServoSpec{ServoFamily::kNone, ControlLaw::kPid, 4095, 2048, deg_to_rad(360.0), kX430VelocityUnitRpm,
                   kX430PwmFull, &motor};
}

constexpr uint32_t mode_bit(uint8_t mode) { return uint32_t{1} << mode; }
constexpr uint32_t kXModes = mode_bit(0) | mode_bit(1) | mode_bit(3) | mode_bit(4) | mode_bit(5) | mode_bit(16);
constexpr uint32_t kXlModes = mode_bit(1) | mode_bit(3) | mode_bit(4) | mode_bit(16);
constexpr uint8_t kXDriveBits = x430::kDriveReverse | x430::kDriveTimeBased | x430::kDriveTorqueOnByGoal;
constexpr uint8_t kMx2DriveBits = x430::kDriveReverse | x430::kDriveTimeBased;
constexpr double kX430CurrentUnitA = 0.00269;  // XM430 Goal/Present Current, Current Limit (§3.7)
constexpr double kMx2CurrentUnitA = 0.00336;   // MX-64/106(2.0) Goal/Present Current, Current Limit (§3.6)

constexpr P2ModelSpec p2_servo(std::string_view name, const XTable& table, uint32_t modes, double current_unit_a,
                               uint8_t drive_bits, bool x_fw45, const ServoSpec& servo) {
  P2ModelSpec m;
  m.name = name;
  m.model_number = static_cast<uint16_t>(table.items[0].default_raw);
  m.firmware_version = static_cast<uint8_t>(table.items[2].default_raw);
  m.kind = P2DeviceKind::kServo;
  m.registers = {table.items.data(), table.count};
  m.table_bytes = x430::kTableBytes;
  m.operating_modes = modes;
  m.has_current = current_unit_a > 0.0;
  m.servo = servo;
  m.current_unit_a = current_unit_a;
  m.drive_mode_bits = drive_bits;
  m.fast_read = x_fw45;
  m.table_backup = x_fw45;
  return m;
}

// The registry: one entry per model.

const ModelSpec kAx12a{"AX-12A", 12, 24, DeviceKind::kServo, kAx12aTable, 50, false, false, axrx_servo(kAx12aMotor)};
const ModelSpec kRx28{"RX-28", 28, 8, DeviceKind::kServo, kRx28Table, 50, false, false, axrx_servo(kRx28Motor)};
const ModelSpec kRx64{"RX-64", 64, 8, DeviceKind::kServo, kRx64Table, 50, false, false, axrx_servo(kRx64Motor)};
const ModelSpec kMx28{"MX-28", 29, kMxFirmwareVersion, DeviceKind::kServo, kMx28Table, 74, true, true,
                      mx_servo(kMx28Motor)};
const ModelSpec kMx64{"MX-64", 310, kMxFirmwareVersion, DeviceKind::kServo, kMx64Table, 74, true, true,
                      mx_servo(kMx64Motor)};
const ModelSpec kMx106{"MX-106", 320, kMxFirmwareVersion, DeviceKind::kServo, kMx106Table, 74, true, true,
                       mx_servo(kMx106Motor)};
const ModelSpec kFumanoidImu{"FUMANOID-IMU", kFumanoidImuModelNumber, 1, DeviceKind::kImu, kImuTable, 50, true,
                             false, {}};
const ModelSpec kFumanoidFoot{"FUMANOID-FOOT", kFumanoidFootModelNumber, 1, DeviceKind::kFootBoard, kFootTable, 50,
                              true, false, {}};

const P2ModelSpec kXm430W350 = p2_servo("XM430-W350", kXm430Table, kXModes, kX430CurrentUnitA, kXDriveBits, true,
                                        x_servo(kXm430W350Motor));
const P2ModelSpec kXh540W270 = p2_servo("XH540-W270", kXh540W270Table, kXModes, kX430CurrentUnitA, kMx2DriveBits,
                                        true, x_servo(kXh540W270Motor));
const P2ModelSpec kXh540W150 = p2_servo("XH540-W150", kXh540W150Table, kXModes, kX430CurrentUnitA, kMx2DriveBits,
                                        false, x_servo(kXh540W150Motor));
const P2ModelSpec kXl430W250 = p2_servo("XL430-W250", kXl430Table, kXlModes, 0.0, kXDriveBits, true,
                                        x_servo(kXl430W250Motor));
const P2ModelSpec kMx28V2 = p2_servo("MX-28(2.0)", kMx28V2Table, kXlModes, 0.0, kMx2DriveBits, false,
                                     x_servo(kMx28Motor));
const P2ModelSpec kMx64V2 = p2_servo("MX-64(2.0)", kMx64V2Table, kXModes, kMx2CurrentUnitA, kMx2DriveBits, false,
                                     x_servo(kMx64Motor));
const P2ModelSpec kMx106V2 = p2_servo("MX-106(2.0)", kMx106V2Table, kXModes, kMx2CurrentUnitA,
                                      kMx2DriveBits | x430::kDriveMasterSlave, false, x_servo(kMx106Motor));
// OpenCR with the OP3 firmware: OPEN-CR.device of ROBOTIS-Framework (addresses, sizes, access,
// areas, ranges) plus the offsets at 18..23 that only the firmware (dxl_node_op3.h) has; defaults
// from dxl_node_op3_factory_reset / _init (model 0x7400, firmware 2, ID 200, baud index 4).
constexpr std::array<P2RegisterSpec, 25> kOpenCrItems{{
    {"model_number", 0, 2, kRO, kE, 0x7400, 0, 65535},
    {"version_of_firmware", 2, 1, kRO, kE, 2, 0, 254},
    {"ID", 3, 1, kRW, kE, 200, 0, 252},
    {"baudrate", 4, 1, kRW, kE, 4, 0, 252},
    {"return_delay_time", 5, 1, kRW, kE, 0, 0, 254},
    {"status_return_level", 16, 1, kRW, kE, 2, 0, 2},
    {"roll_offset", 18, 2, kRW, kE, 0, -32768, 32767, true},
    {"pitch_offset", 20, 2, kRW, kE, 0, -32768, 32767, true},
    {"yaw_offset", 22, 2, kRW, kE, 0, -32768, 32767, true},
    {"dynamixel_power", 24, 1, kRW, kR, 0, 0, 1},
    {"LED", 25, 1, kRW, kR, 0, 0, 7},
    {"LED_RGB", 26, 2, kRW, kR, 0x001F, 0, 32767},
    {"buzzer", 28, 2, kRW, kR, 0, 0, 65535},
    {"button", 30, 1, kRO, kR, 0, 0, 15},
    {"present_voltage", 31, 1, kRO, kR, 0, 50, 250},
    {"gyro_x", 32, 2, kRO, kR, 0, -32800, 32800, true},
    {"gyro_y", 34, 2, kRO, kR, 0, -32800, 32800, true},
    {"gyro_z", 36, 2, kRO, kR, 0, -32800, 32800, true},
    {"acc_x", 38, 2, kRO, kR, 0, -32768, 32768, true},
    {"acc_y", 40, 2, kRO, kR, 0, -32768, 32768, true},
    {"acc_z", 42, 2, kRO, kR, 0, -32768, 32768, true},
    {"roll", 44, 2, kRO, kR, 0, 0, 4096},
    {"pitch", 46, 2, kRO, kR, 0, 0, 4096},
    {"yaw", 48, 2, kRO, kR, 0, 0, 4096},
    {"imu_control", 50, 1, kRW, kR, 0, 0, 255},
}};
const P2ModelSpec kOpenCr{"OPEN-CR", 0x7400, 2, P2DeviceKind::kOpenCr, kOpenCrItems, 51, 0, false, false, 200, 4, {}};
// Bit-Bots boards (reference §8.2-8.4): factory ID and baud of the current firmware.
const P2ModelSpec kBitbotsImu{"BITBOTS-IMU", 0xBAFF, 1, P2DeviceKind::kBitbotsImu, {}, 0, 0, false, false, 241, 3, {}};
const P2ModelSpec kBitFoot{"BITFOOT", 0, 1, P2DeviceKind::kBitFoot, {}, 0, 0, false, false, 101, 4, {}};
const P2ModelSpec kBitbotsCore{"BITBOTS-CORE", 0xABBA, 1, P2DeviceKind::kBitbotsCore, {}, 0, 0, false, true, 42, 4, {}};

// DARwIn-OP boards: BULK READ (CM-730 since firmware 18, the FSR board on the MX-28 core); the FSR
// board's manual lists 7 843 bps..3 Mbps, the MX baud codes.
const ModelSpec kCm730{"CM-730", kCm730ModelNumber, 0x13, DeviceKind::kCm730, kCm730FullTable, cm730::kTableBytes, true,
                       false, {}};
const ModelSpec kDarwinFsr{"DARWIN-FSR", kDarwinFsrModelNumber, 0x11, DeviceKind::kDarwinFsr, kDarwinFsrTable,
                           darwin_fsr::kTableBytes, true, true, {}};

const std::array<const ModelSpec*, 10> kModels{&kAx12a, &kRx28,        &kRx64,         &kMx28,  &kMx64,
                                               &kMx106, &kFumanoidImu, &kFumanoidFoot, &kCm730, &kDarwinFsr};
const std::array<const P2ModelSpec*, 11> kP2Models{&kXm430W350, &kXl430W250,  &kXh540W270, &kXh540W150,
                                                   &kMx28V2,    &kMx64V2,     &kMx106V2,   &kBitbotsImu,
                                                   &kBitFoot,   &kBitbotsCore, &kOpenCr};

// The entry of `name` in `models` (ModelSpec or P2ModelSpec), nullptr for none.
template <class Model, std::size_t N>
const Model* find_named(const std::array<const Model*, N>& models, std::string_view name) noexcept {
  for (const Model* m : models) {
    if (m->name == name) {
      return m;
    }
  }
  return nullptr;
}

// The board of `kind` (never the servos' kind) in `models`; throws naming `protocol`.
template <class Model, std::size_t N, class Kind>
const Model& board_of(const std::array<const Model*, N>& models, Kind kind, Kind servo, const char* protocol) {
  for (const Model* m : models) {
    if (m->kind == kind && kind != servo) {
      return *m;
    }
  }
  throw std::invalid_argument(std::string("no ") + protocol + " board of this kind");
}

const ModelSpec* find_p1_model(std::string_view name) noexcept { return find_named(kModels, name); }

}  // namespace

const ModelSpec& model_spec(std::string_view name) {
  if (const ModelSpec* m = find_p1_model(name)) {
    return *m;
  }
  throw std::invalid_argument("unknown Dynamixel model \"" + std::string(name) +
                              "\"; known models: " + detail::model_names(known_models()));
}

std::span<const ModelSpec* const> known_models() noexcept { return kModels; }

const ModelSpec& board_spec(DeviceKind kind) { return board_of(kModels, kind, DeviceKind::kServo, "Protocol 1.0"); }

const P2ModelSpec* find_p2_model(std::string_view name) noexcept { return find_named(kP2Models, name); }

const P2ModelSpec& p2_model_spec(std::string_view name) {
  if (const P2ModelSpec* m = find_p2_model(name)) {
    return *m;
  }
  throw std::invalid_argument("unknown Protocol 2.0 model \"" + std::string(name) +
                              "\"; known models: " + detail::model_names(known_p2_models()));
}

std::span<const P2ModelSpec* const> known_p2_models() noexcept { return kP2Models; }

const P2ModelSpec& p2_board_spec(P2DeviceKind kind) {
  return board_of(kP2Models, kind, P2DeviceKind::kServo, "Protocol 2.0");
}

const ServoSpec* find_servo_spec(std::string_view model) noexcept {
  if (const ModelSpec* m = find_p1_model(model); m != nullptr && m->kind == DeviceKind::kServo) {
    return &m->servo;
  }
  if (const P2ModelSpec* m = find_p2_model(model); m != nullptr && m->kind == P2DeviceKind::kServo) {
    return &m->servo;
  }
  return nullptr;
}

const ServoSpec& servo_spec(std::string_view model) {
  if (const ServoSpec* s = find_servo_spec(model)) {
    return *s;
  }
  std::string names;
  for (const ModelSpec* m : kModels) {
    if (m->kind == DeviceKind::kServo) {
      names += (names.empty() ? "" : ", ") + std::string(m->name);
    }
  }
  for (const P2ModelSpec* m : kP2Models) {
    if (m->kind == P2DeviceKind::kServo) {
      names += ", " + std::string(m->name);
    }
  }
  throw std::invalid_argument("\"" + std::string(model) + "\" is not a servo model; known servo models: " + names);
}

}  // namespace doppel::dynamixel
