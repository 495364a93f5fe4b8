// The reference walk: the leg inverse kinematics against the robot file's geometry, and doppel-walk
// driving the default robot through its serial port on ODE and Bullet. Judged on simulation time
// (doppel-walk's clock is the IMU Sample Counter; doppel-ctl state's sim_time_s) and on the pose
// and `fallen` flag doppel-ctl reports, never on wall-clock time.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <regex>
#include <string>
#include <thread>
#include <tuple>
#include <chrono>

#include <nlohmann/json.hpp>

#include "doppel_process.h"
#include "gait.h"

namespace doppel::testing {
namespace {

using nlohmann::json;
constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180;
// What the walk holds in every run on both engines (docs/walk.md, "What it achieves"): achieved
// over commanded distance and turn, heading after a 30 s straight walk, pushes (FX FY FZ MS).
constexpr double kSpeedTolerance = 0.25;
constexpr double kTurnTolerance = 0.35;
constexpr double kHeadingTolerance = 0.3;
const std::string kPushSideways = "0 5 0 100";
const std::string kDarwinPushSideways = "0 3 0 100";

TEST(LegIk, TheDesignPoseIsAllZero) {
  walk::LegAngles a;
  ASSERT_FALSE(walk::leg_ik(walk::LegGeometry{}, 0, 0, 0, 0, a)) << "a straight leg is the edge of reach";
  EXPECT_NEAR(a.hip_pitch, 0, 0.01);
  EXPECT_NEAR(a.knee, 0, 0.02);
  EXPECT_NEAR(a.hip_roll, 0, 1e-9);
}

TEST(LegIk, TheRobotFilesInitialPoseComesBack) {
  // Initial pose hip -15, knee 30, ankle -15 deg: thigh and shank both 15 deg off vertical, the
  // thigh forward and the shank back, so the ankle is 0.12 sin 15 - 0.11 sin 15 forward of the hip
  // and (0.12 + 0.11) cos 15 below it.
  const walk::LegGeometry leg;
  const double x = (leg.thigh_m - leg.shank_m) * std::sin(15 * kDeg);
  const double z = leg.hip_height_m - (leg.thigh_m + leg.shank_m) * std::cos(15 * kDeg) - leg.ankle_height_m;
  walk::LegAngles a;
  ASSERT_TRUE(walk::leg_ik(leg, x, 0, z, 0, a));
  EXPECT_NEAR(a.hip_pitch, -15 * kDeg, 1e-6);
  EXPECT_NEAR(a.knee, 30 * kDeg, 1e-6);
  EXPECT_NEAR(a.ankle_pitch, -15 * kDeg, 1e-6);
}

TEST(LegIk, ASidewaysFootRollsHipAndAnkleOppositely) {
  walk::LegAngles a;
  ASSERT_TRUE(walk::leg_ik(walk::LegGeometry{}, 0, 0.02, 0.03, 0.1, a));
  EXPECT_GT(a.hip_roll, 0) << "+ roll about x swings the foot to +y";
  EXPECT_NEAR(a.ankle_roll, -a.hip_roll, 1e-12) << "the sole stays flat";
  EXPECT_DOUBLE_EQ(a.hip_yaw, 0.1);
}

// The gait's feedback, one step at a time. Phase pi (half a cycle) puts cos(phase) at -1, where
// the left foot is at +step/2 and its hip yaw at +turn/2.
TEST(Gait, AHeadingErrorTurnsTheFeetBackTowardsTheTarget) {
  walk::GaitParameters p;  // heading gain 1 rad/s per rad
  walk::Gait gait(walk::LegGeometry{}, p);
  walk::ImuReading imu;
  gait.step(0, 0, 0, 1, imu);  // the target heading: 0
  imu.yaw = -0.2;              // turned 0.2 rad to the right since
  gait.step(p.period_s / 2, 0, 0, 1, imu);
  // Turn rate 0.2 rad/s over half a period per step: the left hip yaw at +half of it.
  EXPECT_NEAR(gait.joints()[0], 0.5 * 0.2 * p.period_s / 2, 1e-9);
  EXPECT_NEAR(gait.joints()[6], -0.5 * 0.2 * p.period_s / 2, 1e-9);
}

TEST(Gait, ACommandedTurnMovesTheTargetAndTheFeetFollow) {
  walk::GaitParameters p;
  walk::Gait gait(walk::LegGeometry{}, p);
  gait.step(p.period_s / 2, 0, 0.3, 1, {});
  // The target moved 0.3 rad/s x T/2 while the IMU still reads 0: that error adds to the command.
  const double error = 0.3 * p.period_s / 2;
  EXPECT_NEAR(gait.joints()[0], 0.5 * (0.3 + p.heading_gain * error) * p.period_s / 2, 1e-9);
}

TEST(Gait, AFootHangingOnTheHighSideReachesForTheFloor) {
  walk::GaitParameters p;
  walk::ImuReading imu;
  imu.roll = 0.25;  // right side down: the left side is high
  imu.load_right_n = 40;
  imu.load_left_n = 40;
  walk::Gait loaded(walk::LegGeometry{}, p);
  loaded.step(0, 0, 0, 0, imu);
  imu.load_left_n = 0;  // the left foot in the air
  walk::Gait hanging(walk::LegGeometry{}, p);
  hanging.step(0, 0, 0, 0, imu);
  EXPECT_LT(hanging.joints()[3], loaded.joints()[3] - 0.05) << "the left knee straightens";
  EXPECT_DOUBLE_EQ(hanging.joints()[9], loaded.joints()[9]) << "the standing right leg is left alone";
  imu.roll = -0.25;  // the left side low: nothing to reach for
  walk::Gait low(walk::LegGeometry{}, p);
  low.step(0, 0, 0, 0, imu);
  walk::ImuReading level_loaded = imu;
  level_loaded.load_left_n = 40;
  walk::Gait low_loaded(walk::LegGeometry{}, p);
  low_loaded.step(0, 0, 0, 0, level_loaded);
  EXPECT_DOUBLE_EQ(low.joints()[3], low_loaded.joints()[3]);
}

TEST(Gait, EachStepIsHalfTheCyclesTravel) {
  walk::GaitParameters p;
  p.stride_scale = 1;
  p.sway_m = 0;
  p.pelvis_roll_rad = 0;
  p.tilt_roll_gain = 0;
  walk::Gait gait(walk::LegGeometry{}, p);
  gait.step(p.period_s / 2, 0.1, 0, 1, {});
  // The left foot lands at +step/2 = 0.1 m/s x T / 4 forward of the hips: the leg IK's angles for it.
  walk::LegAngles expected;
  ASSERT_TRUE(walk::leg_ik(walk::LegGeometry{}, 0.1 * p.period_s / 4, 0, walk::LegGeometry{}.hip_height_m - p.hip_height_m,
                           0, expected));
  EXPECT_NEAR(gait.joints()[2], expected.hip_pitch, 1e-6);
  EXPECT_NEAR(gait.joints()[3], expected.knee, 1e-6);
}

// doppel (default robot fumanoid-2011) with its control API on a free port.
struct WalkingDoppel {
  explicit WalkingDoppel(const std::string& engine, const std::string& robot_name = "fumanoid-2011")
      : doppel({"--viewer", "0", "--timing", "fast", "--physics", engine, "--robot", robot_name}), robot(robot_name) {
    const std::string output = doppel.wait_for_output("simulation control on http://127.0.0.1:");
    std::smatch match;
    if (!std::regex_search(output, match, std::regex(R"(simulation control on http://127\.0\.0\.1:(\d+))"))) {
      throw std::runtime_error("doppel did not say where its control is: " + output);
    }
    url = "http://127.0.0.1:" + match[1].str();
  }
  // doppel-ctl with `arguments`, finding the run's token in the test's link directory.
  std::pair<int, std::string> ctl(const std::string& arguments) const {
    return run_command(std::string(DOPPEL_CTL) + " --url " + url + " --link-dir " + doppel.link_dir() + " " + arguments);
  }
  json state() const {
    const auto [code, output] = ctl("state");
    EXPECT_EQ(code, 0) << output;
    return json::parse(output);
  }
  // Runs doppel-walk; its per-cycle log (IMU, foot loads, phase) goes to walk-SUITE-TEST-N.csv in
  // the working directory (N counts the walks of this process: --gtest_repeat keeps each run's).
  std::pair<int, std::string> walk(const std::string& arguments) const {
    // DARwIn-OP: the framework's leg gain, P 32 (darwin_op_framework.h), which Doppel's MX PID scale
    // (Rhoban's measurement, docs/devices.md "Servo gains") makes as stiff as P 64 was before it;
    // doppel-walk's own default, 64, is now twice as stiff.
    const std::string which = robot == "darwin-op" ? " --robot darwin-op --p-gain 32" : "";
    const auto* test = ::testing::UnitTest::GetInstance()->current_test_info();
    static int walks = 0;
    std::string log = std::string("walk-") + test->test_suite_name() + "-" + test->name() + "-" + std::to_string(++walks) + ".csv";
    std::replace(log.begin(), log.end(), '/', '-');
    auto result = run_command(std::string(DOPPEL_WALK) + " --port " + doppel.link() + which + " --log " + log + " " + arguments);
    result.second += "(log: " + log + ")";
    return result;
  }
  DoppelProcess doppel;
  std::string robot;
  std::string url;
};

double wrap(double angle) { return std::remainder(angle, 2 * kPi); }

// What a walk did, judged through doppel-ctl state: simulation time passed, the move in the frame
// of the pose it started from, and whether it fell.
struct Walked {
  int code = -1;
  std::string output;
  double sim_s = 0, forward_m = 0, sideways_m = 0, turned_rad = 0;
  bool fallen = true;
};

// Runs doppel-walk with `arguments`; with a `push` (doppel-ctl push's FX FY FZ MS), pushes robot 0
// once `push_at_s` seconds of simulation time have passed since the start.
Walked walk(const WalkingDoppel& doppel, const std::string& arguments, const std::string& push = "", double push_at_s = 0) {
  const json before = doppel.state();
  Walked w;
  if (push.empty()) {
    std::tie(w.code, w.output) = doppel.walk(arguments);
  } else {
    std::thread walker([&] { std::tie(w.code, w.output) = doppel.walk(arguments); });
    const double t0 = before["sim_time_s"].get<double>();
    while (doppel.state()["sim_time_s"].get<double>() < t0 + push_at_s) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));  // polling pace; judged on sim time
    }
    const auto [push_code, push_output] = doppel.ctl("push 0 " + push);
    walker.join();
    EXPECT_EQ(push_code, 0) << push_output;
  }
  const json after = doppel.state();
  const json& start = before["robots"][0]["pose"];
  const json& end = after["robots"][0]["pose"];
  const double yaw0 = start["yaw"].get<double>();
  const double dx = end["x"].get<double>() - start["x"].get<double>();
  const double dy = end["y"].get<double>() - start["y"].get<double>();
  w.sim_s = after["sim_time_s"].get<double>() - before["sim_time_s"].get<double>();
  w.forward_m = dx * std::cos(yaw0) + dy * std::sin(yaw0);
  w.sideways_m = -dx * std::sin(yaw0) + dy * std::cos(yaw0);
  w.turned_rad = wrap(end["yaw"].get<double>() - yaw0);
  w.fallen = after["robots"][0]["fallen"].get<bool>();
  std::printf("%s: exit %d, %.1f s of simulation, forward %.2f m, sideways %.2f m, turned %+.2f rad%s\n", arguments.c_str(),
              w.code, w.sim_s, w.forward_m, w.sideways_m, w.turned_rad, w.fallen ? ", fallen" : "");
  return w;
}

// --seconds 30 --speed 0.05: 1 s stand-up, 1 s ramp in, 26 s, 1 s ramp out (the ramps count half),
// so 27 s x 0.05 m/s = 1.35 m commanded over the walk's own 30 s. Those are simulated seconds for
// the default robot; the DARwIn-OP's walk paces by the wall clock, so under load its 30 s of steps
// take less simulation time: the issue's floor of 1 m counts per 30 s of simulation, the commanded
// distance per walk.
void expect_walks_straight_forward(const WalkingDoppel& doppel, double min_sim_s) {
  const Walked w = walk(doppel, "--seconds 30 --speed 0.05");
  EXPECT_EQ(w.code, 0) << w.output;
  EXPECT_GE(w.sim_s, min_sim_s) << "doppel fell far behind real time";
  EXPECT_FALSE(w.fallen) << w.output;
  EXPECT_GE(w.forward_m * 30.0 / std::max(w.sim_s, 1.0), 1.0) << "the issue's floor: 1 m in 30 s of simulation";
  EXPECT_NEAR(w.forward_m, 1.35, kSpeedTolerance * 1.35) << "the commanded speed";
  EXPECT_LT(std::fabs(w.turned_rad), kHeadingTolerance) << "the heading is held by the IMU";
}

// --seconds 5 --turn 0.3: 1 s stand-up, 1 s ramp in, 2 s, 1 s ramp out: 3 s x 0.3 rad/s = 0.9 rad
// commanded, short enough that the turn stays below pi and its sign is unambiguous.
void expect_turns_in_place(const WalkingDoppel& doppel, double max_moved_m) {
  const Walked w = walk(doppel, "--seconds 5 --speed 0 --turn 0.3");
  EXPECT_EQ(w.code, 0) << w.output;
  EXPECT_FALSE(w.fallen) << w.output;
  EXPECT_NEAR(w.turned_rad, 0.9, kTurnTolerance * 0.9) << "the commanded turn";
  EXPECT_LT(std::hypot(w.forward_m, w.sideways_m), max_moved_m) << "in place";
}

// A push on the trunk for 100 ms at 8 s of simulation time, while walking forward: the walk goes on
// and the robot stands at the end.
void expect_keeps_walking_after_push(const WalkingDoppel& doppel, const std::string& push) {
  const Walked w = walk(doppel, "--seconds 15 --speed 0.05", push, 8);
  EXPECT_EQ(w.code, 0) << w.output;
  EXPECT_FALSE(w.fallen) << w.output;
}

class Walk : public ::testing::TestWithParam<std::string> {};

TEST_P(Walk, ForwardAtLeastOneMetreInThirtySimulatedSecondsWithoutFalling) {
  expect_walks_straight_forward(WalkingDoppel(GetParam()), 30.0);
}

TEST_P(Walk, TurnsLeftInPlaceWithoutFalling) { expect_turns_in_place(WalkingDoppel(GetParam()), 0.15); }

// docs/walk.md's push table: the largest sideways push survived in every run.
TEST_P(Walk, KeepsWalkingAfterASidewaysPush) {
  expect_keeps_walking_after_push(WalkingDoppel(GetParam()), kPushSideways);
}

INSTANTIATE_TEST_SUITE_P(Engines, Walk, ::testing::Values("ode", "bullet"));

TEST(LegIk, TheDarwinOpsWalkReadyPoseComesBack) {
  // data/robots/darwin-op.textproto: thigh = shank = 93 mm, ankle 33.5 mm, hips 219.5 mm up at straight
  // legs; walk-ready hip pitch -23.2, knee 53.17, ankle pitch -29.97 deg (initial_deg).
  const walk::LegGeometry leg{0.093, 0.093, 0.0335, 0.2195, 0.037};
  const double hip = -23.2 * kDeg, knee = 53.17 * kDeg;
  // Thigh forward by -hip, shank back by knee + hip from the vertical.
  const double x = -leg.thigh_m * std::sin(hip) - leg.shank_m * std::sin(knee + hip);
  const double z = leg.hip_height_m - leg.thigh_m * std::cos(hip) - leg.shank_m * std::cos(knee + hip) - leg.ankle_height_m;
  walk::LegAngles a;
  ASSERT_TRUE(walk::leg_ik(leg, x, 0, z, 0, a));
  EXPECT_NEAR(a.hip_pitch, hip, 1e-6);
  EXPECT_NEAR(a.knee, knee, 1e-6);
  EXPECT_NEAR(a.ankle_pitch, -29.97 * kDeg, 0.001);
}

// The DARwIn-OP (data/robots/darwin-op.textproto) through the same walk: doppel-walk powers the servos
// through the CM-730 and paces by an 8 ms wall-clock cycle (no sample counter).
class DarwinWalk : public ::testing::TestWithParam<std::string> {};

TEST_P(DarwinWalk, ForwardAtLeastOneMetreInThirtySimulatedSecondsWithoutFalling) {
  expect_walks_straight_forward(WalkingDoppel(GetParam(), "darwin-op"), 20.0);
}

// Stepping in place this gait drifts a little on the DARwIn-OP (docs/walk.md).
TEST_P(DarwinWalk, TurnsLeftInPlaceWithoutFalling) { expect_turns_in_place(WalkingDoppel(GetParam(), "darwin-op"), 0.2); }

// The default robot's push scaled to the DARwIn-OP's mass (2.9 kg against 4.7 kg).
TEST_P(DarwinWalk, KeepsWalkingAfterASidewaysPush) {
  expect_keeps_walking_after_push(WalkingDoppel(GetParam(), "darwin-op"), kDarwinPushSideways);
}

INSTANTIATE_TEST_SUITE_P(Engines, DarwinWalk, ::testing::Values("ode", "bullet"));

}  // namespace
}  // namespace doppel::testing
