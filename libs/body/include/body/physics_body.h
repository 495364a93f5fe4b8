#pragma once
// A robot's body in the physics world: each servo drives its motor through the drive loop
// (body/servo_drive.h), IMUs and foot boards read their sensors in the world. A device the robot's
// figure does not have (no motor, IMU or foot for its bus and ID) moves or reads as in a
// KinematicBody. The world is stepped by its owner (one world holds every robot), between drive()
// and the readouts.

#include <optional>
#include <vector>

#include "body/kinematic_body.h"
#include "body/servo_drive.h"
#include "body/simulated_body.h"
#include "physics/world.h"

namespace doppel::body {

class PhysicsBody final : public SimulatedBody {
 public:
  // Robot `robot` of `world`; the world outlives the body.
  PhysicsBody(physics::World& world, std::size_t robot) noexcept : world_(world), robot_(robot) {}

  std::size_t add_servo(uint32_t bus, uint8_t id, const ServoSetup& setup) override;
  std::size_t add_imu(uint32_t bus, uint8_t id) override;
  std::size_t add_foot(uint32_t bus, uint8_t id) override;

  void drive(std::size_t servo, const dynamixel::ServoCommand& command, double dt_s) noexcept override;
  dynamixel::ServoFeedback servo(std::size_t servo, int64_t sim_time_ns) const noexcept override;
  dynamixel::ImuFeedback imu(std::size_t imu, int64_t sim_time_ns) const noexcept override;
  dynamixel::FootFeedback foot(std::size_t foot, int64_t sim_time_ns) const noexcept override;
  // Sum of the motors' supply currents (physics::MotorState::supply_current_a) of the servos added.
  double servo_supply_current_a() const noexcept override;
  void reset() noexcept override;
  std::string_view description() const noexcept override { return "body simulated"; }

  // The servo's motor in the world; nullopt when its joint moves kinematically.
  std::optional<physics::MotorHandle> motor(std::size_t servo) const noexcept;

 private:
  // A device in the world, or its index in the kinematic stand-in.
  template <typename InWorld>
  struct Slot {
    std::optional<InWorld> in_world;
    std::size_t kinematic = 0;
  };

  // A sensor in the world if the figure has it, else the kinematic stand-in's (add_kinematic()).
  template <typename Handle, typename AddKinematic>
  static std::size_t add_sensor(std::vector<Slot<Handle>>& slots, std::optional<Handle> in_world,
                                AddKinematic add_kinematic) {
    slots.push_back(Slot<Handle>{in_world, in_world ? 0 : add_kinematic()});
    return slots.size() - 1;
  }

  physics::World& world_;
  std::size_t robot_;
  std::vector<Slot<ServoDrive>> servos_;
  std::vector<Slot<physics::ImuHandle>> imus_;
  std::vector<Slot<physics::FootHandle>> feet_;
  KinematicBody kinematic_;  // devices the figure lacks
};

}  // namespace doppel::body
