// Simulation control on both engines (World::place_robot, reset_robot, push, robot_pose, tilt_rad):
// what doppel-ctl's place, reset and push do to the world, judged against the start pose and, for
// the push, against Newton's second law.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "rigs.h"

namespace doppel::physics {
namespace {

using test::make_world;
using test::robot_from_text;
using test::shipped_robot;

constexpr double kDeg = std::numbers::pi / 180.0;

double yaw_of(const Eigen::Isometry3d& X) { return std::atan2(X.linear()(1, 0), X.linear()(0, 0)); }

class ControlTest : public ::testing::TestWithParam<std::string> {};

TEST_P(ControlTest, PlaceStandsTheRobotInItsInitialPoseWhereAsked) {
  auto world = make_world(GetParam(), {shipped_robot("fumanoid-2011")});
  const double start_height = world->center_of_mass(0).z();
  for (int i = 0; i < 200; ++i) world->step();

  world->place_robot(0, 1.0, -0.5, 0.5 * std::numbers::pi);
  for (int i = 0; i < 500; ++i) world->step();

  const Eigen::Isometry3d X_WR = world->robot_pose(0);
  EXPECT_NEAR(X_WR.translation().x(), 1.0, 1e-3);
  EXPECT_NEAR(X_WR.translation().y(), -0.5, 1e-3);
  EXPECT_NEAR(yaw_of(X_WR), 0.5 * std::numbers::pi, 0.5 * kDeg);
  EXPECT_LT(world->tilt_rad(0), 1.0 * kDeg);
  EXPECT_NEAR(world->center_of_mass(0).z(), start_height, 2e-3);  // on its feet, not in or above the floor
  EXPECT_TRUE(world->held(0));
}

TEST_P(ControlTest, ResetAfterAFallPutsTheRobotBackWhereItStartedAndHoldsIt) {
  WorldOptions options = test::bare_options();
  std::vector<RobotPlacement> placements(1);
  placements[0].position_m = Eigen::Vector3d(-1.0, 0.3, 0.0);
  placements[0].yaw_rad = 0.25;
  auto world = make_world(GetParam(), {shipped_robot("fumanoid-2011")}, options, placements);
  const Eigen::Isometry3d start = world->robot_pose(0);
  const double start_height = world->center_of_mass(0).z();

  world->release(0);  // a limp robot falls
  for (int i = 0; i < 3000; ++i) world->step();
  ASSERT_GT(world->tilt_rad(0), 45.0 * kDeg) << "the robot was expected to lie on the carpet";

  world->reset_robot(0);
  for (int i = 0; i < 1000; ++i) world->step();

  EXPECT_TRUE(world->held(0));
  EXPECT_LT((world->robot_pose(0).translation() - start.translation()).norm(), 2e-3);
  EXPECT_NEAR(yaw_of(world->robot_pose(0)), 0.25, 0.5 * kDeg);
  EXPECT_LT(world->tilt_rad(0), 1.0 * kDeg);
  EXPECT_NEAR(world->center_of_mass(0).z(), start_height, 2e-3);
  for (size_t l = 0; l < world->robot(0).links.size(); ++l) {
    EXPECT_NEAR(world->link_position(0, l), world->robot(0).links[l].initial, 0.5 * kDeg) << world->robot(0).links[l].name;
  }
}

// A 2 kg block resting on the floor, pushed straight up with three times its weight for 100 ms: it
// accelerates at 2 g while pushed (v = 2 g t = 1.96 m/s, rise 2 g t^2 / 2 = 9.8 cm), then flies
// v^2 / 2g = 19.6 cm higher: its highest point is 29.4 cm above the start.
TEST_P(ControlTest, APushGivesTheImpulseOfItsForceAndDuration) {
  constexpr double kMass = 2.0, kG = 9.80665, kPushS = 0.1;
  WorldOptions options = test::bare_options();
  options.hold = HoldMode::kReleased;
  auto world = make_world(GetParam(), {robot_from_text(R"(
name: "block"
bus { name: "b" baud_bps: 1000000 protocol: PROTOCOL_1 }
figure { body { name: "block" pose { position_m { z: 0.05 } } shape { box { size_m { x: 0.1 y: 0.1 z: 0.1 } } } mass_kg: 2 } }
)")}, options);
  for (int i = 0; i < 200; ++i) world->step();  // settles on the floor
  const double start_z = world->center_of_mass(0).z();

  world->push(0, Eigen::Vector3d(0.0, 0.0, 3.0 * kMass * kG), static_cast<uint32_t>(std::lround(kPushS / 0.001)));
  double highest = start_z;
  for (int i = 0; i < 800; ++i) {
    world->step();
    highest = std::max(highest, world->center_of_mass(0).z());
  }

  const double expected = 0.5 * 2.0 * kG * kPushS * kPushS + std::pow(2.0 * kG * kPushS, 2) / (2.0 * kG);
  EXPECT_NEAR(highest - start_z, expected, 0.02 * expected);
}

TEST_P(ControlTest, TiltTellsStandingFromLying) {
  auto world = make_world(GetParam(), {shipped_robot("fumanoid-2011")});
  for (int i = 0; i < 100; ++i) world->step();
  EXPECT_LT(world->tilt_rad(0), 1.0 * kDeg);
  world->release(0);
  for (int i = 0; i < 3000; ++i) world->step();
  EXPECT_GT(world->tilt_rad(0), 45.0 * kDeg);
}

INSTANTIATE_TEST_SUITE_P(Engines, ControlTest, ::testing::Values("ode", "bullet"));

}  // namespace
}  // namespace doppel::physics
