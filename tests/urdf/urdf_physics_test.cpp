// URDF robots in the physics world, on both engines: the test biped (convex-hull feet from an STL
// and a DAE) stands on its feet with torque on, level, its foot boards carrying its weight; the
// pendulum (a bob with only an <inertial>, its tensor in a rotated frame) swings with the period
// its URDF inertia gives. The renderer sees the hulls.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "rigs.h"
#include "urdf/urdf_import.h"

namespace doppel::physics {
namespace {

using test::DrivenRobot;
using test::make_world;

const std::string kData = DOPPEL_URDF_TEST_DATA;
constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kGravity = 9.80665;

RobotModel urdf_robot(const std::string& file) {
  return compile_robot(urdf::load_robot_file(kData + "/" + file), body::motor_catalog());
}

class UrdfPhysicsTest : public ::testing::TestWithParam<std::string> {};

double foot_sum(const World& world) {
  double sum = 0.0;
  for (uint8_t id : {101, 102}) {
    for (double f : world.foot(*world.find_foot(0, 0, id)).force_n) sum += f;
  }
  return sum;
}

TEST_P(UrdfPhysicsTest, BipedStandsOnItsHullFeet) {
  auto world = make_world(GetParam(), {urdf_robot("test-biped.textproto")});
  DrivenRobot driven(*world, 0);
  const ImuHandle imu = *world->find_imu(0, 0, 100);
  driven.enable_all();
  driven.run(2.0);

  // Mean over 100 ms of the eight load cells against m g (the test mass: 2.8 kg).
  double sum = 0.0;
  for (int i = 0; i < 100; ++i) {
    driven.step();
    sum += foot_sum(*world);
  }
  const double weight = 2.8 * kGravity;
  RecordProperty("feet_mN", std::to_string(std::lround(sum / 100.0 * 1000.0)));
  ASSERT_NEAR(world->robot(0).mass_kg, 2.8, 1e-9);
  EXPECT_NEAR(sum / 100.0, weight, 0.05 * weight);

  // At rest on its soles: the soles (30 mm below the ankles, 0.30 m below the trunk's origin) on
  // the floor, the trunk level within 2 deg: the straight legs are an inverted pendulum on three
  // servos in series, each resting anywhere within its compliance margin (1 unit, 0.29 deg, the
  // DrivenRobot's setting) plus the slope's give (both engines lean about 1 deg forward). The IMU
  // is mounted turned 90 deg about z (imu_link): it reads that pitch as roll, and level otherwise.
  const Eigen::Isometry3d trunk = world->body_pose(0, 0);
  EXPECT_NEAR(trunk.translation().z(), 0.33, 0.003);
  EXPECT_GT(trunk.linear()(2, 2), std::cos(2.0 * kDeg));
  EXPECT_LT(std::abs(world->imu(imu).roll_rad), 2.0 * kDeg);
  EXPECT_LT(std::abs(world->imu(imu).pitch_rad), 0.5 * kDeg);
  const Eigen::Vector3d v = world->body_pose(0, 0).translation();
  driven.run(0.5);
  EXPECT_LT((world->body_pose(0, 0).translation() - v).norm(), 1e-3);  // still, not sliding
}

TEST_P(UrdfPhysicsTest, PendulumPeriodFollowsItsUrdfInertia) {
  auto world = make_world(GetParam(), {urdf_robot("pendulum.textproto")});
  world->release(0);
  // Small swing from 5 deg: the period from the upward zero crossings over about 8 periods.
  std::vector<double> crossings;
  double previous = world->link_position(0, 0);
  for (int i = 0; i < 9000; ++i) {
    world->step();
    const double q = world->link_position(0, 0);
    if (previous < 0.0 && q >= 0.0) {
      crossings.push_back(world->time_s() - world->options().step_s * q / (q - previous));
    }
    previous = q;
  }
  ASSERT_GE(crossings.size(), 5U);
  const double period = (crossings.back() - crossings.front()) / static_cast<double>(crossings.size() - 1);
  RecordProperty("period_us", std::to_string(std::lround(period * 1e6)));
  // pendulum.urdf: T = 2 pi sqrt((Iyy + m d^2) / (m g d)), Iyy = 0.005 (the inertial frame's z
  // moment, rolled onto y), m = 0.5, d = 0.2; the 5 deg amplitude lengthens it by 0.05 %.
  const double expected = 2.0 * std::numbers::pi * std::sqrt((0.005 + 0.5 * 0.04) / (0.5 * kGravity * 0.2));
  EXPECT_NEAR(period, expected, 0.02 * expected);
  // Had the tensor's frame been ignored (Iyy = 0.002) the period would be 6 % shorter.
  EXPECT_GT(period, 2.0 * std::numbers::pi * std::sqrt((0.002 + 0.5 * 0.04) / (0.5 * kGravity * 0.2)) * 1.03);
}

TEST_P(UrdfPhysicsTest, TheSceneShowsTheHulls) {
  auto world = make_world(GetParam(), {urdf_robot("test-biped.textproto")});
  SceneView view;
  world->fill_scene(view);
  int hulls = 0;
  for (const VisualShape& s : view.shapes) {
    if (s.type != ShapeType::kConvex) continue;
    ++hulls;
    ASSERT_TRUE(s.hull);
    EXPECT_EQ(s.hull->vertices.size(), 8U);
    // Held at the initial pose on the floor: the sole's lowest vertex at z = 0.
    double lowest = 1.0;
    for (const Eigen::Vector3d& p : s.hull->vertices) lowest = std::min(lowest, (s.X_WS * p).z());
    EXPECT_NEAR(lowest, 0.0, 1e-3);
  }
  EXPECT_EQ(hulls, 2);
}

INSTANTIATE_TEST_SUITE_P(Engines, UrdfPhysicsTest, ::testing::ValuesIn(engine_names()),
                         [](const ::testing::TestParamInfo<std::string>& param) { return param.param; });

}  // namespace
}  // namespace doppel::physics
