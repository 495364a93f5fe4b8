// The world fills the camera's SceneView: every robot shape with its colour and object id, a team
// marker per robot, the ball, the field as given; and the field's goals are solid.

#include <gtest/gtest.h>

#include <map>

#include "physics/field.h"
#include "rigs.h"

namespace doppel::physics {
namespace {

class SceneTest : public ::testing::TestWithParam<std::string> {};

TEST_P(SceneTest, SceneViewHoldsRobotsMarkersBallAndField) {
  WorldOptions options;
  options.field = field_shapes();
  options.ball.position_m = Eigen::Vector3d(0.5, 0.0, 0.0);
  auto world = test::make_world(GetParam(), {test::shipped_robot("fumanoid-2011"), test::shipped_robot("fumanoid-pitch")},
                                options, {RobotPlacement{{-1.0, 0.0, 0.0}, 0.0, 0}, RobotPlacement{{1.0, 0.0, 0.0}, 3.14159, 1}});
  SceneView sut;

  world->fill_scene(sut);

  std::map<uint16_t, int> robot_shapes;
  std::map<uint16_t, Rgb> markers;
  int balls = 0;
  for (const VisualShape& s : sut.shapes) {
    if (s.kind == ObjectKind::kRobotBody) ++robot_shapes[s.object_id];
    if (s.kind == ObjectKind::kTeamMarker) markers[s.object_id] = s.colour;
    if (s.kind == ObjectKind::kBall) {
      ++balls;
      EXPECT_EQ(s.object_id, kBallObjectId);
      EXPECT_NEAR(s.X_WS.translation().x(), 0.5, 1e-9);
    }
  }
  EXPECT_EQ(robot_shapes[kFirstRobotObjectId], 22);
  EXPECT_EQ(robot_shapes[kFirstRobotObjectId + 1], 10);
  EXPECT_EQ(markers[kFirstRobotObjectId].b, kTeamCyan.b);
  EXPECT_EQ(markers[kFirstRobotObjectId + 1].r, kTeamMagenta.r);
  EXPECT_EQ(balls, 1);
  EXPECT_EQ(sut.shapes.size(), options.field.size() + 22 + 10 + 2 + 1);
}

// A ball kicked at 2 m/s along x from 0.5 m before the yellow goal line, at lateral offset `y`.
double furthest_x(const std::string& engine, double y) {
  WorldOptions options;
  options.field = field_shapes();
  const FieldSpec spec;
  options.ball.position_m = Eigen::Vector3d(0.5 * spec.field_length_m - 0.5, y, 0.0);
  auto world = test::make_world(engine, {}, options);
  world->place_ball(world->ball_position(), Eigen::Vector3d(2.0, 0.0, 0.0));
  double furthest = 0.0;
  for (int i = 0; i < 1500; ++i) {
    world->step();
    furthest = std::max(furthest, world->ball_position().x());
  }
  return furthest;
}

TEST_P(SceneTest, GoalPostStopsTheBall) {
  const FieldSpec spec;
  const double post_y = 0.5 * spec.goal_width_m + 0.5 * spec.goal_post_diameter_m;

  const double furthest = furthest_x(GetParam(), post_y);

  // Post centred on the goal line: its front face is at 3.0 - 0.05 m; the ball's centre stops a radius before.
  EXPECT_LT(furthest, 0.5 * spec.field_length_m - 0.5 * spec.goal_post_diameter_m - 0.5 * spec.ball_diameter_m + 0.005);
}

TEST_P(SceneTest, NetCatchesTheBallInTheGoal) {
  const FieldSpec spec;

  const double furthest = furthest_x(GetParam(), 0.0);

  EXPECT_GT(furthest, 0.5 * spec.field_length_m + 0.1);                 // in the goal
  EXPECT_LT(furthest, 0.5 * spec.field_length_m + spec.goal_depth_m);  // held by the back net
}

INSTANTIATE_TEST_SUITE_P(Engines, SceneTest, ::testing::ValuesIn(engine_names()),
                         [](const ::testing::TestParamInfo<std::string>& param) { return param.param; });

}  // namespace
}  // namespace doppel::physics
