#pragma once
// The body of a robot without a simulated one: each servo a kinematic joint (body/kinematic_joint.h),
// the IMUs level and at rest, the robot's weight spread evenly over the load cells of its foot
// boards as when it stands still, no motor currents (no motor model).

#include <vector>

#include "body/kinematic_joint.h"
#include "body/simulated_body.h"

namespace doppel::body {

// Mass the foot boards of a robot without a body carry (the 2011 KidSize robot: 21 servos of
// 72-125 g plus frame, electronics and battery).
inline constexpr double kKinematicRobotMassKg = 4.0;
inline constexpr double kGravityM_S2 = 9.80665;

class KinematicBody final : public SimulatedBody {
 public:
  explicit KinematicBody(double mass_kg = kKinematicRobotMassKg) : mass_kg_(mass_kg) {}

  std::size_t add_servo(uint32_t bus, uint8_t id, const ServoSetup& setup) override;
  std::size_t add_imu(uint32_t bus, uint8_t id) override;
  std::size_t add_foot(uint32_t bus, uint8_t id) override;

  void drive(std::size_t servo, const dynamixel::ServoCommand& command, double dt_s) noexcept override;
  dynamixel::ServoFeedback servo(std::size_t servo, int64_t sim_time_ns) const noexcept override;
  dynamixel::ImuFeedback imu(std::size_t imu, int64_t sim_time_ns) const noexcept override;
  // Each cell carries mass x g / (4 x the number of foot boards added).
  dynamixel::FootFeedback foot(std::size_t foot, int64_t sim_time_ns) const noexcept override;
  double servo_supply_current_a() const noexcept override { return 0.0; }
  void reset() noexcept override;
  std::string_view description() const noexcept override { return "no body: joints move kinematically"; }

 private:
  struct Servo {
    KinematicJoint joint;
    double supply_voltage_v;
  };
  double mass_kg_;
  std::vector<Servo> servos_;
  std::size_t foot_boards_ = 0;
};

}  // namespace doppel::body
