#pragma once
// The shapes of what Doppel knows about a Protocol 1.0 device model: identity (model number,
// firmware version), control table, which instructions its firmware understands, and for servos
// the firmware's units and control law and the motor (MotorSpec). The models themselves are entries
// of the one registry, model_registry.cpp (see model_registry.h); not a device (see
// protocol1_servo.h, fumanoid_boards.h).

#include <cstdint>
#include <span>
#include <string_view>

#include "dynamixel/control_table.h"

namespace doppel::dynamixel {

enum class DeviceKind : uint8_t {
  kServo,
  kImu,        // Doppel's FUmanoid IMU board
  kFootBoard,  // Doppel's FUmanoid foot board
  kCm730,      // DARwIn-OP sub-controller (darwin_boards.h)
  kDarwinFsr,  // DARwIn-OP FSR foot board (darwin_boards.h)
};
enum class ServoFamily : uint8_t { kNone, kAxRx, kMx };

// How the firmware's motor controller turns a goal into a duty (servo_controller.h).
enum class ControlLaw : uint8_t {
  kCompliance,  // AX/RX: compliance margin, slope and punch
  kPid,         // MX (Protocol 1.0 and 2.0 firmware), X series: PID on the position error
};

// A servo's geared DC motor as the simulation needs it, referred to the output shaft (gear
// inside): V = ke w + R i, tau = kt i (thesis section 4.2.1.2). The datasheet point comes with its
// source in the registry entry; the constants derived from it are explained where they are derived.
struct MotorSpec {
  double rated_voltage_v = 0.0;           // supply of the datasheet figures
  double no_load_speed_rpm = 0.0;         // datasheet, output shaft, at rated_voltage_v
  double stall_torque_nm = 0.0;           // datasheet, at rated_voltage_v: what Torque Limit 100 % means
  double stall_current_a = 0.0;           // datasheet, at rated_voltage_v
  double gear_ratio = 0.0;                // motor turns per output turn
  double mass_kg = 0.0;                   // whole servo
  double back_emf_v_s_rad = 0.0;          // ke, V per rad/s
  double resistance_ohm = 0.0;            // R, armature
  double torque_constant_nm_a = 0.0;      // kt, N m per A
  double friction_nm = 0.0;               // Coulomb gear friction, N m (assumption, see the registry)
  double viscous_friction_nm_s_rad = 0.0; // viscous gear friction, N m per rad/s (assumption)
  double thermal_resistance_k_w = 0.0;    // winding to ambient, K/W (assumption)
  double thermal_time_constant_s = 0.0;   // winding + case, s (assumption)
};

// A servo's firmware units and control law, and its motor.
struct ServoSpec {
  ServoFamily family = ServoFamily::kNone;  // Protocol 1.0 register semantics; kNone for Protocol 2.0 servos
  ControlLaw law = ControlLaw::kPid;
  uint16_t position_max_raw = 0;     // largest single-turn position: 1023 (AX/RX), 4095 (MX, X)
  uint16_t position_center_raw = 0;  // register value of 0 rad: 512 (AX/RX), 2048 (MX, X)
  double position_span_rad = 0.0;    // angle covered by position_max_raw + 1 units: 300 deg / 360 deg
  double speed_unit_rpm = 0.0;       // speed register unit: 0.111 (AX/RX), 0.114 (MX), 0.229 (X, MX(2.0)) rpm
  double pwm_full_scale = 0.0;       // controller output that means full duty: MX (P1) 515.8, X / MX(2.0) 885
  const MotorSpec* motor = nullptr;  // servos: never null

  // Position register units per radian.
  double units_per_rad() const noexcept { return (position_max_raw + 1.0) / position_span_rad; }
};

struct ModelSpec {
  std::string_view name;        // model name as used in robot descriptions
  uint16_t model_number = 0;    // Model Number register (0)
  uint8_t firmware_version = 0; // Firmware Version register (2)
  DeviceKind kind = DeviceKind::kServo;
  std::span<const RegisterSpec> registers;  // every defined register, ascending address
  uint16_t table_bytes = 0;     // addresses 0..table_bytes-1 can be read; reads beyond -> Range Error
  bool bulk_read = false;       // firmware understands BULK READ (0x92)
  bool mx_baud_codes = false;   // Baud Rate 250..252 mean 2.25/2.5/3 Mbps (MX)
  ServoSpec servo;              // kind == kServo only
};

// The spec of Protocol 1.0 model `name` (model_registry.cpp). Throws std::invalid_argument naming
// the known models. Setup only.
const ModelSpec& model_spec(std::string_view name);

// Every known Protocol 1.0 model, servos first.
std::span<const ModelSpec* const> known_models() noexcept;
// The spec of Doppel's board of `kind` (not kServo), for the board classes. Setup only.
const ModelSpec& board_spec(DeviceKind kind);

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
