#include "physics/convex_hull.h"

#include <libqhull_r/qhull_ra.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <utility>

namespace doppel::physics {
namespace {

// One qhull run; frees qhull's memory on every path out.
class Qhull {
 public:
  Qhull() {
    errors_ = open_memstream(&text_, &size_);
    qh_zero(&qh_, errors_);
  }
  ~Qhull() {
    qh_freeqhull(&qh_, !qh_ALL);
    int curlong = 0, totlong = 0;
    qh_memfreeshort(&qh_, &curlong, &totlong);
    if (errors_ != nullptr) std::fclose(errors_);
    std::free(text_);
  }
  Qhull(const Qhull&) = delete;
  Qhull& operator=(const Qhull&) = delete;

  // Runs qhull on `coords` (x, y, z per point); throws with qhull's first error line.
  void run(std::vector<double>& coords) {
    char options[] = "qhull";  // 3-d default: coplanar facets merged (C-0), exact input points
    const int code = qh_new_qhull(&qh_, 3, static_cast<int>(coords.size() / 3), coords.data(), False, options,
                                  nullptr, errors_);
    if (code != 0) {
      std::fflush(errors_);
      std::string reason = text_ != nullptr ? std::string(text_, size_) : std::string();
      reason = reason.substr(0, reason.find('\n'));
      throw std::invalid_argument(reason.find("flat") != std::string::npos || reason.find("singular") != std::string::npos
                                      ? "the points are coplanar or collinear: no volume"
                                      : "qhull failed: " + reason);
    }
  }
  qhT* qh() { return &qh_; }

 private:
  qhT qh_;
  FILE* errors_ = nullptr;
  char* text_ = nullptr;
  size_t size_ = 0;
};

}  // namespace

std::shared_ptr<const ConvexHull> convex_hull(const std::vector<Eigen::Vector3d>& points) {
  if (points.size() < 4) {
    throw std::invalid_argument(std::to_string(points.size()) + " points, a hull needs at least 4 that span a volume");
  }
  std::vector<double> coords;
  coords.reserve(3 * points.size());
  for (const Eigen::Vector3d& p : points) {
    if (!p.allFinite()) throw std::invalid_argument("a point is not finite");
    coords.insert(coords.end(), {p.x(), p.y(), p.z()});
  }
  Qhull run;
  run.run(coords);
  qhT* qh = run.qh();

  // Vertices: the input points qhull kept, renumbered.
  auto hull = std::make_shared<ConvexHull>();
  std::vector<int> index(points.size(), -1);
  vertexT* vertex;
  FORALLvertices {
    const int id = qh_pointid(qh, vertex->point);
    if (id < 0 || id >= static_cast<int>(points.size())) continue;
    index[static_cast<size_t>(id)] = static_cast<int>(hull->vertices.size());
    hull->vertices.push_back(points[static_cast<size_t>(id)]);
    hull->half_extents = hull->half_extents.cwiseMax(points[static_cast<size_t>(id)].cwiseAbs());
  }
  Eigen::Vector3d inside = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& v : hull->vertices) inside += v;
  inside /= static_cast<double>(hull->vertices.size());

  // Faces: qhull's outward plane; the vertices of a merged facet come unordered, so they are
  // sorted by angle about the face's centre (counter-clockwise seen from outside). Mass
  // properties from tetrahedra (inside, a, b, c) of a fan per face.
  double volume = 0.0;
  Eigen::Vector3d first_moment = Eigen::Vector3d::Zero();
  Eigen::Matrix3d second_moment = Eigen::Matrix3d::Zero();  // integral of x x^T over the volume
  std::vector<std::pair<double, unsigned>> around;
  facetT* facet;
  FORALLfacets {
    if (facet->upperdelaunay || !facet->normal) continue;
    const Eigen::Vector3d n(facet->normal[0], facet->normal[1], facet->normal[2]);
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    around.clear();
    vertexT** vertexp;
    FOREACHvertex_(facet->vertices) {
      const int id = qh_pointid(qh, vertex->point);
      if (id < 0 || id >= static_cast<int>(points.size()) || index[static_cast<size_t>(id)] < 0) continue;
      around.emplace_back(0.0, static_cast<unsigned>(index[static_cast<size_t>(id)]));
      centre += hull->vertices[around.back().second];
    }
    if (around.size() < 3) continue;
    centre /= static_cast<double>(around.size());
    const Eigen::Vector3d u = (hull->vertices[around[0].second] - centre).normalized();
    const Eigen::Vector3d w = n.cross(u);
    for (auto& [angle, i] : around) {
      const Eigen::Vector3d d = hull->vertices[i] - centre;
      angle = std::atan2(d.dot(w), d.dot(u));
    }
    std::sort(around.begin(), around.end());
    hull->planes.emplace_back(n.x(), n.y(), n.z(), -facet->offset);
    hull->polygons.push_back(static_cast<unsigned>(around.size()));
    for (const auto& entry : around) hull->polygons.push_back(entry.second);
    const Eigen::Vector3d& p0 = inside;
    const Eigen::Vector3d& p1 = hull->vertices[around[0].second];
    for (size_t i = 1; i + 1 < around.size(); ++i) {
      const Eigen::Vector3d& p2 = hull->vertices[around[i].second];
      const Eigen::Vector3d& p3 = hull->vertices[around[i + 1].second];
      const double v = (p1 - p0).dot((p2 - p0).cross(p3 - p0)) / 6.0;
      const Eigen::Vector3d s = p0 + p1 + p2 + p3;
      volume += v;
      first_moment += v * s / 4.0;
      second_moment += v / 20.0 * (p0 * p0.transpose() + p1 * p1.transpose() + p2 * p2.transpose() +
                                   p3 * p3.transpose() + s * s.transpose());
    }
  }
  hull->face_count = hull->planes.size();
  const double extent = std::max(hull->half_extents.maxCoeff(), 1e-12);
  if (hull->face_count < 4 || !(volume > 1e-15 * extent * extent * extent)) {
    throw std::invalid_argument("the points are coplanar or collinear: no volume");
  }
  hull->volume_m3 = volume;
  hull->centroid = first_moment / volume;
  const Eigen::Matrix3d C = second_moment - volume * hull->centroid * hull->centroid.transpose();
  hull->inertia_per_kg = (C.trace() * Eigen::Matrix3d::Identity() - C) / volume;
  return hull;
}

}  // namespace doppel::physics
