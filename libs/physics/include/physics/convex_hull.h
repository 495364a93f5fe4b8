#pragma once
// The convex hull of a point cloud, with what both engines and the renderer need of it: vertices,
// outward face planes, face polygons in ODE's dCreateConvex layout, and its mass properties per
// unit density. Collision meshes (URDF <mesh>, Shape.convex) become hulls. Computed with qhull
// (Debian libqhull-dev, reentrant libqhull_r): double precision, the hull's vertices are exactly
// input points, coplanar facets merged into polygons. Bullet's btConvexHullComputer was tried and
// dropped: it rounds the input to a grid of about 10^4 steps per axis, so its vertices are off by
// 1e-4 of the extent and, snapped back, sliver faces of a fine mesh tilt by millimetres.
// Setup code: allocates, may throw.

#include <Eigen/Core>
#include <memory>
#include <vector>

namespace doppel::physics {

struct ConvexHull {
  std::vector<Eigen::Vector3d> vertices;  // hull vertices: the input points on the hull, exactly
  std::vector<Eigen::Vector4d> planes;    // per face: outward unit normal n (x, y, z) and w = n . p on the face
  std::vector<unsigned> polygons;         // per face: vertex count, then vertex indices, counter-clockwise
                                          // seen from outside (ODE's dCreateConvex layout)
  size_t face_count = 0;                  // = planes.size()
  Eigen::Vector3d half_extents = Eigen::Vector3d::Zero();  // max |coordinate| per axis (box about the origin)
  double volume_m3 = 0.0;                                  // > 0
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();      // centre of volume
  Eigen::Matrix3d inertia_per_kg = Eigen::Matrix3d::Zero();  // about the centroid, per kg of uniform mass
};

// Hull of `points` (in one frame). Throws std::invalid_argument with a plain reason ("3 points",
// "the points are coplanar") when they span no volume.
std::shared_ptr<const ConvexHull> convex_hull(const std::vector<Eigen::Vector3d>& points);

}  // namespace doppel::physics
