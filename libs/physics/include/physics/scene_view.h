#pragma once
// What a renderer needs of the world: every visible shape with its world pose, colour and what it
// is (for ground-truth annotations). The physics world fills it each step; camera/ reads it without
// knowing any engine. Plain values: it can be copied into a snapshot for another thread.

#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <vector>

#include "physics/convex_hull.h"

namespace doppel::physics {

enum class ShapeType : uint8_t {
  kBox,       // size_m = full extents x, y, z
  kSphere,    // size_m.x() = radius
  kCylinder,  // size_m.x() = radius, size_m.y() = length along the shape's z axis
  kCapsule,   // size_m.x() = radius, size_m.y() = length of the cylindrical part along z
  kRing,      // flat annulus in the shape's xy plane: size_m = (outer radius, inner radius, thickness)
  kConvex,    // convex hull (the shape's `hull`); size_m = its half extents about the shape origin
};

enum class ObjectKind : uint8_t {
  kCarpet,
  kFieldLine,
  kGoalPost,
  kGoalBar,
  kGoalNet,
  kBall,
  kSidePole,
  kRobotBody,
  kTeamMarker,
  kOther,
};

struct Rgb {
  uint8_t r = 0;  // red, 0..255
  uint8_t g = 0;  // green
  uint8_t b = 0;  // blue
};

struct VisualShape {
  ShapeType type = ShapeType::kBox;              // geometry, see ShapeType for size_m
  ObjectKind kind = ObjectKind::kOther;          // what it is, for annotations
  Eigen::Isometry3d X_WS = Eigen::Isometry3d::Identity();  // pose of shape frame S in world W
  Eigen::Vector3d size_m = Eigen::Vector3d::Zero();        // dimensions, m (meaning per type)
  Rgb colour;                                    // diffuse colour
  uint16_t object_id = 0;                        // which robot / goal / pole it belongs to
  std::shared_ptr<const ConvexHull> hull;        // kConvex only: the hull, in S (shared, immutable)
};

// World frame: origin at the centre of the field on the carpet, x towards the yellow goal, z up.
struct SceneView {
  std::vector<VisualShape> shapes;  // every visible shape
  double sim_time_s = 0.0;          // simulation time the poses belong to
};

}  // namespace doppel::physics
