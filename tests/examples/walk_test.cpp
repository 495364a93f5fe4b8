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
#include <chrono>

#include <nlohmann/json.hpp>

#include "doppel_process.h"
#include "gait.h"

namespace doppel::testing {
namespace {

using nlohmann::json;
constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180;

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
  json state() const {
    const auto [code, output] = run_command(std::string(DOPPEL_CTL) + " --url " + url + " state");
    EXPECT_EQ(code, 0) << output;
    return json::parse(output);
  }
  std::pair<int, std::string> walk(const std::string& arguments) const {
    // DARwIn-OP: the framework's leg gain, P 32 (darwin_op_framework.h), which Doppel's MX PID scale
    // (Rhoban's measurement, docs/devices.md "Servo gains") makes as stiff as P 64 was before it;
    // doppel-walk's own default, 64, is now twice as stiff.
    const std::string which = robot == "darwin-op" ? " --robot darwin-op --p-gain 32" : "";
    return run_command(std::string(DOPPEL_WALK) + " --port " + doppel.link() + which + " " + arguments);
  }
  DoppelProcess doppel;
  std::string robot;
  std::string url;
};

double wrap(double angle) { return std::remainder(angle, 2 * kPi); }

class Walk : public ::testing::TestWithParam<std::string> {};

// The walk is not robust yet: in about 1 run of 8 the default robot falls sideways (docs/walk.md).
// One retry with a fresh doppel, the first attempt printed; two failed attempts fail the test.
TEST_P(Walk, ForwardAtLeastOneMetreInThirtySimulatedSecondsWithoutFalling) {
  for (int attempt = 1; attempt <= 2; ++attempt) {
    WalkingDoppel doppel(GetParam());
    const json before = doppel.state();
    const json start = before["robots"][0]["pose"];
    const auto [code, output] = doppel.walk("--seconds 30 --speed 0.05");
    const json after = doppel.state();
    const json end = after["robots"][0]["pose"];
    const double sim_s = after["sim_time_s"].get<double>() - before["sim_time_s"].get<double>();
    const bool fallen = after["robots"][0]["fallen"].get<bool>();
    // Progress along the heading it started with.
    const double yaw0 = start["yaw"].get<double>();
    const double dx = end["x"].get<double>() - start["x"].get<double>();
    const double dy = end["y"].get<double>() - start["y"].get<double>();
    const double forward = dx * std::cos(yaw0) + dy * std::sin(yaw0);
    if (attempt == 1 && (code != 0 || fallen || forward < 1.0)) {
      std::printf("%s: attempt 1 failed (exit %d, forward %.2f m): %s; retrying once\n", GetParam().c_str(), code,
                  forward, output.c_str());
      continue;
    }
    EXPECT_EQ(code, 0) << output;
    EXPECT_GE(sim_s, 30.0);
    EXPECT_FALSE(fallen) << output;
    EXPECT_GE(forward, 1.0) << "walked dx " << dx << " dy " << dy << " m; " << output;
    std::printf("%s: forward %.2f m, sideways %.2f m, yaw %.2f rad in 30 s\n", GetParam().c_str(), forward,
                -dx * std::sin(yaw0) + dy * std::cos(yaw0), wrap(end["yaw"].get<double>() - yaw0));
    break;
  }
}

TEST_P(Walk, TurnsLeftInPlaceWithoutFalling) {
  WalkingDoppel doppel(GetParam());
  const json before = doppel.state();
  const json start = before["robots"][0]["pose"];
  // 5 s: 1 s stand-up, 1 s ramp in, 2 s turning, 1 s ramp out; short enough that the turn stays
  // below pi and its sign is unambiguous.
  const auto [code, output] = doppel.walk("--seconds 5 --speed 0 --turn 0.3");
  EXPECT_EQ(code, 0) << output;
  const json after = doppel.state();
  const json end = after["robots"][0]["pose"];
  EXPECT_FALSE(after["robots"][0]["fallen"].get<bool>()) << output;
  const double turned = wrap(end["yaw"].get<double>() - start["yaw"].get<double>());
  const double moved = std::hypot(end["x"].get<double>() - start["x"].get<double>(), end["y"].get<double>() - start["y"].get<double>());
  EXPECT_GT(turned, 0.4) << "turned " << turned << " rad; " << output;
  EXPECT_LT(moved, 0.15) << "in place: moved " << moved << " m";
  std::printf("%s: turned %.2f rad, moved %.3f m in 5 s\n", GetParam().c_str(), turned, moved);
}

// docs/walk.md's push: 5 N sideways on the trunk for 100 ms (0.5 N s) at 8 s of simulation time,
// while walking forward; the walk goes on and the robot is standing at the end. 10 N fells it in
// some runs: the push lands at another phase of the gait each run (the walk starts on the wall clock).
TEST_P(Walk, KeepsWalkingAfterASidewaysPush) {
  for (int attempt = 1; attempt <= 2; ++attempt) {  // one retry, as the forward walk above
    WalkingDoppel doppel(GetParam());
    const double t0 = doppel.state()["sim_time_s"].get<double>();
    std::pair<int, std::string> walked;
    std::thread walker([&] { walked = doppel.walk("--seconds 15 --speed 0.05"); });
    while (doppel.state()["sim_time_s"].get<double>() < t0 + 8) {
      std::this_thread::sleep_for(std::chrono::milliseconds(100));  // polling pace; judged on sim time
    }
    const auto [push_code, push_output] = run_command(std::string(DOPPEL_CTL) + " --url " + doppel.url + " push 0 0 5 0 100");
    walker.join();
    const bool fallen = doppel.state()["robots"][0]["fallen"].get<bool>();
    if (attempt == 1 && (walked.first != 0 || fallen)) {
      std::printf("%s: attempt 1 failed (exit %d): %s; retrying once\n", GetParam().c_str(), walked.first, walked.second.c_str());
      continue;
    }
    EXPECT_EQ(push_code, 0) << push_output;
    EXPECT_EQ(walked.first, 0) << walked.second;
    EXPECT_FALSE(fallen) << walked.second;
    break;
  }
}

INSTANTIATE_TEST_SUITE_P(Engines, Walk, ::testing::Values("ode", "bullet"));

TEST(LegIk, TheDarwinOpsWalkReadyPoseComesBack) {
  // robots/darwin-op.textproto: thigh = shank = 93 mm, ankle 33.5 mm, hips 219.5 mm up at straight
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

// The DARwIn-OP (robots/darwin-op.textproto) through the same walk: doppel-walk powers the servos
// through the CM-730, paces by an 8 ms wall-clock cycle (no sample counter), and the distance is
// judged on doppel-ctl's pose over at least 30 s of simulation time.
class DarwinWalk : public ::testing::TestWithParam<std::string> {};

TEST_P(DarwinWalk, ForwardAtLeastOneMetreInThirtySimulatedSecondsWithoutFalling) {
  WalkingDoppel doppel(GetParam(), "darwin-op");
  const json before = doppel.state();
  const json start = before["robots"][0]["pose"];
  const auto [code, output] = doppel.walk("--seconds 30 --speed 0.05");
  EXPECT_EQ(code, 0) << output;
  const json after = doppel.state();
  const json end = after["robots"][0]["pose"];
  const double sim_s = after["sim_time_s"].get<double>() - before["sim_time_s"].get<double>();
  EXPECT_FALSE(after["robots"][0]["fallen"].get<bool>()) << output;
  const double yaw0 = start["yaw"].get<double>();
  const double dx = end["x"].get<double>() - start["x"].get<double>();
  const double dy = end["y"].get<double>() - start["y"].get<double>();
  const double forward = dx * std::cos(yaw0) + dy * std::sin(yaw0);
  // The walk ran 30 s of wall clock; the distance counts per simulated second.
  EXPECT_GE(sim_s, 25.0) << "doppel fell far behind real time";
  EXPECT_GE(forward * 30.0 / std::max(sim_s, 1.0), 1.0) << "walked dx " << dx << " dy " << dy << " m in " << sim_s << " s; " << output;
  std::printf("darwin-op %s: forward %.2f m, sideways %.2f m, yaw %.2f rad in %.1f s of simulation\n", GetParam().c_str(),
              forward, -dx * std::sin(yaw0) + dy * std::cos(yaw0), wrap(end["yaw"].get<double>() - yaw0), sim_s);
}

TEST_P(DarwinWalk, TurnsLeftInPlaceWithoutFalling) {
  WalkingDoppel doppel(GetParam(), "darwin-op");
  const json start = doppel.state()["robots"][0]["pose"];
  // As the default robot's turn: 1 s stand-up, 1 s ramp in, 2 s turning, 1 s ramp out.
  const auto [code, output] = doppel.walk("--seconds 5 --speed 0 --turn 0.3");
  EXPECT_EQ(code, 0) << output;
  const json after = doppel.state();
  const json end = after["robots"][0]["pose"];
  EXPECT_FALSE(after["robots"][0]["fallen"].get<bool>()) << output;
  const double turned = wrap(end["yaw"].get<double>() - start["yaw"].get<double>());
  const double moved = std::hypot(end["x"].get<double>() - start["x"].get<double>(), end["y"].get<double>() - start["y"].get<double>());
  EXPECT_GT(turned, 0.4) << "turned " << turned << " rad; " << output;
  // Stepping in place this gait drifts on the DARwIn-OP (docs/walk.md): 0.12-0.14 m measured.
  EXPECT_LT(moved, 0.2) << "in place: moved " << moved << " m";
  std::printf("darwin-op %s: turned %.2f rad, moved %.3f m in 5 s\n", GetParam().c_str(), turned, moved);
}

// The default robot's push scaled to the DARwIn-OP's mass (2.9 kg against 4.7 kg): 3 N sideways on
// the trunk for 100 ms (0.3 N s) at 8 s of simulation time, while walking forward.
TEST_P(DarwinWalk, KeepsWalkingAfterASidewaysPush) {
  WalkingDoppel doppel(GetParam(), "darwin-op");
  const double t0 = doppel.state()["sim_time_s"].get<double>();
  std::pair<int, std::string> walked;
  std::thread walker([&] { walked = doppel.walk("--seconds 15 --speed 0.05"); });
  while (doppel.state()["sim_time_s"].get<double>() < t0 + 8) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));  // polling pace; judged on sim time
  }
  const auto [push_code, push_output] = run_command(std::string(DOPPEL_CTL) + " --url " + doppel.url + " push 0 0 3 0 100");
  EXPECT_EQ(push_code, 0) << push_output;
  walker.join();
  EXPECT_EQ(walked.first, 0) << walked.second;
  EXPECT_FALSE(doppel.state()["robots"][0]["fallen"].get<bool>()) << walked.second;
}

INSTANTIATE_TEST_SUITE_P(Engines, DarwinWalk, ::testing::Values("ode", "bullet"));

}  // namespace
}  // namespace doppel::testing
