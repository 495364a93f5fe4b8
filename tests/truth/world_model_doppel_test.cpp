// The world-model sensor end to end with the real doppel (--world-model): the placed ball comes
// back within 1 mm with noise off; a session scene built for the constraints (extra balls: one
// behind the robot and nearest of all, one off to the side, two ahead) shows the field of view and
// nearest-ball rules, changed while running through doppel-ctl; bad settings are refused naming
// the field. Messages arrive over UDP on loopback (no RouDi); iceoryx: world_model_iceoryx_test.cpp.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <string>

#include "truth_doppel.h"

namespace doppel::testing {
namespace {

using nlohmann::json;
using proto::truth::WorldModel;

std::vector<uint32_t> balls(const WorldModel& m) {
  std::vector<uint32_t> out;
  for (const auto& b : m.balls()) out.push_back(b.index());
  return out;
}

TEST(WorldModelDoppel, WithNoiseOffThePlacedBallComesBackWithinOneMillimetre) {
  TruthDoppel doppel({"--physics", "ode"});
  const json placed = doppel.ok("ball 0.7 -0.4");
  const auto after_ns = static_cast<int64_t>(placed["sim_time_s"].get<double>() * 1e9);
  const WorldModel m = doppel.next([&](const WorldModel& w) { return w.world_time_ns() > after_ns; });
  ASSERT_EQ(m.balls_size(), 1) << m.DebugString();
  EXPECT_EQ(m.balls(0).index(), 0u);
  EXPECT_NEAR(m.balls(0).field().x_m(), 0.7, 1e-3);
  EXPECT_NEAR(m.balls(0).field().y_m(), -0.4, 1e-3);
  // Relative to the robot as the state reports its pose (held: it does not move).
  const json pose = doppel.ok("state")["robots"][0]["pose"];
  const double x = pose["x"], y = pose["y"], yaw = pose["yaw"];
  EXPECT_NEAR(m.pose().x_m(), x, 1e-3);
  EXPECT_NEAR(m.pose().y_m(), y, 1e-3);
  EXPECT_NEAR(m.pose().yaw_rad(), yaw, 1e-3);
  const double dx = 0.7 - x, dy = -0.4 - y;
  EXPECT_NEAR(m.balls(0).relative().x_m(), std::cos(yaw) * dx + std::sin(yaw) * dy, 1e-3);
  EXPECT_NEAR(m.balls(0).relative().y_m(), -std::sin(yaw) * dx + std::cos(yaw) * dy, 1e-3);
  EXPECT_NEAR(m.balls(0).relative().distance_m(), std::hypot(dx, dy), 1e-3);
  EXPECT_EQ(m.goal_posts_size(), 4);
  EXPECT_EQ(m.side_poles_size(), 2);
  EXPECT_EQ(m.landmarks_size(), 19);
}

TEST(WorldModelDoppel, FieldOfViewAndNearestBallHoldInASceneBuiltForThem) {
  // Robot 0 stands at (-1, -0.8) facing +x (gateway kick-off spot). Ball 0 on the centre spot is
  // 38.7 deg to its left; ball 1 is 0.5 m behind it (nearest of all); balls 2 and 3 are 1 m and
  // 2 m straight ahead.
  const std::string session = ::testing::TempDir() + "/truth_scene.textproto";
  std::ofstream(session) << "ball { position_m { x: -1.5 y: -0.8 } }\n"
                            "ball { position_m { x: 0.0 y: -0.8 } }\n"
                            "ball { position_m { x: 1.0 y: -0.8 } }\n";
  TruthDoppel doppel({"--physics", "ode", "--session", session, "--world-model-fov", "60"});
  const int64_t fresh = static_cast<int64_t>(doppel.ok("state")["sim_time_s"].get<double>() * 1e9);
  // 60 deg about the head camera's axis: the two ahead; not the one behind, nor the centre spot's.
  WorldModel m = doppel.next([&](const WorldModel& w) { return w.world_time_ns() > fresh; });
  EXPECT_EQ(balls(m), (std::vector<uint32_t>{2, 3})) << m.DebugString();
  EXPECT_NEAR(m.fov_deg(), 60.0, 0.0);
  for (const auto& post : m.goal_posts()) EXPECT_EQ(post.goal(), proto::truth::GoalPost::YELLOW) << "blue goal is behind";
  for (const auto& b : m.balls()) EXPECT_LE(std::abs(b.relative().bearing_rad()), 30.0 * M_PI / 180.0 + 0.05);

  json changed = doppel.ok("world-model 0 --nearest-ball true");
  EXPECT_EQ(changed["nearest_ball_only"], true);
  int64_t since = static_cast<int64_t>(doppel.ok("state")["sim_time_s"].get<double>() * 1e9);
  m = doppel.next([&](const WorldModel& w) { return w.world_time_ns() > since; });
  EXPECT_EQ(balls(m), (std::vector<uint32_t>{2})) << "the nearest in view, not ball 1 behind";

  doppel.ok("world-model 0 --fov 0");
  since = static_cast<int64_t>(doppel.ok("state")["sim_time_s"].get<double>() * 1e9);
  m = doppel.next([&](const WorldModel& w) { return w.world_time_ns() > since; });
  EXPECT_EQ(balls(m), (std::vector<uint32_t>{1})) << "all around: the one behind is the nearest";
  EXPECT_EQ(m.goal_posts_size(), 4);

  const auto [code, output] = doppel.ctl("world-model 0 --dropout 1.5");
  EXPECT_EQ(code, 1) << output;
  EXPECT_NE(output.find("dropout"), std::string::npos) << output;
  const auto [code2, output2] = doppel.ctl("world-model 0 --fov 180");
  EXPECT_EQ(code2, 1) << output2;
  EXPECT_NE(output2.find("fov_deg"), std::string::npos) << output2;
  EXPECT_EQ(doppel.ok("world-model 0")["fov_deg"], 0.0) << "a refused change changes nothing";
}

TEST(WorldModelDoppel, ABadSessionBallIsRefusedNamingFileAndField) {
  const std::string session = ::testing::TempDir() + "/truth_bad_ball.textproto";
  std::ofstream(session) << "ball { position_m { x: 9.0 y: 0.0 } }\n";
  const auto [code, output] = run_command(doppel_executable() + " --no-camera --no-viewer --world-model --session " + session);
  EXPECT_NE(code, 0);
  EXPECT_NE(output.find("truth_bad_ball.textproto:1"), std::string::npos) << output;
  EXPECT_NE(output.find("position_m"), std::string::npos) << output;
}

}  // namespace
}  // namespace doppel::testing
