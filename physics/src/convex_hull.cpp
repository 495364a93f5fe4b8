#include "physics/convex_hull.h"

#include <LinearMath/btConvexHullComputer.h>

#include <Eigen/Geometry>
#include <algorithm>

#include <stdexcept>
#include <string>

namespace doppel::physics {

std::shared_ptr<const ConvexHull> convex_hull(const std::vector<Eigen::Vector3d>& points) {
  if (points.size() < 4) {
    throw std::invalid_argument(std::to_string(points.size()) + " points, a hull needs at least 4 that span a volume");
  }
  std::vector<double> coords;
  coords.reserve(3 * points.size());
  Eigen::AlignedBox3d box;
  for (const Eigen::Vector3d& p : points) {
    if (!p.allFinite()) throw std::invalid_argument("a point is not finite");
    coords.insert(coords.end(), {p.x(), p.y(), p.z()});
    box.extend(p);
  }
  btConvexHullComputer computer;
  computer.compute(coords.data(), 3 * static_cast<int>(sizeof(double)), static_cast<int>(points.size()), 0.0, 0.0);
  auto hull = std::make_shared<ConvexHull>();
  // The computer works on integer coordinates and hands back vertices off by up to 1e-4 of the
  // extent; every hull vertex is an input point, so each is replaced by the input point nearest it.
  for (int i = 0; i < computer.vertices.size(); ++i) {
    const Eigen::Vector3d v(computer.vertices[i].x(), computer.vertices[i].y(), computer.vertices[i].z());
    const Eigen::Vector3d* nearest = &points.front();
    double best = (v - *nearest).squaredNorm();
    for (const Eigen::Vector3d& p : points) {
      const double d = (v - p).squaredNorm();
      if (d < best) {
        best = d;
        nearest = &p;
      }
    }
    hull->vertices.push_back(*nearest);
    hull->half_extents = hull->half_extents.cwiseMax(nearest->cwiseAbs());
  }
  const double scale = std::max(box.sizes().maxCoeff(), 1e-12);
  if (computer.faces.size() < 4) {
    throw std::invalid_argument("the points are coplanar or collinear: no volume");
  }
  Eigen::Vector3d inside = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& v : hull->vertices) inside += v;
  inside /= static_cast<double>(hull->vertices.size());

  // Faces, oriented outwards; mass properties from tetrahedra (inside, a, b, c) of a fan per face.
  double volume = 0.0;
  Eigen::Vector3d first_moment = Eigen::Vector3d::Zero();
  Eigen::Matrix3d second_moment = Eigen::Matrix3d::Zero();  // integral of x x^T over the volume
  std::vector<unsigned> face;
  for (int f = 0; f < computer.faces.size(); ++f) {
    face.clear();
    const btConvexHullComputer::Edge* first = &computer.edges[computer.faces[f]];
    const btConvexHullComputer::Edge* edge = first;
    do {
      face.push_back(static_cast<unsigned>(edge->getSourceVertex()));
      edge = edge->getNextEdgeOfFace();
    } while (edge != first && face.size() <= hull->vertices.size());
    if (face.size() < 3) continue;
    // Newell's normal, robust for polygons.
    Eigen::Vector3d n = Eigen::Vector3d::Zero();
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    for (size_t i = 0; i < face.size(); ++i) {
      const Eigen::Vector3d& a = hull->vertices[face[i]];
      const Eigen::Vector3d& b = hull->vertices[face[(i + 1) % face.size()]];
      n += a.cross(b);
      centre += a;
    }
    centre /= static_cast<double>(face.size());
    if (!(n.norm() > 1e-15 * scale * scale)) continue;
    n.normalize();
    if (n.dot(centre - inside) < 0.0) {
      n = -n;
      std::reverse(face.begin(), face.end());
    }
    hull->planes.emplace_back(n.x(), n.y(), n.z(), n.dot(centre));
    hull->polygons.push_back(static_cast<unsigned>(face.size()));
    hull->polygons.insert(hull->polygons.end(), face.begin(), face.end());
    const Eigen::Vector3d& p0 = inside;
    const Eigen::Vector3d& p1 = hull->vertices[face[0]];
    for (size_t i = 1; i + 1 < face.size(); ++i) {
      const Eigen::Vector3d& p2 = hull->vertices[face[i]];
      const Eigen::Vector3d& p3 = hull->vertices[face[i + 1]];
      const double v = (p1 - p0).dot((p2 - p0).cross(p3 - p0)) / 6.0;
      const Eigen::Vector3d s = p0 + p1 + p2 + p3;
      volume += v;
      first_moment += v * s / 4.0;
      second_moment += v / 20.0 * (p0 * p0.transpose() + p1 * p1.transpose() + p2 * p2.transpose() +
                                   p3 * p3.transpose() + s * s.transpose());
    }
  }
  hull->face_count = hull->planes.size();
  if (hull->face_count < 4 || !(volume > 1e-12 * scale * scale * scale)) {
    throw std::invalid_argument("the points are coplanar or collinear: no volume");
  }
  hull->volume_m3 = volume;
  hull->centroid = first_moment / volume;
  const Eigen::Matrix3d C = second_moment - volume * hull->centroid * hull->centroid.transpose();
  hull->inertia_per_kg = (C.trace() * Eigen::Matrix3d::Identity() - C) / volume;
  return hull;
}

}  // namespace doppel::physics
