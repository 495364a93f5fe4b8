#pragma once
// What the Dynamixel fuzz targets share: the invariant check, the input layout (byte 0 picks the line
// rate, byte 1 drives the simulation feedback, the rest is the wire) and the feedback derived from it.
// Not a harness of its own: each target keeps its devices and invariants.

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>

#include "dynamixel/bus_devices.h"
#include "dynamixel/device.h"
#include "dynamixel/protocol1.h"
#include "fuzz_check.h"


namespace doppel::dynamixel::fuzz {

// Bytes before the wire: the line-rate selector and the feedback driver.
constexpr std::size_t kWireStart = 2;

// One of the four `rates` (bit/s), picked by input byte 0.
inline uint32_t line_rate(const uint8_t* data, const uint32_t (&rates)[4]) { return rates[data[0] % 4]; }

// Puts every device on `bus`.
template <class... Devices>
void add_all(BusDevices& bus, Devices&... devices) {
  (bus.add(devices), ...);
}

// True when `packet` is for `device`: its current ID, or the broadcast ID.
inline bool addressed(const InstructionPacket& packet, const Device& device) {
  return packet.id == kBroadcastId || packet.id == device.id();
}

// Servo feedback after wire byte `data[i]`, extremes included: position `position_step_rad` per step
// of that byte around 128, velocity, voltage and the time step from input byte 1. `t_ns` advances.
inline ServoFeedback feedback_at(const uint8_t* data, std::size_t i, double position_step_rad, int64_t& t_ns) {
  t_ns += static_cast<int64_t>(data[1]) * 1'000'000;
  ServoFeedback fb;
  fb.position_rad = (static_cast<int>(data[i]) - 128) * position_step_rad;
  fb.velocity_rad_s = (static_cast<int>(data[1]) - 128) * 0.5;
  fb.torque_ratio = (data[i] & 1) ? 1.0 : -0.3;
  fb.voltage_v = data[1] * 0.1;
  fb.temperature_c = data[i];
  fb.sim_time_ns = t_ns;
  return fb;
}

// The packet of `s`, after the checks every status passes: it is there, with `min_size` to
// `max_size` bytes.
inline const StatusPacket& checked_packet(const OutgoingStatus& s, std::size_t min_size, std::size_t max_size) {
  FUZZ_CHECK(s.packet != nullptr);
  FUZZ_CHECK(s.packet->size >= min_size && s.packet->size <= max_size);
  return *s.packet;
}

// A Protocol 1.0 status: its LENGTH byte and checksum (reference §1.1) agree with its size.
inline void check_protocol1_frame(const StatusPacket& p) {
  FUZZ_CHECK(p.bytes[3] == p.size - 4);
  FUZZ_CHECK(protocol1_checksum(&p.bytes[2], p.size - 3) == p.bytes[p.size - 1]);
}

}  // namespace doppel::dynamixel::fuzz
