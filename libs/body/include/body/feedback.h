#pragma once
// The one conversion between the physics world's readouts (physics/world.h, plain structs of a
// library that knows no device) and what the devices measure (dynamixel/device_io.h). rt-safe.

#include <cstdint>

#include "dynamixel/device_io.h"
#include "physics/world.h"

namespace doppel::body {

// A motor's state as its servo measures it; `overload` is the firmware controller's verdict
// (dynamixel::ControllerOutput::overload).
dynamixel::ServoFeedback servo_feedback(const physics::MotorState& motor, bool overload, int64_t sim_time_ns) noexcept;
dynamixel::ImuFeedback imu_feedback(const physics::ImuState& imu) noexcept;
dynamixel::FootFeedback foot_feedback(const physics::FootState& foot) noexcept;

}  // namespace doppel::body
