#include "body/physics_body.h"

#include "body/feedback.h"

namespace doppel::body {

std::size_t PhysicsBody::add_servo(uint32_t bus, uint8_t id, const ServoSetup& setup) {
  Slot<ServoDrive>& slot = servos_.emplace_back();
  if (const auto motor = world_.find_motor(robot_, bus, id)) {
    slot.in_world.emplace(*motor, setup.controller);
  } else {
    slot.kinematic = kinematic_.add_servo(bus, id, setup);
  }
  return servos_.size() - 1;
}

std::size_t PhysicsBody::add_imu(uint32_t bus, uint8_t id) {
  return add_sensor(imus_, world_.find_imu(robot_, bus, id), [&] { return kinematic_.add_imu(bus, id); });
}

std::size_t PhysicsBody::add_foot(uint32_t bus, uint8_t id) {
  return add_sensor(feet_, world_.find_foot(robot_, bus, id), [&] { return kinematic_.add_foot(bus, id); });
}

void PhysicsBody::reset() noexcept {
  for (Slot<ServoDrive>& slot : servos_) {
    if (slot.in_world) slot.in_world->reset(world_);
  }
  kinematic_.reset();
}

void PhysicsBody::drive(std::size_t servo, const dynamixel::ServoCommand& command, double dt_s) noexcept {
  if (servo >= servos_.size()) {
    return;
  }
  Slot<ServoDrive>& slot = servos_[servo];
  if (slot.in_world) {
    slot.in_world->drive(world_, command, dt_s);
  } else {
    kinematic_.drive(slot.kinematic, command, dt_s);
  }
}

dynamixel::ServoFeedback PhysicsBody::servo(std::size_t servo, int64_t sim_time_ns) const noexcept {
  if (servo >= servos_.size()) {
    return dynamixel::ServoFeedback{};
  }
  const Slot<ServoDrive>& slot = servos_[servo];
  return slot.in_world ? slot.in_world->sense(world_, sim_time_ns) : kinematic_.servo(slot.kinematic, sim_time_ns);
}

dynamixel::ImuFeedback PhysicsBody::imu(std::size_t imu, int64_t sim_time_ns) const noexcept {
  if (imu >= imus_.size()) {
    return dynamixel::ImuFeedback{};
  }
  const Slot<physics::ImuHandle>& slot = imus_[imu];
  return slot.in_world ? imu_feedback(world_.imu(*slot.in_world)) : kinematic_.imu(slot.kinematic, sim_time_ns);
}

dynamixel::FootFeedback PhysicsBody::foot(std::size_t foot, int64_t sim_time_ns) const noexcept {
  if (foot >= feet_.size()) {
    return dynamixel::FootFeedback{};
  }
  const Slot<physics::FootHandle>& slot = feet_[foot];
  return slot.in_world ? foot_feedback(world_.foot(*slot.in_world)) : kinematic_.foot(slot.kinematic, sim_time_ns);
}

double PhysicsBody::servo_supply_current_a() const noexcept {
  double total_a = 0.0;
  for (const Slot<ServoDrive>& slot : servos_) {
    if (slot.in_world) {
      total_a += world_.motor(slot.in_world->motor()).supply_current_a;
    }
  }
  return total_a;
}

std::optional<physics::MotorHandle> PhysicsBody::motor(std::size_t servo) const noexcept {
  if (servo >= servos_.size() || !servos_[servo].in_world) {
    return std::nullopt;
  }
  return servos_[servo].in_world->motor();
}

}  // namespace doppel::body
