#include "demo_scene.h"

#include <cmath>
#include <numbers>

#include "physics/field.h"

namespace doppel::camera {

using physics::ObjectKind;
using physics::ShapeType;
using physics::VisualShape;

namespace {

constexpr physics::Rgb kRobotGrey{60, 60, 65};
constexpr physics::Rgb kRobotDark{35, 35, 40};

VisualShape box_part(uint16_t id, ObjectKind kind, const Eigen::Isometry3d& X_WR, const Eigen::Vector3d& centre_R,
                     const Eigen::Vector3d& size, physics::Rgb colour) {
  VisualShape s;
  s.type = ShapeType::kBox;
  s.kind = kind;
  Eigen::Isometry3d X_RS = Eigen::Isometry3d::Identity();
  X_RS.translation() = centre_R;
  s.X_WS = X_WR * X_RS;
  s.size_m = size;
  s.colour = colour;
  s.object_id = id;
  return s;
}

}  // namespace

std::vector<VisualShape> robot_placeholder(uint16_t object_id, physics::Rgb marker, const Eigen::Isometry3d& X_WR) {
  std::vector<VisualShape> out;
  auto body = [&](const Eigen::Vector3d& c, const Eigen::Vector3d& size, physics::Rgb colour) {
    out.push_back(box_part(object_id, ObjectKind::kRobotBody, X_WR, c, size, colour));
  };
  auto mark = [&](const Eigen::Vector3d& c, const Eigen::Vector3d& size) {
    out.push_back(box_part(object_id, ObjectKind::kTeamMarker, X_WR, c, size, marker));
  };
  for (double sy : {-1.0, 1.0}) {
    body({0.01, sy * 0.05, 0.015}, {0.13, 0.07, 0.03}, kRobotDark);   // foot
    body({0.0, sy * 0.05, 0.16}, {0.05, 0.05, 0.26}, kRobotGrey);     // leg
    body({0.0, sy * 0.11, 0.40}, {0.04, 0.04, 0.20}, kRobotGrey);     // arm
    mark({0.0, sy * 0.11, 0.44}, {0.045, 0.045, 0.06});               // arm marker
  }
  body({0.0, 0.0, 0.39}, {0.09, 0.16, 0.20}, kRobotGrey);            // torso
  mark({0.047, 0.0, 0.42}, {0.005, 0.10, 0.06});                     // chest marker
  mark({-0.047, 0.0, 0.42}, {0.005, 0.10, 0.06});                    // back marker
  body({0.0, 0.0, 0.54}, {0.08, 0.08, 0.09}, kRobotDark);            // head
  return out;
}

physics::SceneView make_demo_scene(int robots, const Eigen::Vector2d& ball_xy_W) {
  physics::SceneView scene;
  const physics::FieldSpec spec;
  scene.shapes = physics::field_shapes(spec);
  scene.shapes.push_back(physics::ball_shape({ball_xy_W.x(), ball_xy_W.y(), 0.5 * spec.ball_diameter_m}, spec));
  struct Placement {
    double x, y;
  };
  static constexpr Placement kCyan[3] = {{-2.6, 0.0}, {-1.2, 1.0}, {-1.0, -0.9}};
  static constexpr Placement kMagenta[3] = {{2.6, 0.0}, {1.3, 1.1}, {1.1, -1.0}};
  for (int i = 0; i < robots && i < 6; ++i) {
    const bool cyan = (i % 2) == 0;
    const Placement p = cyan ? kCyan[i / 2] : kMagenta[i / 2];
    Eigen::Isometry3d X_WR = Eigen::Isometry3d::Identity();
    X_WR.translation() = Eigen::Vector3d(p.x, p.y, 0.0);
    X_WR.linear() = Eigen::AngleAxisd(cyan ? 0.0 : std::numbers::pi, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    const auto parts = robot_placeholder(static_cast<uint16_t>(physics::kFirstRobotObjectId + i),
                                         cyan ? physics::kTeamCyan : physics::kTeamMagenta, X_WR);
    scene.shapes.insert(scene.shapes.end(), parts.begin(), parts.end());
  }
  return scene;
}

}  // namespace doppel::camera
