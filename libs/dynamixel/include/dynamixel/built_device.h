#pragma once
// A device as the factories build it: the bus side (Device, owned) and its simulation side, typed
// by role, so that the gateway links it to the body by a switch over the role instead of probing
// concrete types. Every device the factories know has exactly one role.

#include <memory>
#include <variant>

#include "dynamixel/device.h"
#include "dynamixel/device_io.h"

namespace doppel::dynamixel {

// The simulation side of one device; the pointer is never null and points into BuiltDevice::device.
using DeviceRole =
    std::variant<SimulatedServo*, SimulatedImu*, SimulatedFootBoard*, SimulatedPowerBoard*, SimulatedController*>;

struct BuiltDevice {
  std::unique_ptr<Device> device;  // what the bus dispatches packets to
  DeviceRole role;                 // what the simulation reads commands from and feeds measurements to
};

// Pairs a concrete device with its role (the role pointer is taken before ownership moves).
template <typename Role, typename Concrete>
BuiltDevice built(std::unique_ptr<Concrete> device) {
  Role* role = device.get();
  return BuiltDevice{std::move(device), DeviceRole{role}};
}

}  // namespace doppel::dynamixel
