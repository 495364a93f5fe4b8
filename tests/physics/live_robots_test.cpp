// Robots added to and removed from a running world (World::add_robot / remove_robot), on both
// engines: an added robot stands and is held as the robots the world started with, the others do
// not notice, and a removed robot leaves nothing that collides.

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <stdexcept>

#include "physics/field.h"
#include "rigs.h"

namespace doppel::physics {
namespace {

using test::DrivenRobot;
using test::make_world;
using test::shipped_robot;

constexpr double kDeg = std::numbers::pi / 180.0;

class LiveRobotsTest : public ::testing::TestWithParam<std::string> {};

RobotPlacement at(double x, double y, double yaw = 0.0) {
  RobotPlacement placement;
  placement.position_m = Eigen::Vector3d(x, y, 0.0);
  placement.yaw_rad = yaw;
  return placement;
}

WorldOptions held_options() {
  WorldOptions options = test::bare_options();
  options.hold = HoldMode::kUntilTorque;
  return options;
}

TEST_P(LiveRobotsTest, AnAddedRobotIsHeldAndStandsAsTheOthers) {
  auto world = make_world(GetParam(), {shipped_robot("fumanoid-2011")}, held_options(), {at(-1.0, 0.0)});
  const double start_height = world->center_of_mass(0).z();
  DrivenRobot first(*world, 0);
  first.enable_all();
  first.run(0.5);

  const size_t added = world->add_robot(shipped_robot("fumanoid-2011"), at(1.0, 0.5, std::numbers::pi));
  ASSERT_EQ(added, 1U);
  ASSERT_TRUE(world->has_robot(1));
  EXPECT_EQ(world->robot_count(), 2U);
  EXPECT_TRUE(world->held(1));
  // Standing in its initial pose on the floor where it was put, as a robot the world started with.
  EXPECT_NEAR(world->center_of_mass(1).z(), start_height, 1e-3);
  EXPECT_NEAR(world->robot_pose(1).translation().x(), 1.0, 1e-3);
  EXPECT_NEAR(world->robot_pose(1).translation().y(), 0.5, 1e-3);
  ASSERT_TRUE(world->find_motor(1, 0, world->robot(1).motors[0].id).has_value());
  ASSERT_TRUE(world->find_imu(1, 0, 100).has_value());

  first.run(2.0);  // the new robot's driver has not switched anything on: held
  // Held exactly as a robot the world started with after the same two seconds: trunk, joints and
  // the load its feet carry (the handler takes the rest) within the held-pose tolerances.
  auto reference = make_world(GetParam(), {shipped_robot("fumanoid-2011")}, held_options(), {at(1.0, 0.5, std::numbers::pi)});
  for (int i = 0; i < 2000; ++i) reference->step();
  auto feet_n = [](const World& w, size_t r) {
    double sum = 0.0;
    for (uint8_t id : {101, 102}) {
      for (double f : w.foot(*w.find_foot(r, 0, id)).force_n) sum += f;
    }
    return sum;
  };
  EXPECT_TRUE(world->held(1));
  EXPECT_NEAR(world->center_of_mass(1).z(), reference->center_of_mass(0).z(), 1e-3);
  for (size_t l = 0; l < world->robot(1).links.size(); ++l) {
    EXPECT_NEAR(world->link_position(1, l), world->robot(1).links[l].initial, 0.5 * kDeg) << world->robot(1).links[l].name;
  }
  EXPECT_GT(feet_n(*world, 1), 1.0) << "its feet rest on the carpet";
  EXPECT_NEAR(feet_n(*world, 1), feet_n(*reference, 0), 1.5);

  // Its driver switches its servos on: the handler lets go and it stands on its own servos.
  DrivenRobot second(*world, 1);
  second.enable_all();
  for (int i = 0; i < 3000; ++i) {
    first.drive();
    second.drive();
    world->step();
    first.sense();
    second.sense();
  }
  EXPECT_FALSE(world->held(1));
  EXPECT_GT(world->center_of_mass(1).z(), start_height - 0.01);
  EXPECT_GT(world->center_of_mass(0).z(), start_height - 0.01) << "the first robot still stands";
}

TEST_P(LiveRobotsTest, ARemovedRobotLeavesNothingThatCollidesAndTheOthersStand) {
  WorldOptions options = held_options();
  options.ball.present = true;
  options.ball.position_m = Eigen::Vector3d(0.0, -2.0, 0.0);
  auto world = make_world(GetParam(), {shipped_robot("fumanoid-2011"), shipped_robot("fumanoid-2011")}, options,
                          {at(-1.0, 0.0), at(1.0, 0.0)});
  const double start_height = world->center_of_mass(0).z();
  DrivenRobot first(*world, 0);
  const MotorHandle motor = first.handle(0);
  const ImuHandle imu = *world->find_imu(0, 0, 100);
  first.enable_all();
  first.run(0.5);
  const Eigen::Vector3d trunk = world->center_of_mass(1);

  world->remove_robot(1);
  EXPECT_FALSE(world->has_robot(1));
  EXPECT_EQ(world->robot_count(), 2U) << "the slot stays, empty";
  EXPECT_FALSE(world->find_motor(1, 0, world->robot(0).motors[0].id).has_value());
  EXPECT_THROW(world->remove_robot(1), std::invalid_argument);
  // Robot 0's handles are the ones it had.
  EXPECT_EQ(world->find_motor(0, 0, world->robot(0).motors[0].id)->index, motor.index);
  EXPECT_EQ(world->find_imu(0, 0, 100)->index, imu.index);

  // A ball dropped through where the removed robot's trunk was falls straight to the carpet.
  const double radius = options.ball.radius_m;
  world->place_ball(Eigen::Vector3d(trunk.x(), trunk.y(), 0.6), Eigen::Vector3d::Zero());
  first.run(1.5);
  const Eigen::Vector3d ball = world->ball_position();
  EXPECT_NEAR(ball.z(), radius, 2e-3);
  EXPECT_NEAR(ball.x(), trunk.x(), 0.01);
  EXPECT_NEAR(ball.y(), trunk.y(), 0.01);

  first.run(2.0);
  EXPECT_GT(world->center_of_mass(0).z(), start_height - 0.01);
  EXPECT_LT(std::abs(world->imu(imu).pitch_rad), 3.0 * kDeg);
  SceneView view;
  world->fill_scene(view);
  for (const VisualShape& shape : view.shapes) {
    EXPECT_NE(shape.object_id, kFirstRobotObjectId + 1) << "the removed robot is not drawn";
  }
}

TEST_P(LiveRobotsTest, AnEmptySlotIsReusedAndASeventhRobotIsRefused) {
  auto world = make_world(GetParam(), {shipped_robot("fumanoid-2011"), shipped_robot("fumanoid-2011")}, held_options(),
                          {at(-1.0, 0.0), at(1.0, 0.0)});
  world->remove_robot(0);
  for (int i = 0; i < 10; ++i) world->step();
  EXPECT_EQ(world->add_robot(shipped_robot("fumanoid-2011"), at(-1.0, 1.0)), 0U) << "the empty slot first";
  for (size_t r = 2; r < kMaxRobotGroups; ++r) {
    EXPECT_EQ(world->add_robot(shipped_robot("fumanoid-2011"), at(-3.0 + static_cast<double>(r), -2.0)), r);
  }
  EXPECT_THROW(world->add_robot(shipped_robot("fumanoid-2011"), at(0.0, 2.0)), std::invalid_argument);
  for (int i = 0; i < 500; ++i) world->step();
  for (size_t r = 0; r < kMaxRobotGroups; ++r) {
    EXPECT_TRUE(world->held(r)) << r;
    EXPECT_LT(world->tilt_rad(r), 0.5 * kDeg) << r;
  }
}

// The others do not notice a robot added far away: the standing robot's trunk follows the same
// course within a tenth of a millimetre and its joints within one position step of its RX-28 and
// RX-64 servos (300 deg / 1024 = 0.29 deg: what its driver could read). Not bit for bit: the
// engines' solvers sweep over every constraint of the world, the new ones included (ODE's
// QuickStep also shuffles them). The same run with the same add is bit for bit the same run.
TEST_P(LiveRobotsTest, ARobotAddedFarAwayDoesNotDisturbTheOthers) {
  struct Course {
    Eigen::Vector3d com;
    std::vector<double> joints;
  };
  auto run = [&](bool add) {
    auto world = make_world(GetParam(), {shipped_robot("fumanoid-2011")}, held_options(), {at(-1.0, 0.0)});
    DrivenRobot driven(*world, 0);
    driven.enable_all();
    driven.run(0.5);
    if (add) world->add_robot(shipped_robot("fumanoid-2011"), at(3.0, 2.5));
    driven.run(2.0);
    Course course{world->center_of_mass(0), {}};
    for (size_t l = 0; l < world->robot(0).links.size(); ++l) course.joints.push_back(world->link_position(0, l));
    return course;
  };
  const Course alone = run(false);
  const Course with = run(true);
  const Course again = run(true);
  EXPECT_LT((with.com - alone.com).norm(), 1e-4);
  for (size_t l = 0; l < alone.joints.size(); ++l) {
    EXPECT_NEAR(with.joints[l], alone.joints[l], 300.0 / 1024.0 * kDeg) << l;
    EXPECT_EQ(again.joints[l], with.joints[l]) << l;
  }
  EXPECT_EQ(again.com, with.com);
}

INSTANTIATE_TEST_SUITE_P(Engines, LiveRobotsTest, ::testing::ValuesIn(engine_names()),
                         [](const ::testing::TestParamInfo<std::string>& param) { return param.param; });

}  // namespace
}  // namespace doppel::physics
