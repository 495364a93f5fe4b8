// Self-collision: parts of one robot that no link joins collide (an arm driven into another part
// stops where they touch) on both engines; linked parts, and parts already touching in the initial
// pose, are exempt; Figure.self_collision: false turns it off.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include "rigs.h"

namespace doppel::physics {
namespace {

using test::make_world;
using test::robot_from_text;
using test::shipped_robot;

constexpr double kDeg = std::numbers::pi / 180.0;

// An upright arm (2 x 2 x 15 cm) on a hinge about x at y = +4 cm on top of a heavy base, and a post
// of the same size fixed to the base at y = -4 cm (heavy, so that its fixed link, solved iteratively
// like every joint, does not give way under the push). Turning the arm by +q swings its top toward
// the post.
std::string arm_and_post(const std::string& figure_extra = "", const std::string& link_extra = "") {
  return R"(name: "arm-and-post"
bus { name: "b" baud_bps: 1000000 protocol: PROTOCOL_1 device { id: 1 model: "RX-64" name: "L" } }
figure {
  body { name: "base" pose { position_m { z: 0.05 } } shape { box { size_m { x: 0.4 y: 0.4 z: 0.1 } } } mass_kg: 20 }
  body { name: "arm" pose { position_m { y: 0.04 z: 0.175 } } shape { box { size_m { x: 0.02 y: 0.02 z: 0.15 } } } mass_kg: 0.1 }
  body { name: "post" pose { position_m { y: -0.04 z: 0.175 } } shape { box { size_m { x: 0.02 y: 0.02 z: 0.15 } } } mass_kg: 5 }
  link { name: "L" type: LINK_REVOLUTE parent: "base" child: "arm" anchor_m { y: 0.04 z: 0.1 } axis { x: 1 }
         lower_deg: -90 upper_deg: 90 motor { bus: 0 id: 1 } )" + link_extra + R"( }
  link { name: "P" type: LINK_FIXED parent: "base" child: "post" }
  )" + figure_extra + R"(
})";
}

// Drives the arm toward the post at full voltage for 1 s; returns its final angle.
double push(World& world) {
  const MotorHandle arm = *world.find_motor(0, 0, 1);
  world.set_motor(arm, MotorCommand{true, 1.0, 1.0});
  for (int i = 0; i < 1000; ++i) world.step();
  return world.link_position(0, 0);
}

class SelfCollisionTest : public ::testing::TestWithParam<std::string> {};

TEST_P(SelfCollisionTest, AnArmDrivenIntoAnotherPartStopsWhereTheyTouch) {
  auto world = make_world(GetParam(), {robot_from_text(arm_and_post())});

  const double angle = push(*world);

  // The arm's inner top edge meets the post's face at y = -0.03: 0.04 - 0.01 cos q - 0.15 sin q = -0.03.
  const double touch = std::asin(0.07 / std::hypot(0.01, 0.15)) - std::atan2(0.01, 0.15);  // 23.9 deg
  EXPECT_NEAR(angle, touch, 1.0 * kDeg);
}

TEST_P(SelfCollisionTest, PartsPassThroughEachOtherWhenSelfCollisionIsOff) {
  auto world = make_world(GetParam(), {robot_from_text(arm_and_post("self_collision: false"))});

  const double angle = push(*world);

  EXPECT_GT(angle, 80.0 * kDeg);  // on to the 90 deg stop
}

INSTANTIATE_TEST_SUITE_P(Engines, SelfCollisionTest, ::testing::ValuesIn(engine_names()),
                         [](const ::testing::TestParamInfo<std::string>& param) { return param.param; });

bool exempt(const RobotModel& model, const std::string& a, const std::string& b) {
  auto index = [&](const std::string& name) {
    return static_cast<int>(std::find_if(model.bodies.begin(), model.bodies.end(),
                                         [&](const BodyModel& body) { return body.name == name; }) -
                            model.bodies.begin());
  };
  const std::pair<int, int> pair{std::min(index(a), index(b)), std::max(index(a), index(b))};
  return std::binary_search(model.collision_exempt.begin(), model.collision_exempt.end(), pair);
}

TEST(SelfCollisionExemption, LinkedBodiesAreExemptOthersCollide) {
  const RobotModel sut = robot_from_text(arm_and_post());

  EXPECT_TRUE(sut.self_collision);
  EXPECT_TRUE(exempt(sut, "base", "arm"));
  EXPECT_TRUE(exempt(sut, "base", "post"));
  EXPECT_FALSE(exempt(sut, "arm", "post"));
}

TEST(SelfCollisionExemption, BodiesOverlappingInTheInitialPoseAreExempt) {
  // The arm starts tilted 40 deg toward the post: its top is already inside the post.
  const RobotModel sut = robot_from_text(arm_and_post("", "initial_deg: 40"));

  EXPECT_TRUE(exempt(sut, "arm", "post"));
}

TEST(SelfCollisionExemption, ShippedHumanoidsLegsCollide) {
  for (const char* name : {"fumanoid-2011", "fumanoid-pitch"}) {
    const RobotModel sut = shipped_robot(name);
    EXPECT_TRUE(sut.self_collision) << name;
    EXPECT_FALSE(exempt(sut, "foot_left", "foot_right")) << name;
    EXPECT_FALSE(exempt(sut, "shank_left", "shank_right")) << name;
  }
}

TEST(SelfCollisionExemption, CanBeSwitchedOffInTheFile) {
  EXPECT_FALSE(robot_from_text(arm_and_post("self_collision: false")).self_collision);
}

}  // namespace
}  // namespace doppel::physics
