#pragma once
// What Doppel knows about each Protocol 1.0 device model: identity (model number, firmware
// version), control table, which instructions its firmware understands, and for servos the
// physical data the simulation needs (resolution, speed unit, DC-motor constants, gear, mass).
// Static data with a lookup by model name; not a device (see protocol1_servo.h, fumanoid_boards.h).

#include <cstdint>
#include <span>
#include <string_view>

#include "dynamixel/control_table.h"

namespace doppel::dynamixel {

enum class DeviceKind : uint8_t { kServo, kImu, kFootBoard };
enum class ServoFamily : uint8_t { kNone, kAxRx, kMx };

// Physical data of a servo (reference §3.4/3.5/§5, thesis Table 7).
struct ServoSpec {
  ServoFamily family = ServoFamily::kNone;
  uint16_t position_max_raw = 0;     // largest Present Position: 1023 (AX/RX), 4095 (MX)
  uint16_t position_center_raw = 0;  // register value of 0 rad: 512 (AX/RX), 2048 (MX)
  double position_span_rad = 0.0;    // angle covered by position_max_raw + 1 units: 300 deg / 360 deg
  double speed_unit_rpm = 0.0;       // Moving/Present Speed unit: 0.111 (AX/RX), 0.114 (MX) rpm
  double nominal_voltage_v = 0.0;    // supply of the datasheet figures below
  double no_load_speed_rpm = 0.0;    // output shaft, at nominal_voltage_v
  double stall_torque_n_m = 0.0;     // output shaft, at nominal_voltage_v
  double stall_current_a = 0.0;      // at nominal_voltage_v
  // DC-motor model seen at the output shaft (thesis §4.2.1.2): V = ke*w + R*i, tau = kt*i.
  double ke_v_s_per_rad = 0.0;       // back-EMF constant
  double resistance_ohm = 0.0;       // armature resistance
  double kt_n_m_per_a = 0.0;         // torque constant
  double gear_ratio = 0.0;           // motor turns per output turn
  double mass_kg = 0.0;

  // Position register units per radian.
  double units_per_rad() const noexcept { return (position_max_raw + 1.0) / position_span_rad; }
};

struct ModelSpec {
  std::string_view name;        // model name as used in robot descriptions, e.g. "RX-64"
  uint16_t model_number = 0;    // Model Number register (0)
  uint8_t firmware_version = 0; // Firmware Version register (2)
  DeviceKind kind = DeviceKind::kServo;
  std::span<const RegisterSpec> registers;  // every defined register, ascending address
  uint16_t table_bytes = 0;     // addresses 0..table_bytes-1 can be read; reads beyond -> Range Error
  bool bulk_read = false;       // firmware understands BULK READ (0x92)
  bool mx_baud_codes = false;   // Baud Rate 250..252 mean 2.25/2.5/3 Mbps (MX)
  ServoSpec servo;              // kind == kServo only
};

// The spec of `name` ("AX-12A", "RX-28", "RX-64", "MX-28", "MX-64", "MX-106", "FUMANOID-IMU",
// "FUMANOID-FOOT"). Throws std::invalid_argument naming the known models. Setup only.
const ModelSpec& model_spec(std::string_view name);

// Every known model, in the order above.
std::span<const ModelSpec* const> known_models() noexcept;

// Model numbers of Doppel's own boards (unused by ROBOTIS and by the boards of reference §8).
inline constexpr uint16_t kFumanoidImuModelNumber = 0x4649;   // 17993, "FI"
inline constexpr uint16_t kFumanoidFootModelNumber = 0x4646;  // 17990, "FF"

// Line rate of a Protocol 1.0 Baud Rate register value (reference §3.2): 2 000 000 / (raw + 1),
// with MX's special codes 250/251/252 = 2.25/2.5/3 Mbps when `mx_codes`. rt-safe.
uint32_t p1_baud_bps(uint8_t raw, bool mx_codes) noexcept;

// The Baud Rate register value whose rate is closest to `bps` for `model`. Throws
// std::invalid_argument when no value is within the 3 % a UART tolerates. Setup only.
uint8_t p1_baud_register(uint32_t bps, const ModelSpec& model);

}  // namespace doppel::dynamixel
