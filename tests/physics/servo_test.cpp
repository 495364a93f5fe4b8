// A single servo on both engines: the DC-motor model's no-load speed and stall torque reach the
// rigid body through the engine, the Torque Limit caps the torque, torque off leaves the joint limp.

#include <gtest/gtest.h>

#include <cmath>

#include "rigs.h"

namespace doppel::physics {
namespace {

using test::make_world;
using test::robot_from_text;
using test::servo_rig;

// RX-64 in the thesis' Table 7 at the FUmanoid supply of 14.8 V.
constexpr double kSupply = 14.8;
constexpr double kKe = 2.82, kR = 0.75, kKt = 3.2;
constexpr double kStallCap = 5.3 * kSupply / 18.5;  // datasheet stall torque scaled to the supply

class ServoTest : public ::testing::TestWithParam<std::string> {};

TEST_P(ServoTest, UnloadedServoReachesTheNoLoadSpeed) {
  // A light rotor: 50 g disc of 3 cm radius.
  auto world = make_world(GetParam(), {robot_from_text(servo_rig(
                                          "shape { cylinder { radius_m: 0.03 length_m: 0.02 } } mass_kg: 0.05"))});
  const MotorHandle sut = *world->find_motor(0, 0, 1);
  world->set_motor(sut, MotorCommand{true, 1.0, 1.0});

  for (int i = 0; i < 500; ++i) world->step();

  const double no_load = kSupply / kKe;  // w0 = V / ke
  EXPECT_NEAR(world->motor(sut).velocity_rad_s, no_load, 0.10 * no_load);
  EXPECT_NEAR(world->motor(sut).velocity_rad_s, no_load, 0.01 * no_load);
}

TEST_P(ServoTest, StalledServoDeliversTheStallTorque) {
  // A 1 kg m^2 flywheel (20 kg, radius 0.316 m): for 0.1 s it barely turns, so the motor is at stall
  // and the torque the engine applied is I * dw / dt.
  auto world = make_world(GetParam(), {robot_from_text(servo_rig(
                                          "shape { cylinder { radius_m: 0.316228 length_m: 0.02 } } mass_kg: 20"))});
  const MotorHandle sut = *world->find_motor(0, 0, 1);
  world->set_motor(sut, MotorCommand{true, 1.0, 1.0});

  for (int i = 0; i < 100; ++i) world->step();

  const double inertia = 0.5 * 20.0 * 0.316228 * 0.316228;
  const double measured = inertia * world->motor(sut).velocity_rad_s / 0.1;
  const double model_stall = std::min(kKt * kSupply / kR, kStallCap);  // DC line, capped by Torque Limit 100 %
  EXPECT_NEAR(measured, model_stall, 0.10 * model_stall);
  EXPECT_NEAR(world->motor(sut).torque_nm, model_stall, 1e-9);
  EXPECT_NEAR(world->motor(sut).torque_ratio, 1.0, 1e-9);
}

TEST_P(ServoTest, TorqueLimitScalesTheStallTorque) {
  auto world = make_world(GetParam(), {robot_from_text(servo_rig(
                                          "shape { cylinder { radius_m: 0.316228 length_m: 0.02 } } mass_kg: 20"))});
  const MotorHandle sut = *world->find_motor(0, 0, 1);
  world->set_motor(sut, MotorCommand{true, -1.0, 0.5});

  for (int i = 0; i < 100; ++i) world->step();

  const double measured = 1.0 * world->motor(sut).velocity_rad_s / 0.1;
  EXPECT_NEAR(measured, -0.5 * kStallCap, 0.05 * kStallCap);
}

TEST_P(ServoTest, BelowTheCapTheTorqueFollowsTheDcMotorLine) {
  // 5 % duty: kt V / R = 3.2 * 0.74 / 0.75 = 3.16 N m, under the 4.24 N m cap.
  auto world = make_world(GetParam(), {robot_from_text(servo_rig(
                                          "shape { cylinder { radius_m: 0.316228 length_m: 0.02 } } mass_kg: 20"))});
  const MotorHandle sut = *world->find_motor(0, 0, 1);
  world->set_motor(sut, MotorCommand{true, 0.05, 1.0});

  for (int i = 0; i < 20; ++i) world->step();

  const double w = world->motor(sut).velocity_rad_s;
  const double measured = 1.0 * w / 0.02;
  const double expected = kKt * (0.05 * kSupply - kKe * 0.5 * w) / kR;  // at the mean speed of the interval
  EXPECT_NEAR(measured, expected, 0.05 * expected);
}

TEST_P(ServoTest, TorqueOffLeavesTheJointLimp) {
  // A horizontal pendulum arm about y: 0.5 kg at 0.15 m needs 0.74 N m, far more than gear friction.
  const std::string rig = R"(name: "pendulum"
bus { name: "b" baud_bps: 1000000 protocol: PROTOCOL_1 device { id: 1 model: "RX-64" name: "J" } }
figure {
  body { name: "base" pose { position_m { z: 0.05 } } shape { box { size_m { x: 0.6 y: 0.6 z: 0.1 } } } mass_kg: 80 }
  body { name: "post" pose { position_m { z: 0.35 } } shape { box { size_m { x: 0.04 y: 0.04 z: 0.5 } } } mass_kg: 1 }
  body { name: "arm" pose { position_m { x: 0.15 y: 0.05 z: 0.5 } } shape { box { size_m { x: 0.3 y: 0.02 z: 0.02 } } } mass_kg: 0.5 }
  link { name: "fix" type: LINK_FIXED parent: "base" child: "post" }
  link { name: "J" type: LINK_REVOLUTE parent: "post" child: "arm" anchor_m { y: 0.05 z: 0.5 } axis { y: 1 }
         motor { bus: 0 id: 1 } }
})";
  WorldOptions options = test::bare_options();
  options.hold = HoldMode::kReleased;
  auto world = make_world(GetParam(), {robot_from_text(rig)}, options);
  test::Firmware firmware(*world, 0);

  firmware.enable_all();
  firmware.run(0.5);
  const double held = world->motor(firmware.handle(0)).position_rad;
  firmware.disable_all();
  firmware.run(0.5);
  const double limp = world->motor(firmware.handle(0)).position_rad;

  EXPECT_NEAR(held, 0.0, 2.0 * 0.29 * M_PI / 180.0);  // within two position units of the goal
  EXPECT_GT(limp, 0.5);                               // swung down (about +y: the arm's tip goes down)
}

INSTANTIATE_TEST_SUITE_P(Engines, ServoTest, ::testing::ValuesIn(engine_names()),
                         [](const ::testing::TestParamInfo<std::string>& param) { return param.param; });

}  // namespace
}  // namespace doppel::physics
