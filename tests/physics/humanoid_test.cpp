// Physical plausibility of the shipped robots on both engines: standing with torque on, collapsing
// with torque off, load cells carrying the weight, the IMU showing a known tilt, the start-up hold.

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "rigs.h"

namespace doppel::physics {
namespace {

using test::DrivenRobot;
using test::make_world;
using test::shipped_robot;

constexpr double kDeg = std::numbers::pi / 180.0;

class HumanoidTest : public ::testing::TestWithParam<std::string> {};

double load_cell_sum(const World& world) {
  double sum = 0.0;
  for (uint8_t id : {101, 102}) {
    for (double f : world.foot(*world.find_foot(0, 0, id)).force_n) sum += f;
  }
  return sum;
}

TEST_P(HumanoidTest, StandsTenSecondsWithTorqueOn) {
  auto world = make_world(GetParam(), {shipped_robot("fumanoid-2011")});
  DrivenRobot driven(*world, 0);
  const double start_height = world->center_of_mass(0).z();
  const ImuHandle imu = *world->find_imu(0, 0, 100);

  driven.enable_all();
  double lowest = start_height, worst_tilt = 0.0;
  for (int i = 0; i < 10000; ++i) {
    driven.step();
    lowest = std::min(lowest, world->center_of_mass(0).z());
    worst_tilt = std::max({worst_tilt, std::abs(world->imu(imu).pitch_rad), std::abs(world->imu(imu).roll_rad)});
  }

  EXPECT_FALSE(world->held(0));
  EXPECT_GT(lowest, start_height - 0.01);  // the centre of mass sags by less than 1 cm
  EXPECT_LT(worst_tilt, 3.0 * kDeg);       // and the head stays level
}

TEST_P(HumanoidTest, CollapsesWithTorqueOff) {
  auto world = make_world(GetParam(), {shipped_robot("fumanoid-2011")});
  const double start_height = world->center_of_mass(0).z();

  world->release(0);  // the handler lets go of a robot whose servos never got torque
  for (int i = 0; i < 3000; ++i) world->step();

  EXPECT_LT(world->center_of_mass(0).z(), 0.5 * start_height);
}

TEST_P(HumanoidTest, IsHeldUprightUntilItsDriverEnablesTorque) {
  auto world = make_world(GetParam(), {shipped_robot("fumanoid-2011")});
  const double start_height = world->center_of_mass(0).z();

  for (int i = 0; i < 2000; ++i) world->step();

  EXPECT_TRUE(world->held(0));
  EXPECT_NEAR(world->center_of_mass(0).z(), start_height, 1e-3);
  for (size_t l = 0; l < world->robot(0).links.size(); ++l) {
    EXPECT_NEAR(world->link_position(0, l), world->robot(0).links[l].initial, 0.5 * kDeg) << world->robot(0).links[l].name;
  }
}

// A driver that switches its servos on one at a time (ROBOTIS' robotis_controller: 20 ms apart
// here): the handler hands the robot over joint by joint and lets go when the last has torque.
TEST_P(HumanoidTest, IsHandedOverJointByJointWhileItsDriverEnablesTheServosOneByOne) {
  auto world = make_world(GetParam(), {shipped_robot("fumanoid-2011")});
  DrivenRobot driven(*world, 0);
  const double start_height = world->center_of_mass(0).z();
  for (size_t i = 0; i < driven.size(); ++i) {
    driven.command(i).torque_enabled = true;
    driven.run(0.02);
    EXPECT_EQ(world->held(0), i + 1 < driven.size()) << i;
  }
  driven.run(1.0);
  EXPECT_FALSE(world->held(0));
  EXPECT_GT(world->center_of_mass(0).z(), start_height - 0.01);  // standing, not sagged
  for (size_t i = 0; i < driven.size(); ++i) {
    EXPECT_NEAR(world->link_position(0, static_cast<size_t>(driven.link(i))),
                world->robot(0).links[static_cast<size_t>(driven.link(i))].initial, 3.0 * kDeg)
        << world->robot(0).links[static_cast<size_t>(driven.link(i))].name;
  }
}

// One servo on and no more: its joint follows it at once; the handler lets go 1 s later
// (WorldOptions::hold_hand_over_s) and the limp rest of the robot collapses.
TEST_P(HumanoidTest, LetsGoTheHandOverTimeAfterTheFirstServoWhenTheOthersStayOff) {
  auto world = make_world(GetParam(), {shipped_robot("fumanoid-2011")});
  DrivenRobot driven(*world, 0);
  const double start_height = world->center_of_mass(0).z();
  const int link = driven.link(0);
  const double initial = world->robot(0).links[static_cast<size_t>(link)].initial;
  driven.command(0).torque_enabled = true;
  driven.command(0).goal_position_rad = world->motor(driven.handle(0)).position_rad + 0.3;
  driven.run(0.9);
  EXPECT_TRUE(world->held(0));
  EXPECT_GT(std::abs(world->link_position(0, static_cast<size_t>(link)) - initial), 0.2);
  driven.run(2.2);
  EXPECT_FALSE(world->held(0));
  EXPECT_LT(world->center_of_mass(0).z(), 0.7 * start_height);
}

TEST_P(HumanoidTest, LoadCellsCarryTheWeightWhenStandingStill) {
  auto world = make_world(GetParam(), {shipped_robot("fumanoid-2011")});
  DrivenRobot driven(*world, 0);
  driven.enable_all();
  driven.run(2.0);

  // Mean over 100 ms (100 readings), as a foot board that averages its cells would report.
  double sum = 0.0;
  for (int i = 0; i < 100; ++i) {
    driven.step();
    sum += load_cell_sum(*world);
  }

  const double weight = world->robot(0).mass_kg * 9.80665;
  EXPECT_NEAR(sum / 100.0, weight, 0.05 * weight);
}

TEST_P(HumanoidTest, LoadCellsShowWhereTheWeightIs) {
  auto world = make_world(GetParam(), {shipped_robot("fumanoid-2011")});
  DrivenRobot driven(*world, 0);
  driven.enable_all();
  driven.run(2.0);

  double left = 0.0, right = 0.0;
  for (double f : world->foot(*world->find_foot(0, 0, 101)).force_n) left += f;
  for (double f : world->foot(*world->find_foot(0, 0, 102)).force_n) right += f;

  // Symmetric robot, both feet on the floor: each carries about half.
  EXPECT_NEAR(left / (left + right), 0.5, 0.1);
}

struct Tilt {
  const char* name;
  double roll_deg;
  double pitch_deg;
};

class ImuTiltTest : public ::testing::TestWithParam<std::tuple<std::string, Tilt>> {};

TEST_P(ImuTiltTest, ShowsTheTiltOfTheHeldRobot) {
  const auto& [engine, tilt] = GetParam();
  auto world = make_world(engine, {shipped_robot("fumanoid-2011")});
  const ImuHandle sut = *world->find_imu(0, 0, 100);
  Eigen::Isometry3d X_WR = Eigen::Isometry3d::Identity();
  X_WR.linear() = rotation_from_rpy_deg(tilt.roll_deg, tilt.pitch_deg, 0.0);
  X_WR.translation() = Eigen::Vector3d(0.0, 0.0, 0.3);

  world->place_held(0, X_WR);
  for (int i = 0; i < 200; ++i) world->step();

  // The head is pitched 22 deg and its IMU mounted at -22 deg (thesis 4.2.1.3): it reads the body's tilt.
  const ImuState s = world->imu(sut);
  EXPECT_NEAR(s.roll_rad, tilt.roll_deg * kDeg, 1.0 * kDeg);
  EXPECT_NEAR(s.pitch_rad, tilt.pitch_deg * kDeg, 1.0 * kDeg);
  // At rest the accelerometer reads gravity's reaction, expressed in the tilted sensor frame. Bound:
  // 5 % of g; ODE's QuickStep (20 sweeps) leaves about 1 mm/s of velocity jitter in the held chain,
  // which differentiated and low-passed at 5 ms is 0.2..0.35 m/s^2 (Bullet: below 0.01).
  const Eigen::Vector3d f(s.a_WS_S_m_s2[0], s.a_WS_S_m_s2[1], s.a_WS_S_m_s2[2]);
  const Eigen::Vector3d expected = X_WR.linear().transpose() * Eigen::Vector3d(0.0, 0.0, 9.80665);
  EXPECT_NEAR((f - expected).norm(), 0.0, 0.05 * 9.80665);
}

INSTANTIATE_TEST_SUITE_P(Engines, HumanoidTest, ::testing::ValuesIn(engine_names()),
                         [](const ::testing::TestParamInfo<std::string>& param) { return param.param; });

INSTANTIATE_TEST_SUITE_P(Engines, ImuTiltTest,
                         ::testing::Combine(::testing::ValuesIn(engine_names()),
                                            ::testing::Values(Tilt{"Upright", 0.0, 0.0}, Tilt{"Forward10", 0.0, 10.0},
                                                              Tilt{"Back15", 0.0, -15.0}, Tilt{"Left8", 8.0, 0.0},
                                                              Tilt{"Both", -6.0, 12.0})),
                         [](const ::testing::TestParamInfo<std::tuple<std::string, Tilt>>& param) {
                           return std::get<0>(param.param) + "_" + std::get<1>(param.param).name;
                         });

}  // namespace
}  // namespace doppel::physics
