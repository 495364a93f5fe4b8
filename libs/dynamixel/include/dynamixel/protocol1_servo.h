#pragma once
// A Protocol 1.0 Dynamixel servo (AX/RX and MX with Protocol 1.0 firmware) as its firmware
// behaves on the bus, plus the link to the simulation: command() turns the registers into SI
// set-points for the motor model, apply() turns measured SI values into the Present registers and
// the condition error bits. It does not simulate the motor; the physics side does.
// Behaviour choices where the manuals are silent are listed in docs/devices.md.

#include <cstdint>

#include "dynamixel/device_io.h"
#include "dynamixel/protocol1_device.h"

namespace doppel::dynamixel {

enum class ServoMode : uint8_t {
  kJoint,      // position control within [CW, CCW] Angle Limit
  kWheel,      // both angle limits 0: endless turn, Moving Speed is a signed output
  kMultiTurn,  // MX only, both angle limits 4095: position over +-7 turns
};

class Protocol1Servo final : public Protocol1Device, public SimulatedServo {
 public:
  // Powers on a servo of `spec` (kind kServo) with the given ID (0..253), Baud Rate register value
  // and Return Delay Time register value, its output at `initial_position_rad`. Throws
  // std::invalid_argument for a non-servo spec or an out-of-range value. Setup only.
  Protocol1Servo(const ModelSpec& spec, uint8_t id, uint8_t baud_raw, uint8_t return_delay_raw,
                 double initial_position_rad = 0.0);

  // Power cycle: RAM registers to their power-on values, Goal Position = Present Position
  // (from `position_rad`), Torque Limit = Max Torque, Lock and Registered cleared; EEPROM kept. rt-safe.
  void power_on(double position_rad) noexcept;

  // Registers -> what the motor controller should do (SI; conventions in device_io.h). rt-safe.
  ServoCommand command() const noexcept override;
  // Measured values -> Present Position/Speed/Load/Voltage/Temperature, Moving, (MX) Realtime
  // Tick and Current (from current_a); updates the condition bits (Overload: the motor
  // controller's, feedback.overload) and applies Alarm Shutdown. rt-safe.
  void apply(const ServoFeedback& feedback) noexcept override;

  ServoMode mode() const noexcept;
  // Persistent condition bits (p1_error::kOverload, kOverheating, kInputVoltage) from the last apply().
  uint8_t conditions() const noexcept { return conditions_; }

  // Register <-> SI conversions of this model (rt-safe).
  double position_rad_from_raw(int32_t raw) const noexcept;  // 512 / 2048 -> 0 rad
  int32_t position_raw_from_rad(double position_rad) const noexcept;  // unclamped, rounded
  double speed_rad_s_from_raw(uint16_t magnitude_raw) const noexcept;  // magnitude, no direction bit

 protected:
  uint8_t condition_bits() const noexcept override { return conditions_; }
  uint8_t check_write(const Table& candidate, uint8_t start, std::size_t n) const noexcept override;
  void after_factory_reset() noexcept override;
  // A write that sets Goal Position switches the torque on (docs/devices.md 3.7), unless it writes
  // Torque Enable itself.
  void after_write(uint8_t start, std::size_t n) noexcept override;

 private:
  ServoMode mode_for(uint16_t cw_limit_raw, uint16_t ccw_limit_raw) const noexcept;
  bool is_mx() const noexcept { return spec().servo.family == ServoFamily::kMx; }
  bool has_register(uint8_t address) const noexcept;

  uint8_t conditions_ = 0;
  double last_position_rad_ = 0.0;
};

}  // namespace doppel::dynamixel
