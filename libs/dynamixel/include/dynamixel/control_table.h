#pragma once
// Protocol 1.0 control tables: the register layout of every device model (address, size, access,
// EEPROM/RAM area, factory default, writable range), named as in the ROBOTIS e-Manual (reference
// §3.4/3.5), and the status-packet error bits (§1.4). Data only; the device models in
// protocol1_device.h enforce it. Servo-specific value rules (angle limits, wheel mode) live there too.

#include <cstdint>
#include <span>
#include <string_view>

namespace doppel::dynamixel {

// ERR byte of a Protocol 1.0 status packet (reference §1.4). Also the bit layout of the
// Alarm LED (17) and Alarm Shutdown (18) masks.
namespace p1_error {
inline constexpr uint8_t kInputVoltage = 0x01;  // Present Voltage outside [Min, Max] Voltage Limit
inline constexpr uint8_t kAngleLimit = 0x02;    // Goal Position written outside [CW, CCW] Angle Limit
inline constexpr uint8_t kOverheating = 0x04;   // Present Temperature > Temperature Limit
inline constexpr uint8_t kRange = 0x08;         // value, address or access out of range
inline constexpr uint8_t kChecksum = 0x10;      // instruction packet checksum wrong
inline constexpr uint8_t kOverload = 0x20;      // load cannot be controlled with the set torque
inline constexpr uint8_t kInstruction = 0x40;   // undefined/malformed instruction, ACTION without REG_WRITE
}  // namespace p1_error

// Register addresses of the Protocol 1.0 servos (AX-12A, RX-28, RX-64, MX-28/64/106 with P1 firmware).
// Where AX/RX and MX differ, both names are given for the same address.
namespace p1 {
inline constexpr uint8_t kModelNumber = 0;
inline constexpr uint8_t kFirmwareVersion = 2;
inline constexpr uint8_t kId = 3;
inline constexpr uint8_t kBaudRate = 4;
inline constexpr uint8_t kReturnDelayTime = 5;
inline constexpr uint8_t kCwAngleLimit = 6;
inline constexpr uint8_t kCcwAngleLimit = 8;
inline constexpr uint8_t kDriveMode = 10;  // MX-106 only
inline constexpr uint8_t kTemperatureLimit = 11;
inline constexpr uint8_t kMinVoltageLimit = 12;
inline constexpr uint8_t kMaxVoltageLimit = 13;
inline constexpr uint8_t kMaxTorque = 14;
inline constexpr uint8_t kStatusReturnLevel = 16;
inline constexpr uint8_t kAlarmLed = 17;
inline constexpr uint8_t kAlarmShutdown = 18;
inline constexpr uint8_t kDownCalibration = 20;   // AX/RX
inline constexpr uint8_t kUpCalibration = 22;     // AX/RX
inline constexpr uint8_t kMultiTurnOffset = 20;   // MX
inline constexpr uint8_t kResolutionDivider = 22; // MX
inline constexpr uint8_t kTorqueEnable = 24;
inline constexpr uint8_t kLed = 25;
inline constexpr uint8_t kCwComplianceMargin = 26;   // AX/RX
inline constexpr uint8_t kCcwComplianceMargin = 27;  // AX/RX
inline constexpr uint8_t kCwComplianceSlope = 28;    // AX/RX
inline constexpr uint8_t kCcwComplianceSlope = 29;   // AX/RX
inline constexpr uint8_t kDGain = 26;                // MX
inline constexpr uint8_t kIGain = 27;                // MX
inline constexpr uint8_t kPGain = 28;                // MX
inline constexpr uint8_t kGoalPosition = 30;
inline constexpr uint8_t kMovingSpeed = 32;
inline constexpr uint8_t kTorqueLimit = 34;
inline constexpr uint8_t kPresentPosition = 36;
inline constexpr uint8_t kPresentSpeed = 38;
inline constexpr uint8_t kPresentLoad = 40;
inline constexpr uint8_t kPresentVoltage = 42;
inline constexpr uint8_t kPresentTemperature = 43;
inline constexpr uint8_t kRegistered = 44;
inline constexpr uint8_t kMoving = 46;
inline constexpr uint8_t kLock = 47;
inline constexpr uint8_t kPunch = 48;
inline constexpr uint8_t kRealtimeTick = 50;          // MX
inline constexpr uint8_t kCurrent = 68;               // MX-64, MX-106
inline constexpr uint8_t kTorqueCtrlModeEnable = 70;  // MX-64, MX-106
inline constexpr uint8_t kGoalTorque = 71;            // MX-64, MX-106
inline constexpr uint8_t kGoalAcceleration = 73;      // MX

// While Lock (47) is 1 only these addresses accept writes (S7 manuals).
inline constexpr uint8_t kLockedWritableFirst = 24;
inline constexpr uint8_t kLockedWritableLast = 35;
}  // namespace p1

// Register addresses of Doppel's FUmanoid boards (docs/devices.md). The header (0..5, 16) matches a
// servo's so generic drivers can ping them and change ID, baud rate and Return Delay Time.
namespace fumanoid {
inline constexpr uint8_t kModelNumber = 0;
inline constexpr uint8_t kFirmwareVersion = 2;
inline constexpr uint8_t kId = 3;
inline constexpr uint8_t kBaudRate = 4;
inline constexpr uint8_t kReturnDelayTime = 5;
inline constexpr uint8_t kSamplePeriod = 6;  // ms between two latched samples
inline constexpr uint8_t kStatusReturnLevel = 16;
inline constexpr uint8_t kLed = 25;
// IMU (FUMANOID-IMU): int16 each.
inline constexpr uint8_t kPitch = 26;   // 0.1 mrad, + = nose down
inline constexpr uint8_t kRoll = 28;    // 0.1 mrad, + = right side down
inline constexpr uint8_t kYaw = 30;     // 0.1 mrad, + = CCW seen from above, -pi..pi
inline constexpr uint8_t kGyroX = 32;   // mrad/s
inline constexpr uint8_t kGyroY = 34;   // mrad/s
inline constexpr uint8_t kGyroZ = 36;   // mrad/s
inline constexpr uint8_t kAccelX = 38;  // 0.01 m/s^2 (specific force)
inline constexpr uint8_t kAccelY = 40;  // 0.01 m/s^2
inline constexpr uint8_t kAccelZ = 42;  // 0.01 m/s^2, about +981 at rest
// Foot board (FUMANOID-FOOT): uint16 each, 0.01 N.
inline constexpr uint8_t kForceFrontLeft = 26;
inline constexpr uint8_t kForceFrontRight = 28;
inline constexpr uint8_t kForceBackLeft = 30;
inline constexpr uint8_t kForceBackRight = 32;
inline constexpr uint8_t kForceTotal = 34;
// Both boards.
inline constexpr uint8_t kRegistered = 44;
inline constexpr uint8_t kLock = 47;
inline constexpr uint8_t kSampleCounter = 48;  // uint16, +1 per latched sample, wraps
}  // namespace fumanoid

// Register addresses of the DARwIn-OP CM-730 sub-controller: the framework's CM730.h
// (darwinop-ens/darwin-op, Framework/include/CM730.h) and the e-Manual's CM-730 table (docs/devices.md).
namespace cm730 {
inline constexpr uint8_t kModelNumber = 0;
inline constexpr uint8_t kFirmwareVersion = 2;
inline constexpr uint8_t kId = 3;
inline constexpr uint8_t kBaudRate = 4;
inline constexpr uint8_t kReturnDelayTime = 5;
inline constexpr uint8_t kStatusReturnLevel = 16;
inline constexpr uint8_t kDxlPower = 24;   // 1 = the servos' supply is switched on
inline constexpr uint8_t kLedPanel = 25;   // bits 0..2 = LED2, LED3, LED4
inline constexpr uint8_t kLedHead = 26;    // LED 5, RGB555: red bits 0-4, green 5-9, blue 10-14
inline constexpr uint8_t kLedEye = 28;     // LED 6, RGB555
inline constexpr uint8_t kButton = 30;     // bit 0 MODE, bit 1 START
inline constexpr uint8_t kGyroZ = 38;      // 10 bit, 512 = no rotation
inline constexpr uint8_t kGyroY = 40;
inline constexpr uint8_t kGyroX = 42;
inline constexpr uint8_t kAccelX = 44;     // 10 bit, 512 = 0 g
inline constexpr uint8_t kAccelY = 46;
inline constexpr uint8_t kAccelZ = 48;
inline constexpr uint8_t kVoltage = 50;    // 0.1 V
inline constexpr uint8_t kLeftMic = 51;    // MIC 1 / ADC 1, 10 bit
inline constexpr uint8_t kAdc2 = 53;       // ADC 2..8 at 53, 55, ..., 65
inline constexpr uint8_t kRightMic = 67;   // MIC 2 / ADC 9
inline constexpr uint8_t kAdc10 = 69;      // ADC 10..15 at 69, 71, ..., 79
inline constexpr uint8_t kTableBytes = 81; // CM730::MAXNUM_ADDRESS
}  // namespace cm730

// Register addresses of the DARwIn-OP FSR foot boards: the framework's FSR.h
// (darwinop-ens/darwin-op, Framework/include/FSR.h) and the e-Manual's FSR table (docs/devices.md).
namespace darwin_fsr {
inline constexpr uint8_t kModelNumber = 0;
inline constexpr uint8_t kFirmwareVersion = 2;
inline constexpr uint8_t kId = 3;
inline constexpr uint8_t kBaudRate = 4;
inline constexpr uint8_t kReturnDelayTime = 5;
inline constexpr uint8_t kStatusReturnLevel = 16;
inline constexpr uint8_t kOperatingMode = 19;  // FSR.h only; stored, no effect
inline constexpr uint8_t kLed = 25;
inline constexpr uint8_t kFsr1 = 26;           // FSR1..4 at 26, 28, 30, 32: 1 mN
inline constexpr uint8_t kFsr2 = 28;
inline constexpr uint8_t kFsr3 = 30;
inline constexpr uint8_t kFsr4 = 32;
inline constexpr uint8_t kFsrX = 34;           // centre of pressure 0..254, 255 = no load
inline constexpr uint8_t kFsrY = 35;
inline constexpr uint8_t kPresentVoltage = 42; // 0.1 V
inline constexpr uint8_t kRegistered = 44;
inline constexpr uint8_t kLock = 47;
inline constexpr uint8_t kTableBytes = 48;     // FSR::MAXNUM_ADDRESS
inline constexpr uint8_t kRightFootId = 111;   // FSR::ID_R_FSR
inline constexpr uint8_t kLeftFootId = 112;    // FSR::ID_L_FSR
}  // namespace darwin_fsr

enum class Access : uint8_t { kRead, kReadWrite };
enum class Area : uint8_t { kEeprom, kRam };

// One register of a control table. Multi-byte registers are little-endian.
struct RegisterSpec {
  std::string_view name;  // e-Manual name, e.g. "Goal Position"
  uint8_t address = 0;    // first byte
  uint8_t size = 1;       // bytes: 1 or 2
  Access access = Access::kRead;
  Area area = Area::kRam;
  int32_t default_raw = 0;  // factory default / power-on value (servos set Goal Position and Torque Limit at power-on)
  int32_t min_raw = 0;      // smallest value a WRITE may store (signed registers: as int16)
  int32_t max_raw = 0;      // largest value a WRITE may store
  bool is_signed = false;   // two's complement (MX Multi Turn Offset, multi-turn Goal Position)
};

// Looks up the register that contains `address` in `registers`; nullptr for a reserved/undefined byte.
const RegisterSpec* find_register(std::span<const RegisterSpec> registers, uint8_t address) noexcept;

}  // namespace doppel::dynamixel
