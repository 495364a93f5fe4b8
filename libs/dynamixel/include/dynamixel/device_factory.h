#pragma once
// Builds a Protocol 1.0 device model from a robot description entry (model name, ID, baud rate,
// Return Delay Time), with its role for the link to the simulation (servo, IMU or foot board).
// Setup only.

#include <cstdint>
#include <string_view>

#include "dynamixel/built_device.h"

namespace doppel::dynamixel {

// `model`: a name known to model_spec(); `baud_bps`: the bus rate, turned into the model's Baud
// Rate register value (within 3 %); `return_delay_raw`: Return Delay Time register (2 µs units).
// Servos start at 0 rad. Throws std::invalid_argument for an unknown model or a value the model's
// registers cannot hold.
BuiltDevice make_protocol1_device(std::string_view model, uint8_t id, uint32_t baud_bps,
                                  uint8_t return_delay_raw = 250);

}  // namespace doppel::dynamixel
