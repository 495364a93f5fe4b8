// Simulation control end to end: doppel with its control API on a free loopback port, driven with
// doppel-ctl as a user would, while the robot's bus is read through its pty. Judged on simulation
// time (the IMU's Sample Counter, +1 per 20 ms sample) and on the state doppel-ctl prints.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <regex>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "controlled_doppel.h"
#include "reference_client.h"
#include "sim_time.h"

namespace doppel::testing {
namespace {

using nlohmann::json;

constexpr uint32_t kBaud = 1000000;
constexpr uint8_t kRead = 0x02, kWrite = 0x03, kPing = 0x01;
constexpr uint8_t kTorqueEnable = 24;

TEST(SimControl, PauseFreezesTheWorldWhileTheBusAnswersAndStepRunsExactlyWhatWasAsked) {
  ControlledDoppel doppel({"--physics", "ode"});
  SerialClient client(doppel.doppel.link(), kBaud);
  wait_sim_time(client, 0.1);

  const json paused = doppel.ok("pause");
  EXPECT_EQ(paused["paused"], true);
  const uint16_t frozen = imu_sample_counter(client);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_EQ(imu_sample_counter(client), frozen) << "the IMU kept sampling while paused";
  EXPECT_EQ(client.transact(p1_instruction(15, kPing), 6).size(), 6u) << "a servo stopped answering while paused";
  const double t0 = doppel.ok("state")["sim_time_s"].get<double>();
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_EQ(doppel.ok("state")["sim_time_s"].get<double>(), t0);

  const json stepped = doppel.ok("step 100");
  EXPECT_NEAR(stepped["sim_time_s"].get<double>() - t0, 0.100, 1e-9);
  EXPECT_EQ(stepped["paused"], true);
  EXPECT_EQ(static_cast<uint16_t>(imu_sample_counter(client) - frozen), 5) << "100 ms are five 20 ms IMU samples";

  EXPECT_EQ(doppel.ok("resume")["paused"], false);
  wait_sim_time(client, 0.06);
  EXPECT_GT(doppel.ok("state")["sim_time_s"].get<double>(), t0 + 0.1);
}

TEST(SimControl, PlaceMovesTheRobotAndResetPowersItOnWhereItStarted) {
  ControlledDoppel doppel({"--physics", "ode"});
  SerialClient client(doppel.doppel.link(), kBaud);
  const json start = doppel.ok("state")["robots"][0];
  EXPECT_EQ(start["name"], "fumanoid-2011");
  EXPECT_EQ(start["held"], true);

  const json placed = doppel.ok("place 0 1.0 -0.5 1.5708")["robots"][0];
  EXPECT_NEAR(placed["pose"]["x"].get<double>(), 1.0, 0.01);
  EXPECT_NEAR(placed["pose"]["y"].get<double>(), -0.5, 0.01);
  EXPECT_NEAR(placed["pose"]["yaw"].get<double>(), 1.5708, 0.02);
  EXPECT_EQ(placed["fallen"], false);

  client.send(p1_instruction(0xFE, kWrite, {kTorqueEnable, 1}));  // the driver takes over: the handler lets go
  wait_sim_time(client, 0.2);
  EXPECT_EQ(doppel.ok("state")["robots"][0]["held"], false);

  const json reset = doppel.ok("reset")["robots"][0];
  EXPECT_EQ(reset["held"], true);
  EXPECT_NEAR(reset["pose"]["x"].get<double>(), start["pose"]["x"].get<double>(), 0.01);
  EXPECT_NEAR(reset["pose"]["y"].get<double>(), start["pose"]["y"].get<double>(), 0.01);
  EXPECT_NEAR(reset["pose"]["yaw"].get<double>(), start["pose"]["yaw"].get<double>(), 0.02);
  // The servos powered on again: Torque Enable is back to its power-on 0 (within a bus tick).
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  const Bytes torque = client.transact(p1_instruction(15, kRead, {kTorqueEnable, 1}), 7);
  ASSERT_EQ(torque.size(), 7u);
  EXPECT_EQ(torque[5], 0);
  wait_sim_time(client, 0.2);
  EXPECT_EQ(doppel.ok("state")["robots"][0]["held"], true) << "the old torque commands released it again";
}

TEST(SimControl, APushSidewaysFellsTheStandingRobot) {
  ControlledDoppel doppel({"--physics", "ode"});
  SerialClient client(doppel.doppel.link(), kBaud);
  client.send(p1_instruction(0xFE, kWrite, {kTorqueEnable, 1}));
  wait_sim_time(client, 0.5);
  ASSERT_EQ(doppel.ok("state")["robots"][0]["fallen"], false);

  doppel.ok("push fumanoid-2011 0 60 0 300");  // 18 N s into a 4.7 kg robot: nearly 4 m/s sideways
  wait_sim_time(client, 2);
  const json robot = doppel.ok("state")["robots"][0];
  EXPECT_EQ(robot["fallen"], true) << robot.dump();
  EXPECT_GT(robot["tilt"].get<double>(), M_PI / 4);
}

TEST(SimControl, BadRequestsAreRefusedWithTheReasonAndChangeNothing) {
  ControlledDoppel doppel({"--physics", "ode"});
  const json before = doppel.ok("state")["robots"][0]["pose"];
  const struct {
    const char* arguments;
    const char* reason;
  } refusals[] = {
      {"place 7 0 0 0", "no robot 7"},
      {"place nao 0 0 0", "no robot named 'nao'"},
      {"place 0 40 0 0", "off the carpet"},
      {"push 0 5000 0 0 10", "more than 1000 N"},
      {"step 10", "pause first"},
  };
  for (const auto& refusal : refusals) {
    const auto [code, output] = doppel.ctl(refusal.arguments);
    EXPECT_EQ(code, 1) << refusal.arguments << ": " << output;
    EXPECT_NE(output.find(refusal.reason), std::string::npos) << refusal.arguments << ": " << output;
  }
  const json after = doppel.ok("state")["robots"][0]["pose"];
  EXPECT_NEAR(after["x"].get<double>(), before["x"].get<double>(), 1e-3);  // a held robot settles by microns
  EXPECT_NEAR(after["y"].get<double>(), before["y"].get<double>(), 1e-3);
  EXPECT_EQ(doppel.ok("state")["paused"], false);
}

TEST(SimControl, DoppelCtlSaysWhenNoDoppelListens) {
  const auto [code, output] = run_command(std::string(DOPPEL_CTL) + " --url http://127.0.0.1:1 state");
  EXPECT_EQ(code, 2);
  EXPECT_NE(output.find("cannot reach doppel at http://127.0.0.1:1"), std::string::npos) << output;
}

TEST(SimControl, APortInUseThatTheUserNamedStopsDoppelWithTheReason) {
  ControlledDoppel first({"--physics", "none"});
  const std::string port = first.url.substr(first.url.rfind(':') + 1);
  const auto [code, output] =
      run_command(doppel_executable() + " --no-camera --physics none --link-dir /tmp/doppel-test-port-" + port +
                  " --viewer " + port);
  EXPECT_NE(code, 0);
  EXPECT_NE(output.find("--viewer: cannot listen on 127.0.0.1:" + port), std::string::npos) << output;
}

}  // namespace
}  // namespace doppel::testing
