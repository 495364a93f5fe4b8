#pragma once
// What the active faults of a FaultTable do, applied where a real fault acts: to the measurements
// a device's firmware takes (feedback before it reaches the control table: the firmware's own
// error bits and shutdown follow), to the motor's drive (simulation thread), and to the statuses on
// the wire (bus thread, after the devices answered). Every function is rt-safe: no allocation, no
// lock, no exception. Time is simulation time, ns.

#include <array>
#include <cstdint>
#include <span>

#include "dynamixel/bus_devices.h"
#include "dynamixel/device_io.h"
#include "faults/fault.h"

namespace doppel::faults {

// A servo's measured values under its faults (overheat, voltage, position noise, stuck,
// overload, brown-out). `stuck` remembers where a stuck fault caught the servo. rt-safe.
struct StuckHold {
  uint32_t number = 0;  // the stuck fault holding it (0: none)
  double position_rad = 0.0;
};
void apply_servo(const FaultTable& table, uint32_t bus, uint8_t id, int64_t t_ns, dynamixel::ServoFeedback& feedback,
                 StuckHold& stuck) noexcept;

// The fraction of its torque a servo's motor can give (a weak motor, a sagging supply of
// `nominal_supply_v`): 1 without a fault. rt-safe.
double torque_scale(const FaultTable& table, uint32_t bus, uint8_t id, int64_t t_ns, double nominal_supply_v) noexcept;

// A dead servo or a cut bus: the device neither sees packets nor answers. rt-safe.
bool unreachable(const FaultTable& table, uint32_t bus, uint8_t id, int64_t t_ns) noexcept;

// An IMU's or foot board's readings under their faults; false when they freeze (dropout: the
// caller keeps the board's last values). rt-safe.
bool apply_imu(const FaultTable& table, uint32_t bus, uint8_t id, int64_t t_ns, dynamixel::ImuFeedback& feedback) noexcept;
bool apply_foot(const FaultTable& table, uint32_t bus, uint8_t id, int64_t t_ns, dynamixel::FootFeedback& feedback) noexcept;
// A power board's supply reading under a brown-out. rt-safe.
void apply_power(const FaultTable& table, int64_t t_ns, dynamixel::PowerFeedback& feedback) noexcept;

// What the wire faults of one bus did, for the listing and tests (bus thread writes).
struct WireCounters {
  uint64_t corrupted = 0;  // statuses with a flipped byte
  uint64_t dropped = 0;    // statuses lost
  uint64_t delayed = 0;    // statuses sent late
  uint64_t stray = 0;      // statuses of a device that should have been silent
};

// The bus faults on the statuses of one instruction: late answers, corrupted or dropped statuses,
// a stray status colliding with the answer. Owns copies of the packets it changes (valid until
// the next apply). Each rate fault draws once per status (collision: per instruction) in the
// order they come, so the same traffic with the same seed meets the same faults. rt-safe.
class WireFaults {
 public:
  std::span<const dynamixel::OutgoingStatus> apply(const FaultTable& table, uint32_t bus, int64_t t_ns,
                                                   const dynamixel::InstructionPacket& instruction,
                                                   std::span<const dynamixel::OutgoingStatus> statuses) noexcept;
  const WireCounters& counters() const noexcept { return counters_; }

 private:
  // The next draw of the fault in table slot `slot` (restarts at 0 for a new fault in the slot).
  double draw(const Fault& fault, std::size_t slot) noexcept;

  std::array<dynamixel::OutgoingStatus, dynamixel::BusDevices::kMaxDevices + 1> out_{};
  std::array<dynamixel::StatusPacket, dynamixel::BusDevices::kMaxDevices + 1> packets_{};
  std::array<uint32_t, kMaxFaults> slot_number_{};
  std::array<uint64_t, kMaxFaults> draws_{};
  WireCounters counters_{};
};

}  // namespace doppel::faults
