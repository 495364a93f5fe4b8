// A session's extra balls (WorldOptions::extra_balls): balls 1, 2, ... after the ball, each a body
// of its own that rests where it was put, shows in the scene with an object id of its own, goes
// back to its spot on reset_ball(), and leaves "the ball" (index 0) of every single-ball call alone.
#include <gtest/gtest.h>

#include "physics/field.h"
#include "rigs.h"

namespace doppel::physics::test {
namespace {

WorldOptions three_balls() {
  WorldOptions o;
  o.ball.position_m = Eigen::Vector3d(0.5, 0.0, 0.0);
  for (double x : {-1.0, 2.0}) {
    BallOptions extra = o.ball;
    extra.position_m = Eigen::Vector3d(x, 1.0, 0.0);
    o.extra_balls.push_back(extra);
  }
  return o;
}

TEST(ExtraBalls, RestWhereTheyArePutAndShowInTheSceneWithTheirOwnIds) {
  auto world = make_world("ode", {}, three_balls());
  ASSERT_EQ(world->ball_count(), 3u);
  for (int i = 0; i < 200; ++i) world->step();
  const double r = 0.0335;
  EXPECT_NEAR((world->ball_position(0) - Eigen::Vector3d(0.5, 0.0, r)).norm(), 0.0, 1e-3);
  EXPECT_NEAR((world->ball_position(1) - Eigen::Vector3d(-1.0, 1.0, r)).norm(), 0.0, 1e-3);
  EXPECT_NEAR((world->ball_position(2) - Eigen::Vector3d(2.0, 1.0, r)).norm(), 0.0, 1e-3);
  EXPECT_EQ(world->ball_position(0), world->ball_position());
  SceneView view;
  world->fill_scene(view);
  std::vector<uint16_t> ids;
  for (const VisualShape& s : view.shapes) {
    if (s.kind == ObjectKind::kBall) ids.push_back(s.object_id);
  }
  EXPECT_EQ(ids, (std::vector<uint16_t>{kBallObjectId, kBallObjectId + 1, kBallObjectId + 2}));
}

TEST(ExtraBalls, PlaceBallMovesOnlyBallZeroAndResetPutsEveryBallBack) {
  auto world = make_world("ode", {}, three_balls());
  world->place_ball(Eigen::Vector3d(0.0, -1.0, 0.0335), Eigen::Vector3d(1.0, 0.0, 0.0));
  for (int i = 0; i < 100; ++i) world->step();
  EXPECT_GT(world->ball_position(0).x(), 0.05);
  EXPECT_NEAR(world->ball_position(1).x(), -1.0, 1e-3);
  world->reset_ball();
  world->step();
  EXPECT_NEAR(world->ball_position(0).x(), 0.5, 1e-3);
  EXPECT_NEAR(world->ball_position(2).x(), 2.0, 1e-3);
}

TEST(ExtraBalls, MoreThanSevenAreRefused) {
  WorldOptions o;
  o.extra_balls.resize(kMaxExtraBalls + 1);
  EXPECT_THROW(make_world("ode", {}, o), std::invalid_argument);
  o.extra_balls.resize(kMaxExtraBalls);
  EXPECT_EQ(make_world("ode", {}, o)->ball_count(), kMaxExtraBalls + 1);
}

}  // namespace
}  // namespace doppel::physics::test
