// The world-model sensor's computation (truth/world_model.h) against hand-computed geometry and
// statistics: the robot-relative transform, the field of view and range, nearest ball only, the
// field's objects from physics/field.h, dropout within binomial bounds, Gaussian noise, latency and
// rate in simulation time, and settings refused by the field they are wrong in.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "truth/world_model.h"

namespace doppel::truth {
namespace {

using contract::WorldModelSettings;
constexpr double kDeg = std::numbers::pi / 180.0;

RobotSample robot_at(double x, double y, double yaw_rad, uint8_t team = 0) {
  RobotSample r;
  r.present = true;
  r.team = team;
  r.x_m = r.view_x_m = x;
  r.y_m = r.view_y_m = y;
  r.yaw_rad = r.view_yaw_rad = yaw_rad;
  return r;
}

WorldSample sample_with_balls(const std::vector<std::array<double, 2>>& balls, int64_t t_ns = 0) {
  WorldSample s;
  s.sim_time_ns = t_ns;
  s.robots[0] = robot_at(0.0, 0.0, 0.0);
  s.ball_count = static_cast<uint32_t>(balls.size());
  for (std::size_t b = 0; b < balls.size(); ++b) s.balls[b] = {balls[b][0], balls[b][1], 0.0335};
  return s;
}

std::vector<uint32_t> ball_indices(const proto::truth::WorldModel& m) {
  std::vector<uint32_t> out;
  for (const auto& b : m.balls()) out.push_back(b.index());
  return out;
}

TEST(WorldModel, RelativeTransformMatchesHandComputedGeometry) {
  // Robot at (1, 2) facing +y: a point 1 m to the north is straight ahead, one 1 m west is on its left.
  proto::truth::Relative ahead = relative_to(1.0, 2.0, 90 * kDeg, 1.0, 3.0);
  EXPECT_NEAR(ahead.x_m(), 1.0, 1e-12);
  EXPECT_NEAR(ahead.y_m(), 0.0, 1e-12);
  EXPECT_NEAR(ahead.distance_m(), 1.0, 1e-12);
  EXPECT_NEAR(ahead.bearing_rad(), 0.0, 1e-12);
  proto::truth::Relative left = relative_to(1.0, 2.0, 90 * kDeg, 0.0, 2.0);
  EXPECT_NEAR(left.x_m(), 0.0, 1e-12);
  EXPECT_NEAR(left.y_m(), 1.0, 1e-12);
  EXPECT_NEAR(left.bearing_rad(), 90 * kDeg, 1e-12);
  // Robot at (-1, -0.8) heading 30 deg, the centre spot: d = (1, 0.8) rotated by -30 deg:
  // x = cos30 + 0.8 sin30 = 1.2660254, y = -sin30 + 0.8 cos30 = 0.1928203.
  proto::truth::Relative centre = relative_to(-1.0, -0.8, 30 * kDeg, 0.0, 0.0);
  EXPECT_NEAR(centre.x_m(), 1.2660254038, 1e-9);
  EXPECT_NEAR(centre.y_m(), 0.1928203230, 1e-9);
  EXPECT_NEAR(centre.distance_m(), std::sqrt(1.0 + 0.64), 1e-12);
  EXPECT_NEAR(centre.bearing_rad(), std::atan2(0.1928203230, 1.2660254038), 1e-9);
  // Behind, slightly right: bearing near -180 deg, not +180.
  EXPECT_NEAR(relative_to(0.0, 0.0, 0.0, -1.0, -1e-6).bearing_rad(), -std::numbers::pi, 1e-5);
}

TEST(WorldModel, FieldOfViewEdgesAndRange) {
  WorldModelSettings s;
  s.fov_deg = 90.0;
  const RobotSample r = robot_at(0.0, 0.0, 0.0);
  auto at_bearing = [&](double deg, double d = 1.0) { return in_view(r, s, d * std::cos(deg * kDeg), d * std::sin(deg * kDeg)); };
  EXPECT_TRUE(at_bearing(0.0));
  EXPECT_TRUE(at_bearing(44.9));
  EXPECT_TRUE(at_bearing(-44.9));
  EXPECT_FALSE(at_bearing(45.1));
  EXPECT_FALSE(at_bearing(-45.1));
  EXPECT_FALSE(at_bearing(180.0));
  // The view's centre line near +-180 deg: an object across the wrap is 20 deg off the axis.
  RobotSample turned = robot_at(0.0, 0.0, 170 * kDeg);
  s.fov_deg = 60.0;
  EXPECT_TRUE(in_view(turned, s, std::cos(-170 * kDeg), std::sin(-170 * kDeg)));
  EXPECT_FALSE(in_view(turned, s, std::cos(-130 * kDeg), std::sin(-130 * kDeg)));
  // The field of view starts at the camera, not at the robot's origin: apex 0.1 m ahead.
  RobotSample camera = robot_at(0.0, 0.0, 0.0);
  camera.view_x_m = 0.1;
  s.fov_deg = 90.0;
  EXPECT_FALSE(in_view(camera, s, 0.05, 0.02));  // ahead of the robot but behind its camera
  // 0 = all around; range limits either way.
  s.fov_deg = 0.0;
  EXPECT_TRUE(at_bearing(180.0));
  s.max_range_m = 2.0;
  EXPECT_TRUE(at_bearing(180.0, 1.99));
  EXPECT_FALSE(at_bearing(180.0, 2.01));
  EXPECT_FALSE(at_bearing(0.0, 2.01));
}

TEST(WorldModel, NearestBallOnlyReportsTheNearestBallInViewNotTheNearestBehind) {
  const FieldObjects field = field_objects();
  std::mt19937_64 rng(1);
  // Ball 1 is nearest of all but behind the robot; ball 2 is the nearest in view; ball 0 farther ahead.
  const WorldSample s = sample_with_balls({{2.0, 0.1}, {-0.3, 0.0}, {1.0, -0.2}});
  WorldModelSettings settings;
  settings.fov_deg = 120.0;
  EXPECT_EQ(ball_indices(build_world_model(s, 0, settings, field, rng, 0, 1)), (std::vector<uint32_t>{0, 2}));
  settings.nearest_ball_only = true;
  const proto::truth::WorldModel m = build_world_model(s, 0, settings, field, rng, 0, 1);
  ASSERT_EQ(ball_indices(m), (std::vector<uint32_t>{2}));
  EXPECT_NEAR(m.balls(0).field().x_m(), 1.0, 1e-12);
  EXPECT_NEAR(m.balls(0).relative().distance_m(), std::hypot(1.0, 0.2), 1e-12);
  settings.fov_deg = 0.0;  // all around: now the one behind is the nearest
  EXPECT_EQ(ball_indices(build_world_model(s, 0, settings, field, rng, 0, 1)), (std::vector<uint32_t>{1}));
  settings.fov_deg = 30.0;  // none in view: no ball at all
  const WorldSample far = sample_with_balls({{0.0, 2.0}, {-1.0, 0.0}});
  EXPECT_TRUE(ball_indices(build_world_model(far, 0, settings, field, rng, 0, 1)).empty());
}

TEST(WorldModel, FieldObjectsComeFromTheFieldSpec) {
  const physics::FieldSpec spec;
  const FieldObjects field = field_objects(spec);
  ASSERT_EQ(field.posts.size(), 4u);
  const double post_y = 0.5 * spec.goal_width_m + 0.5 * spec.goal_post_diameter_m;  // 0.8 m: post centres
  for (const auto& post : field.posts) {
    const bool yellow = post.goal == proto::truth::GoalPost::YELLOW;
    EXPECT_DOUBLE_EQ(post.x_m, yellow ? 3.0 : -3.0);
    EXPECT_DOUBLE_EQ(std::abs(post.y_m), post_y);
    // Left seen from the field looking into the goal: +y for the yellow goal, -y for the blue one.
    EXPECT_EQ(post.left, yellow ? post.y_m > 0.0 : post.y_m < 0.0);
  }
  ASSERT_EQ(field.poles.size(), 2u);
  for (const auto& pole : field.poles) {
    EXPECT_DOUBLE_EQ(pole.x_m, 0.0);
    EXPECT_DOUBLE_EQ(pole.y_m, pole.left ? 2.4 : -2.4);  // touch line 2.0 + offset 0.4
  }
  int count[5] = {};
  for (const auto& mark : field.marks) {
    ++count[mark.type];
    if (mark.type == proto::truth::Landmark::PENALTY_MARK) {
      EXPECT_DOUBLE_EQ(std::abs(mark.x_m), 3.0 - 1.8);
      EXPECT_DOUBLE_EQ(mark.y_m, 0.0);
    }
    if (mark.type == proto::truth::Landmark::X_CROSSING) {
      EXPECT_DOUBLE_EQ(std::abs(mark.y_m), 0.6);  // centre circle radius
    }
  }
  EXPECT_EQ(count[proto::truth::Landmark::L_CROSSING], 8);
  EXPECT_EQ(count[proto::truth::Landmark::T_CROSSING], 6);
  EXPECT_EQ(count[proto::truth::Landmark::X_CROSSING], 2);
  EXPECT_EQ(count[proto::truth::Landmark::PENALTY_MARK], 2);
  EXPECT_EQ(count[proto::truth::Landmark::CENTRE_CIRCLE], 1);
}

TEST(WorldModel, OtherRobotsWithTeamPoseAndRelativeHeadingButNotItself) {
  WorldSample s = sample_with_balls({});
  s.robots[0] = robot_at(-1.0, 0.0, 0.0, 0);
  s.robots[3] = robot_at(1.0, 1.0, std::numbers::pi, 1);
  std::mt19937_64 rng(1);
  const proto::truth::WorldModel m = build_world_model(s, 0, {}, field_objects(), rng, 5, 9);
  EXPECT_EQ(m.sequence(), 9u);
  EXPECT_EQ(m.sim_time_ns(), 5);
  ASSERT_EQ(m.robots_size(), 1);
  EXPECT_EQ(m.robots(0).index(), 3u);
  EXPECT_EQ(m.robots(0).team(), 1u);
  EXPECT_NEAR(m.robots(0).pose().x_m(), 1.0, 1e-12);
  EXPECT_NEAR(std::abs(m.robots(0).relative_yaw_rad()), std::numbers::pi, 1e-12);
  EXPECT_NEAR(m.robots(0).relative().x_m(), 2.0, 1e-12);
  EXPECT_NEAR(m.robots(0).relative().y_m(), 1.0, 1e-12);
  EXPECT_NEAR(m.pose().x_m(), -1.0, 1e-12);
}

TEST(WorldModel, DropoutRemovesTheConfiguredShareWithinBinomialBounds) {
  const FieldObjects field = field_objects();
  WorldModelSettings settings;
  settings.dropout = 0.3;
  settings.seed = 7;
  std::mt19937_64 rng(settings.seed);
  const WorldSample s = sample_with_balls({{1.0, 0.0}});
  const int all = 1 + 4 + 2 + 19;  // ball, posts, poles, landmarks (all around, no range)
  const int messages = 2000;
  long kept = 0;
  for (int i = 0; i < messages; ++i) {
    const proto::truth::WorldModel m = build_world_model(s, 0, settings, field, rng, 0, 1);
    kept += m.balls_size() + m.goal_posts_size() + m.side_poles_size() + m.landmarks_size();
  }
  const double n = static_cast<double>(all) * messages;
  const double dropped_share = 1.0 - static_cast<double>(kept) / n;
  const double sigma = std::sqrt(0.3 * 0.7 / n);
  EXPECT_NEAR(dropped_share, 0.3, 5.0 * sigma) << "5 sigma of a binomial share over " << n << " objects";
  settings.dropout = 0.0;  // and none without dropout
  const proto::truth::WorldModel m = build_world_model(s, 0, settings, field, rng, 0, 1);
  EXPECT_EQ(m.balls_size() + m.goal_posts_size() + m.side_poles_size() + m.landmarks_size(), all);
}

TEST(WorldModel, GaussianNoiseHasTheConfiguredSigmaAndNoBias) {
  const FieldObjects field = field_objects();
  WorldModelSettings settings;
  settings.position_sigma_m = 0.05;
  settings.angle_sigma_rad = 0.1;
  std::mt19937_64 rng(3);
  const WorldSample s = sample_with_balls({{1.0, 0.5}});
  const int n = 5000;
  double sum_x = 0, sum_xx = 0, sum_a = 0, sum_aa = 0;
  for (int i = 0; i < n; ++i) {
    const proto::truth::WorldModel m = build_world_model(s, 0, settings, field, rng, 0, 1);
    const double ex = m.balls(0).field().x_m() - 1.0;
    sum_x += ex;
    sum_xx += ex * ex;
    const double ea = m.pose().yaw_rad();
    sum_a += ea;
    sum_aa += ea * ea;
    // The ball's relative position is the same noisy point seen from the true pose.
    EXPECT_NEAR(m.balls(0).relative().x_m(), m.balls(0).field().x_m(), 1e-12);
  }
  const double mean_x = sum_x / n, sd_x = std::sqrt(sum_xx / n - mean_x * mean_x);
  const double mean_a = sum_a / n, sd_a = std::sqrt(sum_aa / n - mean_a * mean_a);
  // Mean within 5 standard errors; sample sigma within 5 of its standard errors (sigma / sqrt(2n)).
  EXPECT_NEAR(mean_x, 0.0, 5.0 * 0.05 / std::sqrt(n));
  EXPECT_NEAR(sd_x, 0.05, 5.0 * 0.05 / std::sqrt(2.0 * n));
  EXPECT_NEAR(mean_a, 0.0, 5.0 * 0.1 / std::sqrt(n));
  EXPECT_NEAR(sd_a, 0.1, 5.0 * 0.1 / std::sqrt(2.0 * n));
  // Noise off: exact.
  settings.position_sigma_m = settings.angle_sigma_rad = 0.0;
  const proto::truth::WorldModel exact = build_world_model(s, 0, settings, field, rng, 0, 1);
  EXPECT_EQ(exact.balls(0).field().x_m(), 1.0);
  EXPECT_EQ(exact.pose().yaw_rad(), 0.0);
}

// Samples every 1 ms of simulation time with the ball at x = t (s), as the simulation thread queues them.
std::vector<proto::truth::WorldModel> run_topic(WorldModelTopic& topic, int64_t until_ms) {
  std::vector<proto::truth::WorldModel> out;
  for (int64_t ms = 1; ms <= until_ms; ++ms) {
    WorldSample s = sample_with_balls({{static_cast<double>(ms) * 1e-3, 0.0}}, ms * 1'000'000);
    topic.on_sample(s, [&](std::size_t, const proto::truth::WorldModel& m) { out.push_back(m); });
  }
  return out;
}

TEST(WorldModelTopic, LatencyDescribesTheWorldThatLongAgoAtTheConfiguredRate) {
  WorldModelTopic topic;
  WorldModelSettings settings;
  settings.rate_hz = 10.0;
  settings.latency_s = 0.25;
  ASSERT_EQ(topic.set(0, settings), "");
  const std::vector<proto::truth::WorldModel> messages = run_topic(topic, 2000);
  ASSERT_EQ(messages.size(), 20u) << "10 Hz for 2 s of simulation time";
  for (std::size_t i = 0; i < messages.size(); ++i) {
    const proto::truth::WorldModel& m = messages[i];
    EXPECT_EQ(m.sequence(), i + 1);
    EXPECT_EQ(m.sim_time_ns(), 1'000'000 + static_cast<int64_t>(i) * 100'000'000);
    if (m.sim_time_ns() <= 250'000'000) continue;  // the first 250 ms: no history that old yet
    EXPECT_EQ(m.world_time_ns(), m.sim_time_ns() - 250'000'000);
    EXPECT_DOUBLE_EQ(m.balls(0).field().x_m(), static_cast<double>(m.world_time_ns()) * 1e-9);
  }
}

TEST(WorldModelTopic, SameSeedSameNoiseAndSettingsChangeWhileRunning) {
  WorldModelSettings settings;
  settings.position_sigma_m = 0.1;
  settings.seed = 42;
  WorldModelTopic a, b;
  ASSERT_EQ(a.set(0, settings), "");
  ASSERT_EQ(b.set(0, settings), "");
  const auto ma = run_topic(a, 500), mb = run_topic(b, 500);
  ASSERT_EQ(ma.size(), mb.size());
  for (std::size_t i = 0; i < ma.size(); ++i) EXPECT_EQ(ma[i].SerializeAsString(), mb[i].SerializeAsString());
  settings.seed = 43;
  WorldModelTopic c;
  ASSERT_EQ(c.set(0, settings), "");
  EXPECT_NE(run_topic(c, 100).front().balls(0).field().x_m(), ma.front().balls(0).field().x_m());
  // Off, then a bad value refused with nothing changed.
  settings.enabled = false;
  ASSERT_EQ(c.set(0, settings), "");
  EXPECT_TRUE(run_topic(c, 200).empty());
  settings.fov_deg = 180.0;
  EXPECT_NE(c.set(0, settings).find("fov_deg"), std::string::npos);
  EXPECT_EQ(c.settings(0)->fov_deg, 0.0);
}

TEST(WorldModelSettings, BadValuesAreRefusedNamingTheField) {
  auto problem = [](auto change) {
    WorldModelSettings s;
    change(s);
    return settings_problem(s);
  };
  EXPECT_EQ(problem([](WorldModelSettings&) {}), "");
  EXPECT_EQ(problem([](WorldModelSettings& s) { s.fov_deg = 179.9; }), "");
  EXPECT_NE(problem([](WorldModelSettings& s) { s.rate_hz = 0.0; }).find("rate_hz"), std::string::npos);
  EXPECT_NE(problem([](WorldModelSettings& s) { s.rate_hz = 1001.0; }).find("rate_hz"), std::string::npos);
  EXPECT_NE(problem([](WorldModelSettings& s) { s.fov_deg = 180.0; }).find("fov_deg"), std::string::npos);
  EXPECT_NE(problem([](WorldModelSettings& s) { s.fov_deg = -1.0; }).find("fov_deg"), std::string::npos);
  EXPECT_NE(problem([](WorldModelSettings& s) { s.max_range_m = -0.1; }).find("max_range_m"), std::string::npos);
  EXPECT_NE(problem([](WorldModelSettings& s) { s.position_sigma_m = -1.0; }).find("position_sigma_m"), std::string::npos);
  EXPECT_NE(problem([](WorldModelSettings& s) { s.angle_sigma_rad = NAN; }).find("angle_sigma_rad"), std::string::npos);
  EXPECT_NE(problem([](WorldModelSettings& s) { s.dropout = 1.0; }).find("dropout"), std::string::npos);
  EXPECT_NE(problem([](WorldModelSettings& s) { s.latency_s = 1.5; }).find("latency_s"), std::string::npos);
}

}  // namespace
}  // namespace doppel::truth
