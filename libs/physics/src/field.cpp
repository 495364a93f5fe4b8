#include "physics/field.h"

#include <Eigen/Geometry>

#include <cmath>
#include <numbers>
#include <stdexcept>

#include "physics/carpet.h"

namespace doppel::physics {
namespace {

// An axis-aligned shape centred at `centre` (world frame).
VisualShape make_shape(ShapeType type, ObjectKind kind, uint16_t id, const Eigen::Vector3d& centre,
                       const Eigen::Vector3d& size_m, Rgb colour) {
  VisualShape s;
  s.type = type;
  s.kind = kind;
  s.X_WS = Eigen::Isometry3d::Identity();
  s.X_WS.translation() = centre;
  s.size_m = size_m;
  s.colour = colour;
  s.object_id = id;
  return s;
}

VisualShape make_box(ObjectKind kind, uint16_t id, const Eigen::Vector3d& centre, const Eigen::Vector3d& size,
                     Rgb colour) {
  return make_shape(ShapeType::kBox, kind, id, centre, size, colour);
}

VisualShape make_cylinder(ObjectKind kind, uint16_t id, const Eigen::Vector3d& centre, double radius, double length,
                          Rgb colour) {
  return make_shape(ShapeType::kCylinder, kind, id, centre, {radius, length, 0.0}, colour);
}

void check(const FieldSpec& spec) {
  const double values[] = {spec.field_length_m,       spec.field_width_m,         spec.goal_depth_m,
                           spec.goal_width_m,         spec.goal_area_length_m,    spec.goal_area_width_m,
                           spec.penalty_mark_distance_m, spec.centre_circle_diameter_m, spec.border_strip_width_m,
                           spec.line_width_m,         spec.penalty_mark_size_m,   spec.goal_post_diameter_m,
                           spec.goal_height_m,        spec.crossbar_lower_edge_m, spec.pole_diameter_m,
                           spec.pole_height_m,        spec.pole_offset_m,         spec.ball_diameter_m,
                           spec.line_thickness_m};
  for (double v : values) {
    if (!(v > 0.0) || !std::isfinite(v)) throw std::invalid_argument("FieldSpec: every dimension must be positive");
  }
  if (spec.crossbar_lower_edge_m >= spec.goal_height_m) {
    throw std::invalid_argument("FieldSpec: crossbar_lower_edge_m must lie below goal_height_m");
  }
}

}  // namespace

std::vector<VisualShape> field_shapes(const FieldSpec& spec) {
  check(spec);
  const double half_a = 0.5 * spec.field_length_m;
  const double half_b = 0.5 * spec.field_width_m;
  const double lw = spec.line_width_m;
  const double t = spec.line_thickness_m;
  const double zl = 0.5 * t;
  std::vector<VisualShape> shapes;

  // Carpet, its top face at z = 0.
  shapes.push_back(make_box(ObjectKind::kCarpet, kCarpetObjectId, {0.0, 0.0, -0.005},
                            {2.0 * carpet_half_length_m(spec), 2.0 * carpet_half_width_m(spec), 0.01},
                            kCarpetGreen));

  // Lines: positions are line centres; lengths reach the outer edge of the lines they meet.
  auto line = [&](double cx, double cy, double sx, double sy) {
    shapes.push_back(make_box(ObjectKind::kFieldLine, kFieldLinesObjectId, {cx, cy, zl}, {sx, sy, t}, kLineWhite));
  };
  for (double sy : {-1.0, 1.0}) line(0.0, sy * half_b, spec.field_length_m + lw, lw);  // touch lines
  for (double sx : {-1.0, 1.0}) line(sx * half_a, 0.0, lw, spec.field_width_m + lw);  // goal lines
  line(0.0, 0.0, lw, spec.field_width_m);                                               // centre line
  for (double sx : {-1.0, 1.0}) {
    const double x_front = sx * (half_a - spec.goal_area_length_m);
    line(x_front, 0.0, lw, spec.goal_area_width_m + lw);
    for (double sy : {-1.0, 1.0}) {
      line(sx * (half_a - 0.5 * spec.goal_area_length_m), sy * 0.5 * spec.goal_area_width_m,
           spec.goal_area_length_m, lw);
    }
    const double x_mark = sx * (half_a - spec.penalty_mark_distance_m);
    line(x_mark, 0.0, spec.penalty_mark_size_m, lw);
    line(x_mark, 0.0, lw, spec.penalty_mark_size_m);
  }
  VisualShape circle;
  circle.type = ShapeType::kRing;
  circle.kind = ObjectKind::kFieldLine;
  circle.X_WS = Eigen::Isometry3d::Identity();
  circle.X_WS.translation() = Eigen::Vector3d(0.0, 0.0, zl);
  const double rc = 0.5 * spec.centre_circle_diameter_m;
  circle.size_m = {rc + 0.5 * lw, rc - 0.5 * lw, t};
  circle.colour = kLineWhite;
  circle.object_id = kFieldLinesObjectId;
  shapes.push_back(circle);

  // Goals: posts centred on the goal line, crossbar on top, nets behind.
  const double d = spec.goal_post_diameter_m;
  const double h = spec.goal_height_m;
  const double post_y = 0.5 * spec.goal_width_m + 0.5 * d;
  const double net = 0.02;
  for (double sx : {1.0, -1.0}) {
    const bool yellow = sx > 0.0;
    const Rgb colour = yellow ? kGoalYellow : kGoalBlue;
    const uint16_t goal_id = yellow ? kYellowGoalId : kBlueGoalId;
    const uint16_t post_pos_y = yellow ? kYellowGoalLeftPostId : kBlueGoalRightPostId;
    const uint16_t post_neg_y = yellow ? kYellowGoalRightPostId : kBlueGoalLeftPostId;
    const double x = sx * half_a;
    shapes.push_back(make_cylinder(ObjectKind::kGoalPost, post_pos_y, {x, post_y, 0.5 * h}, 0.5 * d, h, colour));
    shapes.push_back(make_cylinder(ObjectKind::kGoalPost, post_neg_y, {x, -post_y, 0.5 * h}, 0.5 * d, h, colour));
    const double bar_h = h - spec.crossbar_lower_edge_m;
    shapes.push_back(make_box(ObjectKind::kGoalBar, goal_id, {x, 0.0, spec.crossbar_lower_edge_m + 0.5 * bar_h},
                              {d, 2.0 * post_y, bar_h}, colour));
    const double x_back = sx * (half_a + spec.goal_depth_m);
    const double x_mid = sx * (half_a + 0.5 * spec.goal_depth_m);
    shapes.push_back(
        make_box(ObjectKind::kGoalNet, goal_id, {x_back, 0.0, 0.5 * h}, {net, 2.0 * post_y, h}, kNetWhite));
    for (double sy : {-1.0, 1.0}) {
      shapes.push_back(make_box(ObjectKind::kGoalNet, goal_id, {x_mid, sy * post_y, 0.5 * h},
                                {spec.goal_depth_m, net, h}, kNetWhite));
    }
    shapes.push_back(make_box(ObjectKind::kGoalNet, goal_id, {x_mid, 0.0, h - 0.5 * net},
                              {spec.goal_depth_m, 2.0 * post_y, net}, kNetWhite));
  }

  // Landmark poles on the extension of the centre line, three bands each. Assumption: the pole at
  // y > 0 is blue-yellow-blue (bottom to top), the one at y < 0 yellow-blue-yellow.
  const double band = spec.pole_height_m / 3.0;
  for (double sy : {1.0, -1.0}) {
    const Rgb outer = sy > 0.0 ? kGoalBlue : kGoalYellow;
    const Rgb middle = sy > 0.0 ? kGoalYellow : kGoalBlue;
    const uint16_t id = sy > 0.0 ? kLeftPoleId : kRightPoleId;
    const double y = sy * (half_b + spec.pole_offset_m);
    for (int i = 0; i < 3; ++i) {
      shapes.push_back(make_cylinder(ObjectKind::kSidePole, id, {0.0, y, (i + 0.5) * band}, 0.5 * spec.pole_diameter_m,
                                     band, i == 1 ? middle : outer));
    }
  }
  return shapes;
}

VisualShape ball_shape(const Eigen::Vector3d& centre_W, const FieldSpec& spec) {
  VisualShape s;
  s.type = ShapeType::kSphere;
  s.kind = ObjectKind::kBall;
  s.X_WS = Eigen::Isometry3d::Identity();
  s.X_WS.translation() = centre_W;
  s.size_m = {0.5 * spec.ball_diameter_m, 0.0, 0.0};
  s.colour = kBallOrange;
  s.object_id = kBallObjectId;
  return s;
}

std::vector<FieldFeature> field_features(const FieldSpec& spec) {
  check(spec);
  const double half_a = 0.5 * spec.field_length_m;
  const double half_b = 0.5 * spec.field_width_m;
  const double half_f = 0.5 * spec.goal_area_width_m;
  const double x_area = half_a - spec.goal_area_length_m;
  std::vector<FieldFeature> out;
  auto add = [&out](FieldFeatureType type, double x, double y, double heading) {
    FieldFeature f;
    f.type = type;
    f.position_W = {x, y, 0.0};
    f.heading_rad = heading;
    out.push_back(f);
  };
  for (double sx : {-1.0, 1.0}) {
    for (double sy : {-1.0, 1.0}) {
      add(FieldFeatureType::kL, sx * half_a, sy * half_b, std::atan2(-sy, -sx));   // field corner
      add(FieldFeatureType::kL, sx * x_area, sy * half_f, std::atan2(-sy, sx));    // goal-area corner
      add(FieldFeatureType::kT, sx * half_a, sy * half_f, std::atan2(0.0, -sx));   // goal area on goal line
    }
  }
  for (double sy : {-1.0, 1.0}) {
    add(FieldFeatureType::kT, 0.0, sy * half_b, std::atan2(-sy, 0.0));  // centre line on touch line
    add(FieldFeatureType::kX, 0.0, sy * 0.5 * spec.centre_circle_diameter_m, 0.5 * std::numbers::pi);
  }
  for (double sx : {-1.0, 1.0}) add(FieldFeatureType::kX, sx * (half_a - spec.penalty_mark_distance_m), 0.0, 0.0);
  return out;
}

}  // namespace doppel::physics
