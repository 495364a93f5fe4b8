#pragma once
// The devices that share one bus, and what the wire carries back after one instruction packet:
// every answering device's status, in transmission order. Two devices answering at the same time
// (a Protocol 1.0 broadcast PING with several devices) collide: the wire then carries the
// wired-AND of their bytes, which no host can decode, as on a real half-duplex line.
// Chained replies (BULK READ) go out in chain order; a device whose predecessor in the chain
// stayed silent never sees its cue, so it and everything after it is dropped (reference §6 leaves
// this open; this is Doppel's documented choice, see docs/devices.md).
// Pure logic; the bus layer adds time.

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "dynamixel/device.h"

namespace doppel::dynamixel {

// One status packet ready for the wire, with what the timing model needs to place it.
struct OutgoingStatus {
  const StatusPacket* packet = nullptr;  // bytes to transmit (owned by BusDevices, valid until the next dispatch)
  uint8_t device_id = 0;                 // ID of the sender at the time of the instruction
  uint32_t return_delay_us = 0;          // sender's Return Delay Time
  bool after_previous = false;           // starts after the previous status in this list has ended
  bool collision = false;                // bytes are the garbled overlap of several devices
  int64_t extra_delay_ns = 0;            // P2 broadcast PING: idle ID slots before this status, ns
  bool continues_previous = false;       // P2 fast-read block: follows the previous one with no gap
};

// Counters a diagnostics thread may read (plain integers, written only by the bus thread).
struct BusDeviceCounters {
  uint64_t instructions = 0;      // packets dispatched
  uint64_t baud_mismatches = 0;   // packets that no device understood because of the line's baud rate
  uint64_t collisions = 0;        // replies that collided on the wire
  uint64_t broken_chains = 0;     // chained replies dropped because their predecessor stayed silent
};

class BusDevices {
 public:
  static constexpr std::size_t kMaxDevices = 64;
  // Relative baud-rate error a UART tolerates (reference 3.2: below 3 % works).
  static constexpr double kBaudTolerance = 0.03;

  // Adds a device (setup only; the device must outlive this object). Throws std::length_error when full.
  void add(Device& device);

  // Hands `packet`, received at `line_baud_bps`, to every device whose UART runs at that rate
  // (within kBaudTolerance) and returns their statuses in wire order. rt-safe.
  std::span<const OutgoingStatus> dispatch(const InstructionPacket& packet, uint32_t line_baud_bps) noexcept;

  // Switches the supply of the device added `index`-th (0-based) off or on, as a sub-controller's
  // Dynamixel Power does: an unpowered device neither sees packets nor answers. Devices are
  // powered when added; restoring RAM at power-on is the caller's (the device's power_cycle()). rt-safe.
  void set_powered(std::size_t index, bool powered) noexcept;
  bool powered(std::size_t index) const noexcept { return index < count_ && powered_[index]; }
  // Cuts the device added `index`-th off the wire or connects it again (faults/: a dead servo, an
  // unplugged cable): a cut-off device neither sees packets nor answers, its state stays. Devices
  // are connected when added. rt-safe.
  void set_reachable(std::size_t index, bool reachable) noexcept;
  bool reachable(std::size_t index) const noexcept { return index < count_ && reachable_[index]; }

  std::span<Device* const> devices() const noexcept { return {devices_.data(), count_}; }
  const BusDeviceCounters& counters() const noexcept { return counters_; }

 private:
  std::array<Device*, kMaxDevices> devices_{};
  std::size_t count_ = 0;
  std::array<bool, kMaxDevices> powered_{};
  std::array<bool, kMaxDevices> reachable_{};
  std::array<Response, kMaxDevices> responses_{};
  std::array<OutgoingStatus, kMaxDevices> outgoing_{};
  std::array<uint8_t, kMaxDevices> sender_ids_{};   // ID of each device before it handled the packet
  std::array<uint32_t, kMaxDevices> sender_delays_us_{};  // its Return Delay Time before the packet
  std::array<uint8_t, kMaxDevices> order_{};        // transmitting devices sorted by reply slot
  BusDeviceCounters counters_{};
};

// True when a UART at `device_bps` decodes bytes sent at `line_bps` (within BusDevices::kBaudTolerance).
bool baud_rates_match(uint32_t device_bps, uint32_t line_bps) noexcept;

}  // namespace doppel::dynamixel
