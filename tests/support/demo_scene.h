#pragma once
// A scene for the camera tests and benchmarks, which render without a physics world: the 2011
// field, a ball and box-built placeholder robots. Test and benchmark code only; doppel renders the
// physics world's SceneView.

#include <Eigen/Geometry>

#include <cstdint>
#include <vector>

#include "physics/scene_view.h"

namespace doppel::camera {

// The 2011 field, the ball at `ball_W` (on the carpet) and `robots` placeholder robots (up to 6: cyan
// team at x < 0 facing +x, magenta team at x > 0 facing -x), each about 0.6 m tall, built of boxes
// with team markers.
physics::SceneView make_demo_scene(int robots = 6, const Eigen::Vector2d& ball_xy_W = Eigen::Vector2d(0.5, 0.2));

// Shapes of one placeholder robot standing at X_WR (R: x forward, z up, origin between the feet on
// the carpet): feet, legs, torso, arms, head, and team markers in `marker` on chest, back and arms.
std::vector<physics::VisualShape> robot_placeholder(uint16_t object_id, physics::Rgb marker,
                                                    const Eigen::Isometry3d& X_WR);

}  // namespace doppel::camera
