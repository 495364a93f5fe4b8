// data/robots/op3.textproto on both engines, below the bus: the body from ROBOTIS-OP3-Common's URDF
// standing in the walking module's ready pose at the Position P Gain its stack sets (800,
// op3_manager/config/dxl_init_OP3.yaml), and the weight on its feet. The OP3 has no foot sensors,
// so the test measures the soles' contact force with load cells of its own: two foot boards added
// to a copy of the file (a probe, not part of the robot), whose four cells share every contact's
// normal force and so sum to the whole force on the sole.

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>

#include "rigs.h"

namespace doppel::physics {
namespace {

using test::DrivenRobot;
using test::make_world;
using test::robot_from_text;
using test::robots_dir;

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kGravity = 9.80665;
// Sum of the link masses of op3_description/urdf/robotis_op3.inertia.xacro (ROBOTIS-OP3-Common).
constexpr double kUrdfMassKg = 1.34928 + 2 * (0.01181 + 0.17886 + 0.11543 + 0.04015 + 0.17886 + 0.06934) +
                               2 * (0.01176 + 0.17758 + 0.04127) + 0.01176 + 0.13631;
constexpr uint8_t kOpenCr = 200;
constexpr uint8_t kProbeRight = 101, kProbeLeft = 102;

std::string op3_text() {
  std::ifstream in(robots_dir() + "/op3.textproto");
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// op3.textproto with a foot board under each sole: the cells at the corners of the larger sole box
// (Menagerie's 0.114 x 0.078 m, 0.0305 m below the ankle roll axis) in the body frame of the foot.
std::string op3_with_probes() {
  std::string text = op3_text();
  const std::string opencr = "device { id: 200 model: \"OPEN-CR\" name: \"open-cr\" }";
  const std::size_t at = text.find(opencr);
  EXPECT_NE(at, std::string::npos);
  text.insert(at + opencr.size(), "\n  device { id: 101 model: \"BITFOOT\" name: \"PROBE_R\" }"
                                  "\n  device { id: 102 model: \"BITFOOT\" name: \"PROBE_L\" }");
  auto foot = [](const char* body, int id, double y) {
    std::ostringstream f;
    f << "  foot { name: \"probe" << id << "\" body: \"" << body << "\" bus: 0 id: " << id;
    for (double x : {0.081, -0.033}) {
      for (double dy : {0.039, -0.039}) {
        f << " cell_m { x: " << x << " y: " << y + dy << " z: -0.0305 }";
      }
    }
    f << " }\n";
    return f.str();
  };
  const std::size_t end = text.rfind('}');
  text.insert(end, foot("r_ank_roll_link", kProbeRight, -0.0125) + foot("l_ank_roll_link", kProbeLeft, 0.0125));
  return text;
}

double probe_sum(const World& world) {
  double sum = 0.0;
  for (uint8_t id : {kProbeRight, kProbeLeft}) {
    for (double f : world.foot(*world.find_foot(0, 0, id)).force_n) sum += f;
  }
  return sum;
}

// The servos as the OP3's stack leaves them: position control, P/I/D 800/0/0, limits 0..4095.
void stack_gains(DrivenRobot& driven) {
  for (size_t i = 0; i < driven.size(); ++i) {
    dynamixel::ServoCommand& c = driven.command(i);
    c.pid = dynamixel::x_pid_gains(800, 0, 0);
    c.punch_raw = 0;
    c.min_position_rad = -std::numbers::pi;
    c.max_position_rad = std::numbers::pi * 4095.0 / 4096.0;
  }
}

// The OP3's brackets (12 g hip yaw, shoulder and neck links) and 40-70 g shanks and feet under a
// 1.35 kg trunk: the engines' iterative solvers need 100 sweeps per step to hold that chain still
// at P 800 (with the default 10 the servo drives chatter between 0 and stall and the robot sinks
// and falls on both engines; 50 still tilts it by 3.5 deg). doppel --solver-iterations 100.
WorldOptions op3_options() {
  WorldOptions o = test::bare_options();
  o.solver_iterations = 100;
  return o;
}

class Op3Body : public ::testing::TestWithParam<std::string> {};

TEST_P(Op3Body, HasTheUrdfMassAndStandsOnFlatFeetInTheReadyPose) {
  auto world = make_world(GetParam(), {robot_from_text(op3_with_probes())});
  const RobotModel& model = world->robot(0);
  EXPECT_NEAR(model.mass_kg, kUrdfMassKg, 1e-6);
  EXPECT_EQ(model.motors.size(), 20u);

  // The walking module's IK put each ankle 0.02 m behind and 0.185 m below the hip pitch axis
  // (x_offset -0.02, z_offset 0.035 of a 0.22015 m thigh + calf): the file's joint angles, axes and
  // directions must rebuild that, with the soles flat on the floor and the trunk level.
  auto body = [&](const char* name) {
    for (size_t b = 0; b < model.bodies.size(); ++b) {
      if (model.bodies[b].name == name) return world->body_pose(0, b);
    }
    ADD_FAILURE() << "no body " << name;
    return Eigen::Isometry3d::Identity();
  };
  for (const char* side : {"r", "l"}) {
    const std::string s(side);
    const Eigen::Isometry3d hip = body((s + "_hip_pitch_link").c_str());
    const Eigen::Isometry3d knee = body((s + "_knee_link").c_str());
    const Eigen::Isometry3d ankle = body((s + "_ank_pitch_link").c_str());
    const Eigen::Isometry3d foot = body((s + "_ank_roll_link").c_str());
    const Eigen::Vector3d hip_to_ankle = ankle.translation() - hip.translation();
    EXPECT_NEAR(hip_to_ankle.x(), -0.02, 0.002) << side;
    EXPECT_NEAR(hip_to_ankle.z(), -0.18515, 0.002) << side;
    EXPECT_GT(knee.translation().x(), hip.translation().x() + 0.03) << side << ": the knee bends forward";
    EXPECT_NEAR(foot.linear().col(2).z(), 1.0, 1e-4) << side << ": the sole is flat";
  }
  EXPECT_NEAR(body("body_link").linear().col(2).z(), 1.0, 1e-6);
}

TEST_P(Op3Body, StandsAtTheStackGainsAndItsFeetCarryItsWeight) {
  auto world = make_world(GetParam(), {robot_from_text(op3_with_probes())}, op3_options());
  DrivenRobot driven(*world, 0);
  stack_gains(driven);
  const ImuHandle imu = *world->find_imu(0, 0, kOpenCr);
  const double start_height = world->center_of_mass(0).z();

  driven.enable_all();
  double lowest = start_height, worst_tilt = 0.0;
  for (int i = 0; i < 3000; ++i) {
    driven.step();
    lowest = std::min(lowest, world->center_of_mass(0).z());
    worst_tilt = std::max({worst_tilt, std::abs(world->imu(imu).pitch_rad), std::abs(world->imu(imu).roll_rad)});
  }
  EXPECT_FALSE(world->held(0));
  EXPECT_GT(lowest, start_height - 0.01);  // the centre of mass sags by less than 1 cm
  EXPECT_LT(worst_tilt, 3.0 * kDeg);       // and the trunk stays level

  // Mean over 100 ms (100 steps) of the soles' contact force.
  double sum = 0.0;
  double gyro = 0.0;
  for (int i = 0; i < 100; ++i) {
    driven.step();
    sum += probe_sum(*world) / 100.0;
    const ImuState s = world->imu(imu);
    gyro = std::max({gyro, std::abs(s.w_WS_S_rad_s[0]), std::abs(s.w_WS_S_rad_s[1]), std::abs(s.w_WS_S_rad_s[2])});
  }
  const double weight = kUrdfMassKg * kGravity;
  EXPECT_NEAR(sum, weight, 0.05 * weight);
  // At rest: no rotation beyond the MPU-9250's zero-rate offset (+-5 deg/s, datasheet), and the
  // accelerometer (the board turned 180 deg about z, level) reads +1 g along its z.
  EXPECT_LT(gyro, 5.0 * kDeg);
  const ImuState s = world->imu(imu);
  EXPECT_NEAR(s.a_WS_S_m_s2[0], 0.0, 0.06 * kGravity);
  EXPECT_NEAR(s.a_WS_S_m_s2[1], 0.0, 0.06 * kGravity);
  EXPECT_NEAR(s.a_WS_S_m_s2[2], kGravity, 0.08 * kGravity);
}

INSTANTIATE_TEST_SUITE_P(Engines, Op3Body, ::testing::ValuesIn(engine_names()),
                         [](const ::testing::TestParamInfo<std::string>& param) { return param.param; });

}  // namespace
}  // namespace doppel::physics
