#pragma once
// A Protocol 2.0 servo (X series, MX(2.0)) as its firmware behaves on the bus,
// plus the link to the simulation through the same structs as the Protocol 1.0 servos
// (device_io.h): command() turns the registers of the active Operating Mode into SI set-points,
// apply() turns measured SI values into the Present items, Moving / Moving Status, Hardware Error
// Status and Shutdown, and runs the Bus Watchdog. It does not simulate the motor.
// Mode rules (reference §3.7): current (0), velocity (1, Velocity P/I gains), position (3),
// extended position (4), current-based position (5), PWM (16); modes 0 and 5 only on models with
// a current sensor. Present Current comes from the measured motor current, the Overload bit from
// the motor controller (ServoFeedback). Choices where the manual is silent are listed in
// docs/devices.md (Protocol 2.0 part).

#include <cstdint>

#include "dynamixel/device_io.h"
#include "dynamixel/protocol2_device.h"

namespace doppel::dynamixel {

class Protocol2Servo final : public Protocol2Device, public SimulatedServo {
 public:
  // |Goal Position - Present Position| at or below this sets In-Position (assumption: the
  // e-Manual names no threshold), pulses.
  static constexpr int32_t kInPositionWindowRaw = 10;

  // Powers on a servo of `spec` (kind kServo) with the given ID (0..252), Baud Rate index and
  // Return Delay Time, its output at `initial_position_rad` (Present Position within one turn).
  // Throws std::invalid_argument for a non-servo spec or an out-of-range value. Setup only.
  Protocol2Servo(const P2ModelSpec& spec, uint8_t id, uint8_t baud_raw, uint8_t return_delay_raw,
                 double initial_position_rad = 0.0);

  // Registers -> what the motor controller should do (SI; conventions in device_io.h). rt-safe.
  ServoCommand command() const noexcept override;
  // Measured values -> Present items, Moving, Moving Status, Realtime Tick; raises Hardware Error
  // Status bits enabled in Shutdown (torque off, Alert in every status until REBOOT) and trips the
  // Bus Watchdog. Call it regularly (also without traffic) so the watchdog sees time pass. rt-safe.
  void apply(const ServoFeedback& feedback) noexcept override;

  uint8_t operating_mode() const noexcept { return raw_table()[x430::kOperatingMode]; }
  // The Bus Watchdog has tripped (item reads -1, Goal items refuse writes until 0 is written).
  bool watchdog_tripped() const noexcept { return raw_table()[x430::kBusWatchdog] == kWatchdogTripped; }

  // Present Position value of a joint angle (rad, 0 = centre) and back, under the current Drive
  // Mode, Homing Offset and turn count. rt-safe.
  int64_t present_raw_from_rad(double position_rad) const noexcept;
  double rad_from_present_raw(int64_t present_raw) const noexcept;

 protected:
  uint8_t check_write(const Table& candidate, const ItemSet& touched) const noexcept override;
  void after_write(const Table& before, const ItemSet& touched) noexcept override;
  void reboot() noexcept override;
  uint8_t clear_multi_turn() noexcept override;
  void on_communication() noexcept override { last_communication_ns_ = now_ns_; }

 private:
  static constexpr uint8_t kWatchdogTripped = 0xFF;

  void power_on() noexcept;
  int direction() const noexcept { return (raw_table()[x430::kDriveMode] & 0x01) != 0 ? -1 : 1; }
  bool position_mode() const noexcept;
  // Re-bases the turn count so that Present Position (before Homing Offset) lies in 0..4095.
  void fold_position() noexcept;

  double last_position_rad_ = 0.0;
  int64_t turn_offset_raw_ = 2048;        // Present Position (before Homing Offset) of 0 rad
  int64_t now_ns_ = 0;                    // simulation time of the last apply()
  int64_t last_communication_ns_ = 0;     // last packet that concerned this servo (Bus Watchdog)
  double watchdog_hold_rad_ = 0.0;        // where the servo stopped when the watchdog tripped
  double time_based_speed_rad_s_ = 0.0;   // Drive Mode bit 2: speed that reaches the goal in Profile Velocity ms
  // Set at power-on: the first measured position (the body's initial pose) also becomes Goal
  // Position and Position Trajectory, as the firmware reads its encoder at boot; a goal written
  // before that measurement arrives wins.
  bool goal_from_feedback_ = false;
};

}  // namespace doppel::dynamixel
