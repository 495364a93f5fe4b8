// A single servo on both engines: the DC-motor model's no-load speed and stall torque reach the
// rigid body through the engine, the Torque Limit caps the torque, torque off leaves the joint limp.

#include <gtest/gtest.h>

#include <cmath>
#include <utility>

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
// Gear friction: Coulomb 2 % of the 5.3 N m stall torque, viscous 2 % of it at the datasheet's
// no-load speed (64 rpm at 18.5 V).
constexpr double kCoulomb = 0.02 * 5.3;
constexpr double kViscous = 0.02 * 5.3 / (64.0 * 2.0 * M_PI / 60.0);
constexpr double kDamping = kKt * kKe / kR;  // b of the motor law
// Datasheet no-load speed at the supply: 53.2 rpm at 15 V (reference, S7).
constexpr double kDatasheetNoLoad = 53.2 * 2.0 * M_PI / 60.0 * kSupply / 15.0;

class ServoTest : public ::testing::TestWithParam<std::string> {};

// A horizontal arm along x on a post, turning about y at its root, driven by one RX-64; nothing
// holds it (released at start). Its weight pulls with m g L / 2 about the joint.
std::unique_ptr<World> make_pendulum(const std::string& engine, double arm_length_m, double arm_mass_kg) {
  const std::string rig = R"(name: "pendulum"
bus { name: "b" baud_bps: 1000000 protocol: PROTOCOL_1 device { id: 1 model: "RX-64" name: "J" } }
figure {
  body { name: "base" pose { position_m { z: 0.05 } } shape { box { size_m { x: 0.6 y: 0.6 z: 0.1 } } } mass_kg: 80 }
  body { name: "post" pose { position_m { z: 0.35 } } shape { box { size_m { x: 0.04 y: 0.04 z: 0.5 } } } mass_kg: 1 }
  body { name: "arm" pose { position_m { x: )" + std::to_string(arm_length_m / 2.0) + R"( y: 0.05 z: 0.5 } }
         shape { box { size_m { x: )" + std::to_string(arm_length_m) + R"( y: 0.02 z: 0.02 } } } mass_kg: )" +
                          std::to_string(arm_mass_kg) + R"( }
  link { name: "fix" type: LINK_FIXED parent: "base" child: "post" }
  link { name: "J" type: LINK_REVOLUTE parent: "post" child: "arm" anchor_m { y: 0.05 z: 0.5 } axis { y: 1 }
         motor { bus: 0 id: 1 } }
})";
  WorldOptions options = test::bare_options();
  options.hold = HoldMode::kReleased;
  return make_world(engine, {robot_from_text(rig)}, options);
}

// These tests model the gear friction while powered too (WorldOptions::powered_gear_friction).
WorldOptions friction_options() {
  WorldOptions options = test::bare_options();
  options.powered_gear_friction = true;
  return options;
}

TEST_P(ServoTest, UnloadedServoReachesTheNoLoadSpeed) {
  // A light rotor: 50 g disc of 3 cm radius.
  auto world = make_world(GetParam(), {robot_from_text(servo_rig(
                                          "shape { cylinder { radius_m: 0.03 length_m: 0.02 } } mass_kg: 0.05"))},
                          friction_options());
  const MotorHandle sut = *world->find_motor(0, 0, 1);
  world->set_motor(sut, MotorCommand{true, 1.0, 1.0});

  for (int i = 0; i < 500; ++i) world->step();

  // The motor's torque b (V/ke - w) equals the gear friction Fc + Fv w.
  const double no_load = (kDamping * kSupply / kKe - kCoulomb) / (kDamping + kViscous);
  EXPECT_NEAR(world->motor(sut).velocity_rad_s, kDatasheetNoLoad, 0.10 * kDatasheetNoLoad);
  EXPECT_NEAR(world->motor(sut).velocity_rad_s, no_load, 0.01 * no_load);
  EXPECT_NEAR(world->motor(sut).torque_nm, kCoulomb + kViscous * no_load, 0.02 * kCoulomb);  // no-load current
}

TEST_P(ServoTest, StalledServoDeliversTheStallTorque) {
  // A 1 kg m^2 flywheel (20 kg, radius 0.316 m): for 0.1 s it barely turns, so the motor is at stall
  // and the torque the engine applied is I * dw / dt.
  auto world = make_world(GetParam(), {robot_from_text(servo_rig(
                                          "shape { cylinder { radius_m: 0.316228 length_m: 0.02 } } mass_kg: 20"))},
                          friction_options());
  const MotorHandle sut = *world->find_motor(0, 0, 1);
  world->set_motor(sut, MotorCommand{true, 1.0, 1.0});

  for (int i = 0; i < 100; ++i) world->step();

  const double inertia = 0.5 * 20.0 * 0.316228 * 0.316228;
  const double measured = inertia * world->motor(sut).velocity_rad_s / 0.1;
  const double model_stall = std::min(kKt * kSupply / kR, kStallCap);  // DC line, capped by Torque Limit 100 %
  EXPECT_NEAR(measured, model_stall, 0.10 * model_stall);
  EXPECT_NEAR(measured, model_stall - kCoulomb, 0.01 * model_stall);  // the gear's friction takes its share
  EXPECT_NEAR(world->motor(sut).torque_nm, model_stall, 1e-9);
  EXPECT_NEAR(world->motor(sut).torque_ratio, 1.0, 1e-9);
  EXPECT_NEAR(world->motor(sut).current_a, model_stall / kKt, 1e-9);  // winding current, + with the CCW torque
}

TEST_P(ServoTest, TorqueLimitScalesTheStallTorque) {
  auto world = make_world(GetParam(), {robot_from_text(servo_rig(
                                          "shape { cylinder { radius_m: 0.316228 length_m: 0.02 } } mass_kg: 20"))},
                          friction_options());
  const MotorHandle sut = *world->find_motor(0, 0, 1);
  world->set_motor(sut, MotorCommand{true, -1.0, 0.5});

  for (int i = 0; i < 100; ++i) world->step();

  const double measured = 1.0 * world->motor(sut).velocity_rad_s / 0.1;
  EXPECT_NEAR(measured, -0.5 * kStallCap + kCoulomb, 0.01 * kStallCap);
}

TEST_P(ServoTest, BelowTheCapTheTorqueFollowsTheDcMotorLine) {
  // 5 % duty: kt V / R = 3.2 * 0.74 / 0.75 = 3.16 N m, under the 4.24 N m cap.
  auto world = make_world(GetParam(), {robot_from_text(servo_rig(
                                          "shape { cylinder { radius_m: 0.316228 length_m: 0.02 } } mass_kg: 20"))},
                          friction_options());
  const MotorHandle sut = *world->find_motor(0, 0, 1);
  world->set_motor(sut, MotorCommand{true, 0.05, 1.0});

  for (int i = 0; i < 20; ++i) world->step();

  const double w = world->motor(sut).velocity_rad_s;
  const double measured = 1.0 * w / 0.02;
  // At the mean speed of the interval, less the gear friction.
  const double expected = kKt * (0.05 * kSupply - kKe * 0.5 * w) / kR - kCoulomb - kViscous * 0.5 * w;
  EXPECT_NEAR(measured, expected, 0.05 * expected);
}

TEST_P(ServoTest, TorqueOffLeavesTheJointLimp) {
  // A horizontal pendulum arm about y: 0.5 kg at 0.15 m needs 0.74 N m, far more than gear friction.
  auto world = make_pendulum(GetParam(), 0.3, 0.5);
  test::DrivenRobot driven(*world, 0);

  driven.enable_all();
  driven.run(0.5);
  const double held = world->motor(driven.handle(0)).position_rad;
  driven.disable_all();
  driven.run(0.5);
  const double limp = world->motor(driven.handle(0)).position_rad;

  EXPECT_NEAR(held, 0.0, 2.0 * 0.29 * M_PI / 180.0);  // within two position units of the goal
  EXPECT_GT(limp, 0.5);                               // swung down (about +y: the arm's tip goes down)
}

TEST_P(ServoTest, EachMotorRunsOnItsBusSupplyVoltage) {
  // Two unloaded rotors, each servo on its own bus: 12 V and 16 V; the world's default is 14.8 V.
  const std::string rig = R"(name: "two-buses"
bus { name: "a" baud_bps: 1000000 protocol: PROTOCOL_1 supply_voltage_v: 12 device { id: 1 model: "RX-64" name: "A" } }
bus { name: "b" baud_bps: 1000000 protocol: PROTOCOL_1 supply_voltage_v: 16 device { id: 1 model: "RX-64" name: "B" } }
figure {
  body { name: "base" pose { position_m { z: 0.05 } } shape { box { size_m { x: 0.6 y: 0.6 z: 0.1 } } } mass_kg: 80 }
  body { name: "ra" pose { position_m { x: -0.1 z: 0.11 } } shape { cylinder { radius_m: 0.03 length_m: 0.02 } } mass_kg: 0.05 }
  body { name: "rb" pose { position_m { x: 0.1 z: 0.11 } } shape { cylinder { radius_m: 0.03 length_m: 0.02 } } mass_kg: 0.05 }
  link { name: "A" type: LINK_REVOLUTE parent: "base" child: "ra" anchor_m { x: -0.1 z: 0.1 } axis { z: 1 } motor { bus: 0 id: 1 } }
  link { name: "B" type: LINK_REVOLUTE parent: "base" child: "rb" anchor_m { x: 0.1 z: 0.1 } axis { z: 1 } motor { bus: 1 id: 1 } }
})";
  auto world = make_world(GetParam(), {robot_from_text(rig)}, friction_options());
  const MotorHandle a = *world->find_motor(0, 0, 1);
  const MotorHandle b = *world->find_motor(0, 1, 1);
  world->set_motor(a, MotorCommand{true, 1.0, 1.0});
  world->set_motor(b, MotorCommand{true, 1.0, 1.0});

  for (int i = 0; i < 500; ++i) world->step();

  for (const auto& [motor, volts] : {std::pair{a, 12.0}, std::pair{b, 16.0}}) {
    const double no_load = (kDamping * volts / kKe - kCoulomb) / (kDamping + kViscous);
    EXPECT_NEAR(world->motor(motor).velocity_rad_s, no_load, 0.01 * no_load) << volts << " V";
    EXPECT_EQ(world->motor(motor).voltage_v, volts);
    EXPECT_NEAR(world->motor(motor).torque_ratio * 5.3 * volts / 18.5, world->motor(motor).torque_nm, 1e-9);
  }
}

TEST_P(ServoTest, GearFrictionHoldsAnUnpoweredJointAgainstASmallLoad) {
  // A horizontal arm about y whose weight pulls with 0.05 N m, less than the 0.106 N m of Coulomb
  // friction: with torque off it stays; the same arm with 0.5 kg (0.74 N m) swings down (above).
  auto world = make_pendulum(GetParam(), 0.2, 0.051);

  for (int i = 0; i < 500; ++i) world->step();

  EXPECT_NEAR(world->link_position(0, 1), 0.0, 0.01);
}

// An MX-28 at P 32 (the DARwIn-OP framework's gain) holding a horizontal arm, 0.2 m and 1 kg, on
// a 12 V bus. Static: the duty is 0.158 x P x error in rad (Rhoban's oscilloscope measurement of the
// MX PID, Rhoban/bam bam/dynamixel/actuator.py), the torque at rest that duty of the 2.5 N m stall
// torque at 12 V (e-Manual); the arm sags until that torque carries m g L/2 cos(sag).
TEST_P(ServoTest, MxHoldsALoadWithTheStiffnessMeasuredOnItsPid) {
  const std::string rig = R"(name: "mx-arm"
bus { name: "b" baud_bps: 1000000 protocol: PROTOCOL_1 supply_voltage_v: 12 device { id: 1 model: "MX-28" name: "J" } }
figure {
  body { name: "base" pose { position_m { z: 0.05 } } shape { box { size_m { x: 0.6 y: 0.6 z: 0.1 } } } mass_kg: 80 }
  body { name: "post" pose { position_m { z: 0.35 } } shape { box { size_m { x: 0.04 y: 0.04 z: 0.5 } } } mass_kg: 1 }
  body { name: "arm" pose { position_m { x: 0.1 y: 0.05 z: 0.5 } } shape { box { size_m { x: 0.2 y: 0.02 z: 0.02 } } } mass_kg: 1 }
  link { name: "fix" type: LINK_FIXED parent: "base" child: "post" }
  link { name: "J" type: LINK_REVOLUTE parent: "post" child: "arm" anchor_m { y: 0.05 z: 0.5 } axis { y: 1 }
         motor { bus: 0 id: 1 } }
})";
  WorldOptions options = test::bare_options();
  options.hold = HoldMode::kReleased;
  auto world = make_world(GetParam(), {robot_from_text(rig)}, options);
  test::DrivenRobot driven(*world, 0);  // MX P 32, I 0, D 0
  driven.enable_all();

  driven.run(2.0);

  const double stiffness_nm_rad = 2.5 * 0.158 * 32.0;  // 12.64 N m/rad
  const double load_nm = 1.0 * 9.80665 * 0.1;
  double sag = 0.0;
  for (int i = 0; i < 20; ++i) sag = load_nm * std::cos(sag) / stiffness_nm_rad;  // 0.0775 rad, 4.4 deg
  EXPECT_NEAR(std::fabs(world->link_position(0, 1)), sag, 0.02 * sag);
  EXPECT_NEAR(world->motor(driven.handle(0)).velocity_rad_s, 0.0, 1e-3);
}

INSTANTIATE_TEST_SUITE_P(Engines, ServoTest, ::testing::ValuesIn(engine_names()),
                         [](const ::testing::TestParamInfo<std::string>& param) { return param.param; });

}  // namespace
}  // namespace doppel::physics
