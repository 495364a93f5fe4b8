// The physics body: the servo drive loop against the physics world, what the servos measure
// (signed motor current, the controller's overload), and the supply current a power board in the
// servo supply sees, checked against the XM430-W350 datasheet: 4.1 N·m stall torque at 12 V,
// drawing 2.3 A (reference §5).

#include "body/physics_body.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>

#include "../physics/rigs.h"
#include "dynamixel/bitbots_boards.h"

namespace doppel::body {
namespace {

constexpr double kStallCurrentA = 2.3;  // XM430-W350 at 12 V (datasheet)
constexpr double kSupplyV = 12.0;

// An XM430-W350 against the stops of tests/physics/rigs.h's stall rig, on a 12 V bus.
std::unique_ptr<physics::World> stall_rig(const std::string& engine) {
  physics::WorldOptions options = physics::test::bare_options();
  options.hold = physics::HoldMode::kReleased;
  const std::string bus =
      R"(baud_bps: 4000000 protocol: PROTOCOL_2 supply_voltage_v: 12.0 device { id: 1 model: "XM430-W350" name: "J" })";
  return physics::test::make_world(engine, {physics::test::robot_from_text(physics::test::stall_rig(bus))}, options);
}

ServoSetup xm430_setup() {
  return ServoSetup{dynamixel::servo_controller_config("XM430-W350"), 0.0, kSupplyV};
}

dynamixel::ServoCommand goal(double position_rad) {
  dynamixel::ServoCommand command;
  command.torque_enabled = true;
  command.goal_position_rad = position_rad;
  command.min_position_rad = -M_PI;
  command.max_position_rad = M_PI;
  command.pid = dynamixel::x_pid_gains(800, 0, 0);  // XM430 factory Position P Gain
  return command;
}

// Runs the gateway's order for `seconds`: drive, step, read back.
dynamixel::ServoFeedback run(physics::World& world, PhysicsBody& sut, const dynamixel::ServoCommand& command,
                             double seconds) {
  dynamixel::ServoFeedback feedback;
  for (int i = 0; i < static_cast<int>(seconds * 1000.0); ++i) {
    sut.drive(0, command, world.options().step_s);
    world.step();
    feedback = sut.servo(0, world.time_ns());
  }
  return feedback;
}

double core_current_a(const dynamixel::PowerFeedback& power) {
  dynamixel::BitbotsCore core(42, 4);
  core.apply(power);
  const auto raw = static_cast<double>(core.table()[dynamixel::bitbots::kCurrent] |
                                       (core.table()[dynamixel::bitbots::kCurrent + 1] << 8));
  return (raw * 3.3 / 1024.0 - 2.5) / -0.066;  // the Bit-Bots driver's decoding (reference §8.4)
}

class PhysicsBodyTest : public ::testing::TestWithParam<std::string> {};

TEST_P(PhysicsBodyTest, StalledServoDrawsItsStallCurrentAndReportsOverload) {
  auto world = stall_rig(GetParam());
  PhysicsBody sut(*world, 0);
  ASSERT_EQ(sut.add_servo(0, 1, xm430_setup()), 0u);
  ASSERT_TRUE(sut.motor(0).has_value());

  // Goal far behind the +20 deg stop: the controller saturates and the motor stalls against it.
  const dynamixel::ServoFeedback pushing = run(*world, sut, goal(1.6), 1.5);

  EXPECT_NEAR(pushing.position_rad, 20.0 * M_PI / 180.0, 0.02);
  EXPECT_NEAR(pushing.current_a, kStallCurrentA, 0.05 * kStallCurrentA);
  EXPECT_NEAR(pushing.torque_ratio, 1.0, 0.02);
  EXPECT_NEAR(pushing.voltage_v, kSupplyV, 1e-9);
  EXPECT_TRUE(pushing.overload);  // saturated and stalled for more than the controller's 1 s
  EXPECT_EQ(pushing.sim_time_ns, world->time_ns());
  // At full duty into a stalled motor the H-bridge passes the supply current straight through.
  EXPECT_NEAR(sut.servo_supply_current_a(), kStallCurrentA, 0.05 * kStallCurrentA);
  // The CORE board in the supply shows it in its Current register, within one ADC count (0.05 A).
  EXPECT_NEAR(core_current_a({kSupplyV, sut.servo_supply_current_a(), world->time_ns()}), kStallCurrentA,
              0.05 * kStallCurrentA + 0.05);
}

TEST_P(PhysicsBodyTest, MotorCurrentIsSignedSupplyCurrentIsNot) {
  auto world = stall_rig(GetParam());
  PhysicsBody sut(*world, 0);
  sut.add_servo(0, 1, xm430_setup());

  // Against the -10 deg stop: the motor pushes CW, so its current is negative; the supply still
  // delivers the power.
  const dynamixel::ServoFeedback pushing = run(*world, sut, goal(-1.6), 1.5);

  EXPECT_NEAR(pushing.position_rad, -10.0 * M_PI / 180.0, 0.02);
  EXPECT_NEAR(pushing.current_a, -kStallCurrentA, 0.05 * kStallCurrentA);
  EXPECT_NEAR(sut.servo_supply_current_a(), kStallCurrentA, 0.05 * kStallCurrentA);
}

TEST_P(PhysicsBodyTest, TorqueOffDrawsNoCurrentAndClearsOverload) {
  auto world = stall_rig(GetParam());
  PhysicsBody sut(*world, 0);
  sut.add_servo(0, 1, xm430_setup());
  run(*world, sut, goal(1.6), 1.5);

  dynamixel::ServoCommand off = goal(1.6);
  off.torque_enabled = false;
  const dynamixel::ServoFeedback limp = run(*world, sut, off, 0.1);

  EXPECT_EQ(limp.current_a, 0.0);
  EXPECT_FALSE(limp.overload);
  EXPECT_EQ(sut.servo_supply_current_a(), 0.0);
  EXPECT_NEAR(core_current_a({kSupplyV, sut.servo_supply_current_a(), world->time_ns()}), 0.0, 0.05);
}

TEST_P(PhysicsBodyTest, DevicesTheFigureLacksMoveAndReadKinematically) {
  auto world = stall_rig(GetParam());
  PhysicsBody sut(*world, 0);
  const ServoSetup setup{dynamixel::servo_controller_config("XM430-W350"), 6.0, 12.0};
  const std::size_t servo = sut.add_servo(0, 7, setup);
  const std::size_t imu = sut.add_imu(0, 241);
  const std::size_t foot = sut.add_foot(0, 101);
  EXPECT_FALSE(sut.motor(servo).has_value());

  for (int i = 0; i < 100; ++i) {
    sut.drive(servo, goal(1.0), 0.001);
    world->step();
  }

  EXPECT_NEAR(sut.servo(servo, world->time_ns()).position_rad, 0.6, 1e-9);  // 6 rad/s for 0.1 s
  EXPECT_EQ(sut.imu(imu, world->time_ns()).roll_rad, 0.0);
  EXPECT_EQ(sut.imu(imu, world->time_ns()).sim_time_ns, world->time_ns());
  EXPECT_NEAR(sut.foot(foot, 5).force_n[0], kKinematicRobotMassKg * kGravityM_S2 / 4.0, 1e-9);
  EXPECT_EQ(sut.servo_supply_current_a(), 0.0);  // no motor in the world
}

INSTANTIATE_TEST_SUITE_P(Engines, PhysicsBodyTest, ::testing::ValuesIn(physics::engine_names()),
                         [](const ::testing::TestParamInfo<std::string>& param) { return param.param; });

}  // namespace
}  // namespace doppel::body
