#pragma once
// The one registry of device models: every model Doppel emulates is one entry in
// model_registry.cpp, with its model number, the protocol(s) its firmware speaks, its control
// table, its firmware's control law and gain units, and for servos its motor constants with their
// datasheet source. Everything else (devices, the motor controller, the physics glue in body/) asks
// here by name and never names a model itself. Lookups are setup code.

#include <string_view>

#include "dynamixel/models.h"
#include "dynamixel/protocol2_models.h"

namespace doppel::dynamixel {

// The servo spec of `model`, a Protocol 1.0 or 2.0 servo; nullptr for a board or an unknown name.
const ServoSpec* find_servo_spec(std::string_view model) noexcept;

// As find_servo_spec; throws std::invalid_argument naming `model` and the known servo models.
const ServoSpec& servo_spec(std::string_view model);

}  // namespace doppel::dynamixel
