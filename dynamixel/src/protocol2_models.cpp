#include "dynamixel/protocol2_models.h"

#include <array>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "model_tables.h"

namespace doppel::dynamixel {

namespace {

constexpr Area kE = Area::kEeprom;
constexpr Area kR = Area::kRam;
constexpr Access kRO = Access::kRead;
constexpr Access kRW = Access::kReadWrite;

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

constexpr XTable x_table(XDefaults d) {
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
// MX(2.0) (reference §3.6): Min/Max Voltage 95/160, Acceleration Limit 32767, Velocity I/P 1920/100,
// Position D/I/P 0/0/850; Temperature Limit 80 as the X430 tables (§3.6 lists no change).
constexpr XTable kMx28Table = x_table({30, kMx2Firmware, 0, true, false, 80, 160, 95, 95, 160, 380, 1920, 0, 850});
constexpr XTable kMx64Table = x_table({311, kMx2Firmware, 1941, true, false, 80, 160, 95, 95, 160, 435, 1920, 0, 850});
constexpr XTable kMx106Table = x_table({321, kMx2Firmware, 2047, true, false, 80, 160, 95, 95, 160, 360, 1920, 0, 850});

constexpr uint32_t mode_bit(uint8_t mode) { return uint32_t{1} << mode; }

// An X-series / MX(2.0) servo with the DC-motor constants of its datasheet point (reference §5) at
// `volts`, derived as for the Protocol 1.0 servos (detail::with_datasheet_motor).
constexpr ServoSpec x_servo(double volts, double no_load_rpm, double stall_n_m, double stall_a, double gear,
                            double mass_kg) {
  ServoSpec s;
  s.family = ServoFamily::kNone;
  s.position_max_raw = 4095;
  s.position_center_raw = 2048;
  s.position_span_rad = 2.0 * std::numbers::pi;
  s.speed_unit_rpm = kX430VelocityUnitRpm;
  return detail::with_datasheet_motor(s, volts, no_load_rpm, stall_n_m, stall_a, gear, mass_kg);
}

constexpr uint32_t kXModes = mode_bit(0) | mode_bit(1) | mode_bit(3) | mode_bit(4) | mode_bit(5) | mode_bit(16);
constexpr uint32_t kXlModes = mode_bit(1) | mode_bit(3) | mode_bit(4) | mode_bit(16);
constexpr uint8_t kXDriveBits = x430::kDriveReverse | x430::kDriveTimeBased | x430::kDriveTorqueOnByGoal;
constexpr uint8_t kMx2DriveBits = x430::kDriveReverse | x430::kDriveTimeBased;

constexpr P2ModelSpec servo_spec(std::string_view name, const XTable& table, uint32_t modes, double current_unit_a,
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

const P2ModelSpec kXm430W350 = servo_spec("XM430-W350", kXm430Table, kXModes, kX430CurrentUnitA, kXDriveBits, true,
                                          x_servo(12.0, 46.0, 4.1, 2.3, 353.5, 0.082));
// XL430-W250 stall current: 1.4 A at 12 V (e-Manual product page; reference §5 gives torque and speed).
const P2ModelSpec kXl430W250 = servo_spec("XL430-W250", kXl430Table, kXlModes, 0.0, kXDriveBits, true,
                                          x_servo(12.0, 61.0, 1.5, 1.4, 258.5, 0.0572));
// MX(2.0): the datasheet points of reference §5 at 12 V (as the Protocol 1.0 MX models), masses of
// the MX-28T / MX-64T / MX-106T (e-Manual product pages).
const P2ModelSpec kMx28V2 = servo_spec("MX-28(2.0)", kMx28Table, kXlModes, 0.0, kMx2DriveBits, false,
                                       x_servo(12.0, 55.0, 2.5, 1.4, 193.0, 0.072));
const P2ModelSpec kMx64V2 = servo_spec("MX-64(2.0)", kMx64Table, kXModes, kMx2CurrentUnitA, kMx2DriveBits, false,
                                       x_servo(12.0, 63.0, 6.0, 4.1, 200.0, 0.126));
const P2ModelSpec kMx106V2 = servo_spec("MX-106(2.0)", kMx106Table, kXModes, kMx2CurrentUnitA,
                                        kMx2DriveBits | x430::kDriveMasterSlave, false,
                                        x_servo(12.0, 45.0, 8.4, 5.2, 225.0, 0.153));
// Bit-Bots boards (reference §8.2-8.4): factory ID and baud of the current firmware.
const P2ModelSpec kBitbotsImu{"BITBOTS-IMU", 0xBAFF, 1, P2DeviceKind::kBitbotsImu, {}, 0, 0, false, false, 241, 3, {}};
const P2ModelSpec kBitFoot{"BITFOOT", 0, 1, P2DeviceKind::kBitFoot, {}, 0, 0, false, false, 101, 4, {}};
const P2ModelSpec kBitbotsCore{"BITBOTS-CORE", 0xABBA, 1, P2DeviceKind::kBitbotsCore, {}, 0, 0, false, true, 42, 4, {}};

const std::array<const P2ModelSpec*, 8> kP2Models{&kXm430W350, &kXl430W250, &kMx28V2,    &kMx64V2,
                                                  &kMx106V2,   &kBitbotsImu, &kBitFoot, &kBitbotsCore};

constexpr std::array<uint32_t, 8> kBaudTable{9600, 57600, 115200, 1000000, 2000000, 3000000, 4000000, 4500000};

}  // namespace

const P2ModelSpec* find_p2_model(std::string_view name) noexcept {
  for (const P2ModelSpec* m : kP2Models) {
    if (m->name == name) {
      return m;
    }
  }
  return nullptr;
}

const P2ModelSpec& p2_model_spec(std::string_view name) {
  if (const P2ModelSpec* m = find_p2_model(name)) {
    return *m;
  }
  throw std::invalid_argument("unknown Protocol 2.0 model \"" + std::string(name) +
                              "\"; known models: " + detail::model_names(known_p2_models()));
}

std::span<const P2ModelSpec* const> known_p2_models() noexcept { return kP2Models; }

const P2RegisterSpec* find_p2_register(std::span<const P2RegisterSpec> registers, uint16_t address) noexcept {
  return detail::register_containing(registers, address);
}

uint32_t p2_baud_bps(uint8_t raw, bool baud7_is_5m) noexcept {
  if (raw >= kBaudTable.size()) {
    return 0;
  }
  if (raw == 7 && baud7_is_5m) {
    return 5000000;
  }
  return kBaudTable[raw];
}

uint8_t p2_baud_register(uint32_t bps, const P2ModelSpec& model) {
  std::string rates;
  for (uint8_t raw = 0; raw < kBaudTable.size(); ++raw) {
    const uint32_t rate = p2_baud_bps(raw, model.baud7_is_5m);
    if (bps != 0 && std::abs(static_cast<double>(rate) - bps) <= 0.03 * bps) {
      return raw;
    }
    rates += (rates.empty() ? "" : ", ") + std::to_string(rate);
  }
  throw std::invalid_argument(std::string(model.name) + " cannot run at " + std::to_string(bps) +
                              " bps; its Baud Rate register offers " + rates + " bps");
}

}  // namespace doppel::dynamixel
