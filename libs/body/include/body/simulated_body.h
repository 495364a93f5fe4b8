#pragma once
// The body the gateway drives, whatever moves it: the physics world (PhysicsBody) or, for a robot
// without one, kinematic joints (KinematicBody). The gateway links each simulated device of the
// robot to the body once at setup, then on the simulation thread hands it every servo's command
// before the world steps and reads back what every device measures after the step; it never asks
// which kind of body it has. Indices returned by the add_* calls are per kind and stable.

#include <cstddef>
#include <cstdint>
#include <string_view>

#include "dynamixel/device_io.h"
#include "dynamixel/servo_controller.h"

namespace doppel::body {

// What the body needs to know about one servo.
struct ServoSetup {
  dynamixel::ServoControllerConfig controller;  // the firmware's motor controller of the servo's model
  double no_load_speed_rad_s = 0.0;             // top speed at the supply (a joint moved kinematically)
  double supply_voltage_v = 14.8;               // the servo's bus supply (a joint moved kinematically)
};

class SimulatedBody {
 public:
  virtual ~SimulatedBody() = default;

  // Setup (allocates): links the device with `id` on bus `bus` of the robot to the body and returns
  // its index among the body's devices of that kind.
  virtual std::size_t add_servo(uint32_t bus, uint8_t id, const ServoSetup& setup) = 0;
  virtual std::size_t add_imu(uint32_t bus, uint8_t id) = 0;
  virtual std::size_t add_foot(uint32_t bus, uint8_t id) = 0;

  // Simulation thread, before the world steps: servo `servo` acts on `command` for `dt_s`. rt-safe.
  virtual void drive(std::size_t servo, const dynamixel::ServoCommand& command, double dt_s) noexcept = 0;

  // Simulation thread, after the world stepped: what the devices measure at `sim_time_ns`. rt-safe.
  virtual dynamixel::ServoFeedback servo(std::size_t servo, int64_t sim_time_ns) const noexcept = 0;
  virtual dynamixel::ImuFeedback imu(std::size_t imu, int64_t sim_time_ns) const noexcept = 0;
  virtual dynamixel::FootFeedback foot(std::size_t foot, int64_t sim_time_ns) const noexcept = 0;
  // The current the robot's servos together draw from their supply, A (what a power board in the
  // servo supply measures). rt-safe.
  virtual double servo_supply_current_a() const noexcept = 0;

  // Power-on of every servo of the body (a simulation reset): the firmware controllers forget
  // their state and kinematic joints return to where they started. Call it after the world has put
  // the robot back (World::reset_robot). Simulation thread, rt-safe.
  virtual void reset() noexcept = 0;

  // What moves the joints, for the user ("body simulated", ...).
  virtual std::string_view description() const noexcept = 0;
};

}  // namespace doppel::body
