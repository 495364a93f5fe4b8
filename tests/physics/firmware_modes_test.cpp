// The firmware's torque, current and velocity modes against physics: a goal current gives the
// torque kt x I the datasheet implies (kt = stall torque / stall current, reference §5), at rest and
// while the motor turns (the controller compensates the back-EMF); X velocity mode reaches and holds
// its Goal Velocity against gear friction through the Velocity I Gain.

#include <gtest/gtest.h>

#include <cctype>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "dynamixel/servo_controller.h"
#include "rigs.h"

namespace doppel::physics {
namespace {

using test::make_world;
using test::robot_from_text;

constexpr double kRpm = 2.0 * std::numbers::pi / 60.0;
// A 1 kg m^2 flywheel (20 kg, radius 0.316 m) on a vertical axis: gravity does not load the motor
// and the torque is I x dw/dt.
constexpr double kFlywheelInertia = 0.5 * 20.0 * 0.316228 * 0.316228;

std::string rig(const std::string& protocol, const std::string& model, const std::string& rotor) {
  return R"(name: "rig"
bus { name: "b" baud_bps: 1000000 protocol: )" + protocol + R"( device { id: 1 model: ")" + model + R"(" name: "J" } }
figure {
  body { name: "base" pose { position_m { z: 0.05 } } shape { box { size_m { x: 0.8 y: 0.8 z: 0.1 } } } mass_kg: 100 }
  body { name: "rotor" pose { position_m { z: 0.2 } } )" + rotor + R"( }
  link { name: "J" type: LINK_REVOLUTE parent: "base" child: "rotor" anchor_m { z: 0.1 } axis { z: 1 }
         motor { bus: 0 id: 1 } }
})";
}

const char* const kFlywheel = "shape { cylinder { radius_m: 0.316228 length_m: 0.02 } } mass_kg: 20";

struct CurrentCase {
  std::string engine;
  std::string protocol;
  std::string model;
  double stall_nm;  // reference §5, 12 V
  double stall_a;
  double goal_a;
};

class CurrentModeTest : public ::testing::TestWithParam<CurrentCase> {};

TEST_P(CurrentModeTest, GoalCurrentGivesKtTimesCurrentAtRestAndInMotion) {
  const CurrentCase& p = GetParam();
  auto world = make_world(p.engine, {robot_from_text(rig(p.protocol, p.model, kFlywheel))});
  test::DrivenRobot firmware(*world, 0);
  firmware.enable_all();
  firmware.command(0).torque_control = true;
  firmware.command(0).goal_current_a = p.goal_a;
  const double expected_nm = p.stall_nm / p.stall_a * p.goal_a;

  firmware.run(0.2);
  const double w1 = world->motor(firmware.handle(0)).velocity_rad_s;
  firmware.run(0.8);
  const double w2 = world->motor(firmware.handle(0)).velocity_rad_s;

  EXPECT_NEAR(kFlywheelInertia * w1 / 0.2, expected_nm, 0.02 * expected_nm);
  // Turning at w2 the back-EMF ke w takes volts that open-loop duty would lose; the current holds.
  EXPECT_GT(w2, 0.5);
  EXPECT_NEAR(kFlywheelInertia * (w2 - w1) / 0.8, expected_nm, 0.02 * expected_nm);
  EXPECT_NEAR(world->motor(firmware.handle(0)).current_a, p.goal_a, 0.02 * p.goal_a);
}

std::vector<CurrentCase> current_cases() {
  std::vector<CurrentCase> cases;
  for (const std::string& engine : engine_names()) {
    cases.push_back({engine, "PROTOCOL_1", "MX-64", 6.0, 4.1, 1.0});        // Goal Torque (Torque Ctrl Mode)
    cases.push_back({engine, "PROTOCOL_2", "XM430-W350", 4.1, 2.3, 0.5});  // Operating Mode 0
  }
  return cases;
}

INSTANTIATE_TEST_SUITE_P(Servos, CurrentModeTest, ::testing::ValuesIn(current_cases()),
                         [](const ::testing::TestParamInfo<CurrentCase>& param) {
                           std::string name = param.param.engine + "_" + param.param.model;
                           for (char& c : name) {
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           }
                           return name;
                         });

class VelocityModeTest : public ::testing::TestWithParam<std::string> {};

// XM430-W350 in velocity mode with its factory Velocity P/I Gains (100 / 1920, reference §3.7),
// a 200 g rotor, gear friction also while powered (the load).
double speed_after(const std::string& engine, uint16_t velocity_i_gain_raw, double seconds, double goal_rad_s) {
  WorldOptions options = test::bare_options();
  options.powered_gear_friction = true;
  auto world = make_world(engine,
                          {robot_from_text(rig("PROTOCOL_2", "XM430-W350",
                                               "shape { cylinder { radius_m: 0.05 length_m: 0.02 } } mass_kg: 0.2"))},
                          options);
  test::DrivenRobot firmware(*world, 0);
  firmware.enable_all();
  dynamixel::ServoCommand& command = firmware.command(0);
  command.wheel_mode = true;
  command.velocity_control = true;
  command.velocity_pi = dynamixel::x_velocity_pi_gains(100, velocity_i_gain_raw);
  command.moving_speed_rad_s = goal_rad_s;
  firmware.run(seconds);
  return world->motor(firmware.handle(0)).velocity_rad_s;
}

TEST_P(VelocityModeTest, ReachesAndHoldsTheGoalVelocityThroughTheIGain) {
  const double goal = 50 * 0.229 * kRpm;  // Goal Velocity 50 = 11.45 rpm

  const double at_2_s = speed_after(GetParam(), 1920, 2.0, goal);
  const double at_4_s = speed_after(GetParam(), 1920, 4.0, goal);
  const double reverse = speed_after(GetParam(), 1920, 2.0, -goal);
  // Without the I gain the P gain alone (KvP = 100 / 128 PWM units per 0.229 rpm) leaves the
  // rotor far below the goal: about a fifth of it on the motor line (ke ~ 2.5 V s/rad, 14.8 V).
  const double p_only = speed_after(GetParam(), 0, 2.0, goal);

  EXPECT_NEAR(at_2_s, goal, 0.02 * goal);
  EXPECT_NEAR(at_4_s, goal, 0.02 * goal);
  EXPECT_NEAR(reverse, -goal, 0.02 * goal);
  EXPECT_LT(p_only, 0.4 * goal);
  EXPECT_GT(p_only, 0.0);
}

INSTANTIATE_TEST_SUITE_P(Engines, VelocityModeTest, ::testing::ValuesIn(engine_names()),
                         [](const ::testing::TestParamInfo<std::string>& param) { return param.param; });

}  // namespace
}  // namespace doppel::physics
