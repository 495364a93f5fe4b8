#pragma once
// The shapes of what Doppel knows about a Protocol 2.0 device model: the X-series control-table
// layout of reference §3.7 (16-bit addresses, 1/2/4-byte items, EEPROM below 64), shared by the
// MX(2.0) firmware tables of §3.6 with their own items and defaults, the operating modes and
// instructions each model has, and the identity of the Bit-Bots boards of §8. The models
// themselves are entries of the one registry, model_registry.cpp; not a device (see
// protocol2_servo.h, bitbots_boards.h). Register names follow the ROBOTIS e-Manual.

#include <cstdint>
#include <span>
#include <string_view>

#include "dynamixel/control_table.h"
#include "dynamixel/models.h"

namespace doppel::dynamixel {

// Control-table addresses of the X series and MX(2.0) (reference §3.7).
namespace x430 {
inline constexpr uint16_t kModelNumber = 0;
inline constexpr uint16_t kModelInformation = 2;
inline constexpr uint16_t kFirmwareVersion = 6;
inline constexpr uint16_t kId = 7;
inline constexpr uint16_t kBaudRate = 8;
inline constexpr uint16_t kReturnDelayTime = 9;
inline constexpr uint16_t kDriveMode = 10;
inline constexpr uint16_t kOperatingMode = 11;
inline constexpr uint16_t kSecondaryId = 12;
inline constexpr uint16_t kProtocolType = 13;
inline constexpr uint16_t kHomingOffset = 20;
inline constexpr uint16_t kMovingThreshold = 24;
inline constexpr uint16_t kTemperatureLimit = 31;
inline constexpr uint16_t kMaxVoltageLimit = 32;
inline constexpr uint16_t kMinVoltageLimit = 34;
inline constexpr uint16_t kPwmLimit = 36;
inline constexpr uint16_t kCurrentLimit = 38;       // models with has_current
inline constexpr uint16_t kAccelerationLimit = 40;  // XL and MX(2.0) (older X tables)
inline constexpr uint16_t kVelocityLimit = 44;
inline constexpr uint16_t kMaxPositionLimit = 48;
inline constexpr uint16_t kMinPositionLimit = 52;
inline constexpr uint16_t kStartupConfiguration = 60;
inline constexpr uint16_t kShutdown = 63;
inline constexpr uint16_t kTorqueEnable = 64;
inline constexpr uint16_t kLed = 65;
inline constexpr uint16_t kStatusReturnLevel = 68;
inline constexpr uint16_t kRegisteredInstruction = 69;
inline constexpr uint16_t kHardwareErrorStatus = 70;
inline constexpr uint16_t kVelocityIGain = 76;
inline constexpr uint16_t kVelocityPGain = 78;
inline constexpr uint16_t kPositionDGain = 80;
inline constexpr uint16_t kPositionIGain = 82;
inline constexpr uint16_t kPositionPGain = 84;
inline constexpr uint16_t kFeedforward2ndGain = 88;
inline constexpr uint16_t kFeedforward1stGain = 90;
inline constexpr uint16_t kBusWatchdog = 98;
inline constexpr uint16_t kGoalPwm = 100;
inline constexpr uint16_t kGoalCurrent = 102;  // models with has_current
inline constexpr uint16_t kGoalVelocity = 104;
inline constexpr uint16_t kProfileAcceleration = 108;
inline constexpr uint16_t kProfileVelocity = 112;
inline constexpr uint16_t kGoalPosition = 116;
inline constexpr uint16_t kRealtimeTick = 120;
inline constexpr uint16_t kMoving = 122;
inline constexpr uint16_t kMovingStatus = 123;
inline constexpr uint16_t kPresentPwm = 124;
inline constexpr uint16_t kPresentCurrent = 126;  // models with Current Limit: current; others: Present Load
inline constexpr uint16_t kPresentLoad = 126;
inline constexpr uint16_t kPresentVelocity = 128;
inline constexpr uint16_t kPresentPosition = 132;
inline constexpr uint16_t kVelocityTrajectory = 136;
inline constexpr uint16_t kPositionTrajectory = 140;
inline constexpr uint16_t kPresentInputVoltage = 144;
inline constexpr uint16_t kPresentTemperature = 146;
inline constexpr uint16_t kIndirectAddress1 = 168;   // Indirect Address 1..28: 168, 170, ..., 222
inline constexpr uint16_t kIndirectData1 = 224;      // Indirect Data 1..28: 224..251
inline constexpr uint16_t kIndirectAddress29 = 578;  // Indirect Address 29..56: 578, ..., 632
inline constexpr uint16_t kIndirectData29 = 634;     // Indirect Data 29..56: 634..661
inline constexpr uint16_t kIndirectSlots = 28;       // per block

inline constexpr uint16_t kEepromEnd = 64;  // addresses below are EEPROM (locked while torque is on)
inline constexpr uint16_t kTableBytes = 662;

// Protocol Type (13) values: the protocol the servo speaks (reference §3.7).
inline constexpr uint8_t kProtocolType1 = 1;
inline constexpr uint8_t kProtocolType2 = 2;

// Operating Mode (11) values.
inline constexpr uint8_t kCurrentMode = 0;
inline constexpr uint8_t kVelocityMode = 1;
inline constexpr uint8_t kPositionMode = 3;
inline constexpr uint8_t kExtendedPositionMode = 4;
inline constexpr uint8_t kCurrentBasedPositionMode = 5;
inline constexpr uint8_t kPwmMode = 16;

// Hardware Error Status (70) / Shutdown (63) bits.
inline constexpr uint8_t kInputVoltageError = 0x01;
inline constexpr uint8_t kOverheatingError = 0x04;
inline constexpr uint8_t kEncoderError = 0x08;
inline constexpr uint8_t kElectricalShockError = 0x10;
inline constexpr uint8_t kOverloadError = 0x20;

// Drive Mode (10) bits.
inline constexpr uint8_t kDriveReverse = 0x01;
inline constexpr uint8_t kDriveMasterSlave = 0x02;     // MX-106(2.0) dual joint: stored only
inline constexpr uint8_t kDriveTimeBased = 0x04;
inline constexpr uint8_t kDriveTorqueOnByGoal = 0x08;  // X fw >= 45

// Moving Status (123) bits.
inline constexpr uint8_t kInPosition = 0x01;
inline constexpr uint8_t kProfileOngoing = 0x02;
inline constexpr uint8_t kFollowingError = 0x08;
inline constexpr uint8_t kProfileRectangular = 0x10;
inline constexpr uint8_t kProfileTriangular = 0x20;
inline constexpr uint8_t kProfileTrapezoidal = 0x30;
}  // namespace x430

// One item of a Protocol 2.0 control table. Multi-byte items are little-endian.
struct P2RegisterSpec {
  std::string_view name;   // e-Manual name, e.g. "Goal Position"
  uint16_t address = 0;    // first byte
  uint8_t size = 1;        // bytes: 1, 2 or 4
  Access access = Access::kRead;
  Area area = Area::kRam;
  int32_t default_raw = 0;  // factory default / power-on value
  int32_t min_raw = 0;      // smallest value a WRITE may store (signed items: as signed)
  int32_t max_raw = 0;      // largest value a WRITE may store
  bool is_signed = false;   // two's complement
};

enum class P2DeviceKind : uint8_t {
  kServo,        // X series and MX(2.0) (protocol2_servo.h)
  kBitbotsImu,   // Bit-Bots IMU DXL module (bitbots_boards.h)
  kBitFoot,      // Bit-Bots BitFoot foot pressure board
  kBitbotsCore,  // Bit-Bots CORE board
  kOpenCr,       // ROBOTIS OpenCR with the OP3 firmware (opencr_board.h)
};

struct P2ModelSpec {
  std::string_view name;          // model name as used in robot descriptions
  uint16_t model_number = 0;      // Model Number (0), PING params 1-2
  uint8_t firmware_version = 0;   // Firmware Version (6), PING param 3
  P2DeviceKind kind = P2DeviceKind::kServo;
  std::span<const P2RegisterSpec> registers;  // servos, OpenCR: every item, ascending address; Bit-Bots boards: empty
  uint16_t table_bytes = 0;       // servos: addresses 0..table_bytes-1 exist; beyond -> Access Error
  uint32_t operating_modes = 0;   // servos: bit m set = Operating Mode m allowed
  bool has_current = false;       // servos: Current Limit / Goal Current / Present Current
  bool baud7_is_5m = false;       // Baud Rate 7 = 5 Mbps (Bit-Bots CORE) instead of 4.5 Mbps
  uint8_t default_id = 1;         // factory ID
  uint8_t default_baud_raw = 1;   // factory Baud Rate index (reference §3.3 / §8.1)
  ServoSpec servo;                // kind == kServo only (family kNone: Protocol 2.0 register semantics)
  double current_unit_a = 0.0;    // servos with has_current: A per Current Limit / Goal / Present Current unit
  uint8_t drive_mode_bits = 0;    // servos: Drive Mode (10) bits the firmware accepts (others: Data Range)
  bool fast_read = false;         // servos: FAST SYNC READ / FAST BULK READ (X430 fw >= 45, §2.4)
  bool table_backup = false;      // servos: CONTROL TABLE BACKUP (X430 fw >= 45, §2.4)
};

// The spec of Protocol 2.0 model `name` (model_registry.cpp). Throws std::invalid_argument naming
// the known Protocol 2.0 models. Setup only.
const P2ModelSpec& p2_model_spec(std::string_view name);
// nullptr when `name` is not a Protocol 2.0 model. Setup only.
const P2ModelSpec* find_p2_model(std::string_view name) noexcept;
// Every known Protocol 2.0 model, servos first.
std::span<const P2ModelSpec* const> known_p2_models() noexcept;
// The spec of the board of `kind` (not kServo), for the board classes. Setup only.
const P2ModelSpec& p2_board_spec(P2DeviceKind kind);

// The item containing `address`, nullptr for a reserved byte. rt-safe.
const P2RegisterSpec* find_p2_register(std::span<const P2RegisterSpec> registers, uint16_t address) noexcept;

// Line rate of a Baud Rate index (reference §3.3; 7 = 5 Mbps when `baud7_is_5m`), 0 for an index
// the device does not have. rt-safe.
uint32_t p2_baud_bps(uint8_t raw, bool baud7_is_5m = false) noexcept;
// The Baud Rate index whose rate is within 3 % of `bps` for `model`. Throws std::invalid_argument
// listing the rates the model supports. Setup only.
uint8_t p2_baud_register(uint32_t bps, const P2ModelSpec& model);

// X-series units (reference §3.7).
inline constexpr double kX430PulsesPerRev = 4096.0;       // Present/Goal Position
inline constexpr double kX430VelocityUnitRpm = 0.229;     // Goal/Present Velocity, Profile Velocity
inline constexpr double kX430AccelerationUnitRpm2 = 214.577;  // Profile Acceleration, rev/min^2
inline constexpr double kX430PwmFull = 885.0;             // PWM 100 %
inline constexpr double kX430VoltageUnitV = 0.1;          // Present Input Voltage, voltage limits
inline constexpr int64_t kX430WatchdogUnitNs = 20'000'000;  // Bus Watchdog: 20 ms per unit

}  // namespace doppel::dynamixel
