#include "camera/renderer.h"

#include <algorithm>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <limits>
#include <mutex>
#include <numbers>
#include <stdexcept>
#include <string>
#include <thread>

namespace doppel::camera {

using physics::ObjectKind;
using physics::ShapeType;
using physics::VisualShape;

namespace {

constexpr int kTile = 16;
constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr double kGroundTexelM = 0.01;     // ground texture resolution
constexpr int kMaxGroundTexels = 4096;     // per axis; coarser texels beyond
constexpr double kFlatTopMaxM = 0.01;      // shapes whose top is below this and lie flat go to the ground
constexpr float kNetPitchM = 0.05f;        // net mesh spacing
constexpr float kNetStringM = 0.012f;      // net string width
const uint8_t kFloorGrey[3] = {90, 90, 90};
const uint8_t kBackground[3] = {120, 120, 130};
const uint8_t kOutsideLens[3] = {0, 0, 0};

struct Prim {
  ShapeType type = ShapeType::kBox;
  bool net = false;
  int group = -1;             // annotation group, -1 for none
  Eigen::Matrix3f R_SC;       // camera-frame direction -> shape frame
  Eigen::Matrix3f R_CS;       // shape axes in the camera frame (normals)
  Eigen::Vector3f o_S;        // camera origin in the shape frame
  Eigen::Vector3f centre_C;   // shape origin in the camera frame
  Eigen::Vector3f half;       // box: half extents; cylinder/capsule: (r, half length); sphere: (r); ring: (ro, ri)
  const physics::ConvexHull* hull = nullptr;  // convex: its face planes (owned by the scene's shape)
  float bound_r = 0.0f;       // bounding-sphere radius about centre_C
  float near_t = 0.0f;        // no hit can be nearer than this along any ray
  float colour[3] = {0, 0, 0};
  uint32_t order = 0;         // position in the scene: ties in near_t keep scene order
};

struct Cone {
  Eigen::Vector3f dir = Eigen::Vector3f::UnitZ();  // towards the bounding sphere's centre
  float cos_a = 1.0f;                               // half angle it subtends: cos, sin, angle
  float sin_a = 0.0f;
  float angle = 0.0f;
  bool all = false;                                 // the camera is inside the bounding sphere
};

struct Group {
  AnnotationKind kind = AnnotationKind::kBall;
  uint16_t id = 0;
  Eigen::AlignedBox3d box_W;
  Eigen::Vector3d ref_W = Eigen::Vector3d::Zero();
  uint32_t px = 0;
};

bool annotated_kind(ObjectKind kind, AnnotationKind* out) {
  switch (kind) {
    case ObjectKind::kBall: *out = AnnotationKind::kBall; return true;
    case ObjectKind::kGoalPost: *out = AnnotationKind::kGoalPost; return true;
    case ObjectKind::kSidePole: *out = AnnotationKind::kSidePole; return true;
    case ObjectKind::kRobotBody:
    case ObjectKind::kTeamMarker: *out = AnnotationKind::kRobot; return true;
    default: return false;
  }
}

// World-frame half extents of a shape about its origin (for bounding boxes).
Eigen::Vector3d half_extent_W(const VisualShape& s) {
  Eigen::Vector3d local = Eigen::Vector3d::Zero();
  switch (s.type) {
    case ShapeType::kBox: local = 0.5 * s.size_m; break;
    case ShapeType::kSphere: return Eigen::Vector3d::Constant(s.size_m.x());
    case ShapeType::kCylinder: local = {s.size_m.x(), s.size_m.x(), 0.5 * s.size_m.y()}; break;
    case ShapeType::kCapsule: local = {s.size_m.x(), s.size_m.x(), 0.5 * s.size_m.y() + s.size_m.x()}; break;
    case ShapeType::kRing: local = {s.size_m.x(), s.size_m.x(), 0.5 * s.size_m.z()}; break;
    case ShapeType::kConvex: local = s.size_m; break;
  }
  return s.X_WS.linear().cwiseAbs() * local;
}

bool is_flat_on_ground(const VisualShape& s) {
  if (s.type != ShapeType::kBox && s.type != ShapeType::kRing) return false;
  if (s.X_WS.linear()(2, 2) < 0.9999) return false;
  const double top = s.X_WS.translation().z() + half_extent_W(s).z();
  return top <= kFlatTopMaxM;
}

// Nearest positive hit of the ray t * d (camera frame, from the origin) with a primitive, or kInf.
[[gnu::always_inline]] inline float intersect(const Prim& p, const Eigen::Vector3f& d) {
  if (p.type == ShapeType::kSphere) {
    const float b = d.dot(p.centre_C);
    const float c = p.centre_C.squaredNorm() - p.half.x() * p.half.x();
    const float disc = b * b - c;
    if (disc < 0.0f) return kInf;
    const float s = std::sqrt(disc);
    const float t = b - s;
    return t > 1e-4f ? t : kInf;
  }
  const Eigen::Matrix3f& R = p.R_SC;
  const Eigen::Vector3f dl(R(0, 0) * d.x() + R(0, 1) * d.y() + R(0, 2) * d.z(),
                           R(1, 0) * d.x() + R(1, 1) * d.y() + R(1, 2) * d.z(),
                           R(2, 0) * d.x() + R(2, 1) * d.y() + R(2, 2) * d.z());
  const Eigen::Vector3f& o = p.o_S;
  switch (p.type) {
    case ShapeType::kBox: {
      float tmin = -kInf;
      float tmax = kInf;
      for (int i = 0; i < 3; ++i) {
        const float h = p.half[i];
        if (std::abs(dl[i]) < 1e-12f) {
          if (o[i] < -h || o[i] > h) return kInf;
          continue;
        }
        const float inv = 1.0f / dl[i];
        float t1 = (-h - o[i]) * inv;
        float t2 = (h - o[i]) * inv;
        if (t1 > t2) std::swap(t1, t2);
        tmin = std::max(tmin, t1);
        tmax = std::min(tmax, t2);
        if (tmin > tmax) return kInf;
      }
      if (tmin <= 1e-4f) return kInf;
      if (p.net) {
        // A mesh: the ray passes where the entry point falls between the strings.
        const Eigen::Vector3f q = o + tmin * dl;
        int thin = 0;
        for (int i = 1; i < 3; ++i) {
          if (p.half[i] < p.half[thin]) thin = i;
        }
        for (int i = 0; i < 3; ++i) {
          if (i == thin) continue;
          const float u = q[i] + p.half[i];
          const float m = u - kNetPitchM * std::floor(u / kNetPitchM);
          if (m < kNetStringM) return tmin;
        }
        return kInf;
      }
      return tmin;
    }
    case ShapeType::kCylinder:
    case ShapeType::kCapsule: {
      const float r = p.half.x();
      const float hl = p.half.y();
      float best = kInf;
      const float a = dl.x() * dl.x() + dl.y() * dl.y();
      if (a > 1e-12f) {
        const float b = o.x() * dl.x() + o.y() * dl.y();
        const float c = o.x() * o.x() + o.y() * o.y() - r * r;
        const float disc = b * b - a * c;
        if (disc >= 0.0f) {
          const float t = (-b - std::sqrt(disc)) / a;
          const float z = o.z() + t * dl.z();
          if (t > 1e-4f && std::abs(z) <= hl) best = t;
        }
      }
      if (p.type == ShapeType::kCylinder) {
        if (std::abs(dl.z()) > 1e-12f) {
          const float zc = o.z() > 0.0f ? hl : -hl;
          const float t = (zc - o.z()) / dl.z();
          if (t > 1e-4f && t < best) {
            const float x = o.x() + t * dl.x();
            const float y = o.y() + t * dl.y();
            if (x * x + y * y <= r * r) best = t;
          }
        }
      } else {
        for (float zc : {-hl, hl}) {
          const Eigen::Vector3f oc(o.x(), o.y(), o.z() - zc);
          const float b = dl.dot(oc);
          const float c = oc.squaredNorm() - r * r;
          const float disc = b * b - c;
          if (disc < 0.0f) continue;
          const float t = -b - std::sqrt(disc);
          if (t > 1e-4f && t < best) best = t;
        }
      }
      return best;
    }
    case ShapeType::kRing: {
      if (std::abs(dl.z()) < 1e-12f) return kInf;
      const float t = -o.z() / dl.z();
      if (t <= 1e-4f) return kInf;
      const float x = o.x() + t * dl.x();
      const float y = o.y() + t * dl.y();
      const float rr = x * x + y * y;
      return (rr <= p.half.x() * p.half.x() && rr >= p.half.y() * p.half.y()) ? t : kInf;
    }
    case ShapeType::kConvex: {
      // The ray inside every face's half space: entering at the latest entry, leaving at the first exit.
      float tmin = -kInf;
      float tmax = kInf;
      for (const Eigen::Vector4d& plane : p.hull->planes) {
        const Eigen::Vector3f n = plane.head<3>().cast<float>();
        const float denom = n.dot(dl);
        const float gap = static_cast<float>(plane.w()) - n.dot(o);  // >= 0: the origin is inside this face
        if (std::abs(denom) < 1e-12f) {
          if (gap < 0.0f) return kInf;
          continue;
        }
        const float t = gap / denom;
        if (denom < 0.0f) {
          tmin = std::max(tmin, t);
        } else {
          tmax = std::min(tmax, t);
        }
        if (tmin > tmax) return kInf;
      }
      return tmin > 1e-4f ? tmin : kInf;
    }
    default: return kInf;
  }
}

// Outward normal at the hit at distance t, in the camera frame.
inline Eigen::Vector3f normal_C(const Prim& p, const Eigen::Vector3f& d, float t) {
  if (p.type == ShapeType::kSphere) return (t * d - p.centre_C) / p.half.x();
  const Eigen::Vector3f q = p.o_S + t * (p.R_SC * d);
  Eigen::Vector3f n = Eigen::Vector3f::Zero();
  switch (p.type) {
    case ShapeType::kBox: {
      int axis = 0;
      float best = -1.0f;
      for (int i = 0; i < 3; ++i) {
        const float f = std::abs(q[i]) / std::max(p.half[i], 1e-6f);
        if (f > best) {
          best = f;
          axis = i;
        }
      }
      n[axis] = q[axis] > 0.0f ? 1.0f : -1.0f;
      break;
    }
    case ShapeType::kCylinder:
      if (std::abs(q.z()) >= p.half.y() * 0.999f) {
        n.z() = q.z() > 0.0f ? 1.0f : -1.0f;
      } else {
        n = Eigen::Vector3f(q.x(), q.y(), 0.0f) / p.half.x();
      }
      break;
    case ShapeType::kCapsule: {
      const float zc = std::clamp(q.z(), -p.half.y(), p.half.y());
      n = (q - Eigen::Vector3f(0.0f, 0.0f, zc)) / p.half.x();
      break;
    }
    case ShapeType::kConvex: {
      // The face the hit lies on: the plane the point is least inside of.
      float best = -kInf;
      for (const Eigen::Vector4d& plane : p.hull->planes) {
        const Eigen::Vector3f np = plane.head<3>().cast<float>();
        const float outside = np.dot(q) - static_cast<float>(plane.w());
        if (outside > best) {
          best = outside;
          n = np;
        }
      }
      break;
    }
    default: n.z() = 1.0f; break;
  }
  Eigen::Vector3f nc = p.R_CS * n;
  if (nc.dot(d) > 0.0f) nc = -nc;
  return nc;
}

struct GroundTexture {
  double x0 = 0.0;
  double y0 = 0.0;
  double texel_m = kGroundTexelM;
  int w = 0;
  int h = 0;
  std::vector<uint8_t> index;               // palette index per texel
  std::vector<physics::Rgb> palette;        // 0 = floor
  uint64_t hash = 0;
  bool valid = false;
};

uint64_t fnv(uint64_t h, const void* data, size_t n) {
  const auto* p = static_cast<const uint8_t*>(data);
  for (size_t i = 0; i < n; ++i) {
    h ^= p[i];
    h *= 0x100000001B3ull;
  }
  return h;
}

uint64_t flat_hash(const std::vector<VisualShape>& shapes) {
  uint64_t h = 0xCBF29CE484222325ull;
  for (const VisualShape& s : shapes) {
    if (!is_flat_on_ground(s)) continue;
    const uint8_t tags[5] = {static_cast<uint8_t>(s.type), static_cast<uint8_t>(s.kind), s.colour.r, s.colour.g,
                             s.colour.b};
    h = fnv(h, tags, sizeof(tags));
    h = fnv(h, s.size_m.data(), 3 * sizeof(double));
    h = fnv(h, s.X_WS.matrix().data(), 16 * sizeof(double));
  }
  return h;
}

void rebuild_ground(const std::vector<VisualShape>& shapes, uint64_t hash, GroundTexture* g) {
  g->hash = hash;
  g->palette.assign(1, physics::Rgb{kFloorGrey[0], kFloorGrey[1], kFloorGrey[2]});
  std::vector<const VisualShape*> flat;
  Eigen::AlignedBox2d extent;
  for (const VisualShape& s : shapes) {
    if (!is_flat_on_ground(s)) continue;
    flat.push_back(&s);
    const Eigen::Vector2d c = s.X_WS.translation().head<2>();
    const Eigen::Vector2d e = half_extent_W(s).head<2>();
    extent.extend(c - e);
    extent.extend(c + e);
  }
  g->valid = !flat.empty();
  if (!g->valid) return;
  // Painter's order: lower tops first, so lines cover the carpet.
  std::stable_sort(flat.begin(), flat.end(), [](const VisualShape* a, const VisualShape* b) {
    return a->X_WS.translation().z() + half_extent_W(*a).z() < b->X_WS.translation().z() + half_extent_W(*b).z();
  });
  const Eigen::Vector2d size = extent.sizes();
  g->texel_m = std::max(kGroundTexelM, std::max(size.x(), size.y()) / kMaxGroundTexels);
  g->x0 = extent.min().x();
  g->y0 = extent.min().y();
  g->w = std::max(1, static_cast<int>(std::ceil(size.x() / g->texel_m)));
  g->h = std::max(1, static_cast<int>(std::ceil(size.y() / g->texel_m)));
  g->index.assign(static_cast<size_t>(g->w) * g->h, 0);
  for (const VisualShape* s : flat) {
    uint8_t idx = 0;
    for (size_t i = 1; i < g->palette.size(); ++i) {
      const physics::Rgb& c = g->palette[i];
      if (c.r == s->colour.r && c.g == s->colour.g && c.b == s->colour.b) idx = static_cast<uint8_t>(i);
    }
    if (idx == 0) {
      if (g->palette.size() >= 256) continue;
      g->palette.push_back(s->colour);
      idx = static_cast<uint8_t>(g->palette.size() - 1);
    }
    const Eigen::Vector2d c = s->X_WS.translation().head<2>();
    const Eigen::Vector2d e = half_extent_W(*s).head<2>();
    const Eigen::Matrix2d Rt = s->X_WS.linear().topLeftCorner<2, 2>().transpose();
    const int i0 = std::max(0, static_cast<int>(std::floor((c.x() - e.x() - g->x0) / g->texel_m)));
    const int i1 = std::min(g->w - 1, static_cast<int>(std::ceil((c.x() + e.x() - g->x0) / g->texel_m)));
    const int j0 = std::max(0, static_cast<int>(std::floor((c.y() - e.y() - g->y0) / g->texel_m)));
    const int j1 = std::min(g->h - 1, static_cast<int>(std::ceil((c.y() + e.y() - g->y0) / g->texel_m)));
    for (int j = j0; j <= j1; ++j) {
      for (int i = i0; i <= i1; ++i) {
        const Eigen::Vector2d p(g->x0 + (i + 0.5) * g->texel_m, g->y0 + (j + 0.5) * g->texel_m);
        const Eigen::Vector2d l = Rt * (p - c);
        bool inside = false;
        if (s->type == ShapeType::kBox) {
          inside = std::abs(l.x()) <= 0.5 * s->size_m.x() && std::abs(l.y()) <= 0.5 * s->size_m.y();
        } else {
          const double r = l.norm();
          inside = r <= s->size_m.x() && r >= s->size_m.y();
        }
        if (inside) g->index[static_cast<size_t>(j) * g->w + i] = idx;
      }
    }
  }
}

}  // namespace

struct Renderer::Impl {
  Lens lens;
  int w;
  int h;
  PixelFormat format;
  int threads;
  NoiseFilter noise;
  std::vector<physics::FieldFeature> features = physics::field_features();

  // Per lens, once: unit rays (x, y, z per pixel; zero where the lens has no ray) and tile cones.
  std::vector<float> rays;
  int tiles_x = 0;
  int tiles_y = 0;
  std::vector<Eigen::Vector3f> tile_dir;
  std::vector<float> tile_cos;  // cos and sin of the tile cone's half angle
  std::vector<float> tile_sin;
  std::vector<float> tile_half;  // half angle, rad
  std::vector<uint8_t> tile_valid;

  // Per frame.
  GroundTexture ground;
  std::vector<Prim> prims;
  std::vector<Group> groups;
  std::vector<uint32_t> tile_offsets;
  std::vector<uint16_t> tile_prims;
  std::vector<Cone> cones;
  Eigen::Matrix3f R_WC_f;
  Eigen::Vector3f o_W_f;
  Eigen::Vector3f light_C;
  uint64_t frame = 0;
  uint8_t* out = nullptr;
  std::vector<std::vector<uint8_t>> row_buffers;   // per thread
  std::vector<std::vector<uint32_t>> hit_counts;   // per thread, per primitive
  RenderStats stats;

  // Worker threads: each takes the tile rows ty with ty % threads == its index.
  std::vector<std::thread> workers;
  std::mutex mutex;
  std::condition_variable start_cv;
  std::condition_variable done_cv;
  uint64_t generation = 0;
  int pending = 0;
  bool stop = false;

  Impl(const LensConfig& lens_config, int width, int height, PixelFormat fmt, int n_threads)
      : lens(lens_config, width, height), w(width), h(height), format(fmt), threads(n_threads), noise(width, height) {
    build_ray_table();
    row_buffers.assign(threads, std::vector<uint8_t>(3 * static_cast<size_t>(w)));
    hit_counts.assign(threads, {});
    for (int k = 1; k < threads; ++k) workers.emplace_back([this, k] { worker_loop(k); });
  }

  ~Impl() {
    {
      std::lock_guard<std::mutex> lock(mutex);
      stop = true;
    }
    start_cv.notify_all();
    for (std::thread& t : workers) t.join();
  }

  void build_ray_table() {
    rays.assign(3 * static_cast<size_t>(w) * h, 0.0f);
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        Eigen::Vector3d r;
        if (!lens.unproject({static_cast<double>(x), static_cast<double>(y)}, &r)) continue;
        float* dst = &rays[3 * (static_cast<size_t>(y) * w + x)];
        dst[0] = static_cast<float>(r.x());
        dst[1] = static_cast<float>(r.y());
        dst[2] = static_cast<float>(r.z());
      }
    }
    tiles_x = (w + kTile - 1) / kTile;
    tiles_y = (h + kTile - 1) / kTile;
    const size_t n = static_cast<size_t>(tiles_x) * tiles_y;
    tile_dir.assign(n, Eigen::Vector3f::UnitZ());
    tile_cos.assign(n, 1.0f);
    tile_sin.assign(n, 0.0f);
    tile_valid.assign(n, 0);
    tile_half.assign(n, 0.0f);
    for (int ty = 0; ty < tiles_y; ++ty) {
      for (int tx = 0; tx < tiles_x; ++tx) {
        Eigen::Vector3d sum = Eigen::Vector3d::Zero();
        for (int y = ty * kTile; y < std::min(h, (ty + 1) * kTile); ++y) {
          for (int x = tx * kTile; x < std::min(w, (tx + 1) * kTile); ++x) {
            const float* r = &rays[3 * (static_cast<size_t>(y) * w + x)];
            sum += Eigen::Vector3d(r[0], r[1], r[2]);
          }
        }
        const size_t t = static_cast<size_t>(ty) * tiles_x + tx;
        if (sum.norm() < 1e-9) continue;
        const Eigen::Vector3d dir = sum.normalized();
        double min_dot = 1.0;
        for (int y = ty * kTile; y < std::min(h, (ty + 1) * kTile); ++y) {
          for (int x = tx * kTile; x < std::min(w, (tx + 1) * kTile); ++x) {
            const float* r = &rays[3 * (static_cast<size_t>(y) * w + x)];
            if (r[0] == 0.0f && r[1] == 0.0f && r[2] == 0.0f) continue;
            min_dot = std::min(min_dot, dir.dot(Eigen::Vector3d(r[0], r[1], r[2])));
          }
        }
        // Rays between pixel centres (where an edge can be) reach a little further.
        const double half = std::min(std::acos(std::clamp(min_dot, -1.0, 1.0)) * 1.05 + 1e-3, std::numbers::pi);
        tile_dir[t] = dir.cast<float>();
        tile_half[t] = static_cast<float>(half);
        tile_cos[t] = static_cast<float>(std::cos(half));
        tile_sin[t] = static_cast<float>(std::sin(half));
        tile_valid[t] = 1;
      }
    }
  }

  void prepare(const physics::SceneView& scene, const Eigen::Isometry3d& X_WC) {
    stats = {};
    const uint64_t hash = flat_hash(scene.shapes);
    if (hash != ground.hash || (!ground.valid && ground.palette.empty())) {
      rebuild_ground(scene.shapes, hash, &ground);
      stats.ground_rebuilt = true;
    }
    const Eigen::Isometry3d X_CW = X_WC.inverse();
    R_WC_f = X_WC.linear().cast<float>();
    o_W_f = X_WC.translation().cast<float>();
    light_C = (X_CW.linear() * Eigen::Vector3d(0.3, 0.2, 1.0).normalized()).cast<float>();

    // Annotation groups and primitives.
    groups.clear();
    prims.clear();
    for (const VisualShape& s : scene.shapes) {
      int group = -1;
      AnnotationKind kind;
      if (annotated_kind(s.kind, &kind)) {
        for (size_t g = 0; g < groups.size(); ++g) {
          if (groups[g].kind == kind && groups[g].id == s.object_id) group = static_cast<int>(g);
        }
        if (group < 0) {
          Group g;
          g.kind = kind;
          g.id = s.object_id;
          groups.push_back(g);
          group = static_cast<int>(groups.size() - 1);
        }
        const Eigen::Vector3d e = half_extent_W(s);
        groups[group].box_W.extend(s.X_WS.translation() - e);
        groups[group].box_W.extend(s.X_WS.translation() + e);
        if (kind == AnnotationKind::kBall) groups[group].ref_W = s.X_WS.translation();
      }
      if (is_flat_on_ground(s)) continue;
      Prim p;
      p.type = s.type;
      p.net = s.kind == ObjectKind::kGoalNet;
      p.group = group;
      const Eigen::Isometry3d X_CS = X_CW * s.X_WS;
      p.R_CS = X_CS.linear().cast<float>();
      p.R_SC = p.R_CS.transpose();
      p.centre_C = X_CS.translation().cast<float>();
      p.o_S = -(p.R_SC * p.centre_C);
      switch (s.type) {
        case ShapeType::kBox:
          p.half = (0.5 * s.size_m).cast<float>();
          p.bound_r = p.half.norm();
          break;
        case ShapeType::kSphere:
          p.half = Eigen::Vector3f(static_cast<float>(s.size_m.x()), 0.0f, 0.0f);
          p.bound_r = p.half.x();
          break;
        case ShapeType::kCylinder:
          p.half = Eigen::Vector3f(static_cast<float>(s.size_m.x()), static_cast<float>(0.5 * s.size_m.y()), 0.0f);
          p.bound_r = std::hypot(p.half.x(), p.half.y());
          break;
        case ShapeType::kCapsule:
          p.half = Eigen::Vector3f(static_cast<float>(s.size_m.x()), static_cast<float>(0.5 * s.size_m.y()), 0.0f);
          p.bound_r = p.half.x() + p.half.y();
          break;
        case ShapeType::kRing:
          p.half = Eigen::Vector3f(static_cast<float>(s.size_m.x()), static_cast<float>(s.size_m.y()), 0.0f);
          p.bound_r = p.half.x();
          break;
        case ShapeType::kConvex:
          if (!s.hull) continue;
          p.hull = s.hull.get();
          p.half = s.size_m.cast<float>();
          for (const Eigen::Vector3d& v : s.hull->vertices) p.bound_r = std::max(p.bound_r, static_cast<float>(v.norm()));
          break;
      }
      if (!(p.bound_r > 0.0f)) continue;
      p.near_t = std::max(0.0f, p.centre_C.norm() - p.bound_r);
      p.colour[0] = s.colour.r;
      p.colour[1] = s.colour.g;
      p.colour[2] = s.colour.b;
      p.order = static_cast<uint32_t>(prims.size());
      prims.push_back(p);
    }
    for (Group& g : groups) {
      if (g.kind != AnnotationKind::kBall) {
        const Eigen::Vector3d c = g.box_W.center();
        g.ref_W = {c.x(), c.y(), g.box_W.min().z()};
      }
    }
    // std::sort with a tie-break instead of std::stable_sort, whose temporary buffer allocates per frame.
    std::sort(prims.begin(), prims.end(), [](const Prim& a, const Prim& b) {
      return a.near_t < b.near_t || (a.near_t == b.near_t && a.order < b.order);
    });
    stats.primitives = static_cast<uint32_t>(prims.size());
  }

  void cull_tiles() {
    const size_t n_tiles = static_cast<size_t>(tiles_x) * tiles_y;
    tile_offsets.assign(n_tiles + 1, 0);
    tile_prims.clear();
    // Cone of each primitive's bounding sphere as seen from the camera.
    cones.resize(prims.size());
    for (size_t i = 0; i < prims.size(); ++i) {
      const float dist = prims[i].centre_C.norm();
      Cone& c = cones[i];
      c.all = dist <= prims[i].bound_r * 1.001f;
      if (c.all) continue;
      c.dir = prims[i].centre_C / dist;
      c.sin_a = prims[i].bound_r / dist;
      c.cos_a = std::sqrt(std::max(0.0f, 1.0f - c.sin_a * c.sin_a));
      c.angle = std::asin(std::min(1.0f, c.sin_a));
    }
    for (size_t t = 0; t < n_tiles; ++t) {
      tile_offsets[t] = static_cast<uint32_t>(tile_prims.size());
      if (!tile_valid[t]) continue;
      for (size_t i = 0; i < prims.size(); ++i) {
        const Cone& c = cones[i];
        // Overlap when the angle between the axes is at most the sum of the half angles; the
        // cosine of that sum comes from the stored sines and cosines.
        const bool hit = c.all || tile_half[t] + c.angle >= std::numbers::pi_v<float> ||
                         tile_dir[t].dot(c.dir) >= tile_cos[t] * c.cos_a - tile_sin[t] * c.sin_a;
        if (hit) tile_prims.push_back(static_cast<uint16_t>(i));
      }
    }
    tile_offsets[n_tiles] = static_cast<uint32_t>(tile_prims.size());
    stats.tile_entries = static_cast<uint32_t>(tile_prims.size());
  }

  void shade_row(int y, int thread) {
    uint8_t* rgb = row_buffers[thread].data();
    uint32_t* counts = hit_counts[thread].data();
    const Eigen::Vector3f r0 = R_WC_f.row(0).transpose();
    const Eigen::Vector3f r1 = R_WC_f.row(1).transpose();
    const Eigen::Vector3f r2 = R_WC_f.row(2).transpose();
    const float oz = o_W_f.z();
    const GroundTexture& g = ground;
    const float inv_texel = static_cast<float>(1.0 / g.texel_m);
    const float gx0 = static_cast<float>(g.x0);
    const float gy0 = static_cast<float>(g.y0);
    const float tex_w = static_cast<float>(g.w);
    const float tex_h = static_cast<float>(g.h);
    const int ty = y / kTile;
    for (int tx = 0; tx < tiles_x; ++tx) {
      const size_t t = static_cast<size_t>(ty) * tiles_x + tx;
      const uint16_t* list = tile_prims.data() + tile_offsets[t];
      const uint32_t n_list = tile_offsets[t + 1] - tile_offsets[t];
      const int x_end = std::min(w, (tx + 1) * kTile);
      for (int x = tx * kTile; x < x_end; ++x) {
        const float* r = &rays[3 * (static_cast<size_t>(y) * w + x)];
        uint8_t* px = rgb + 3 * x;
        const Eigen::Vector3f d(r[0], r[1], r[2]);
        if (d.x() == 0.0f && d.y() == 0.0f && d.z() == 0.0f) {
          std::memcpy(px, kOutsideLens, 3);
          continue;
        }
        float best = kInf;
        bool on_ground = false;
        const float dz = r2.dot(d);
        if (dz < -1e-7f && oz > 0.0f) {
          best = -oz / dz;
          on_ground = true;
        }
        int hit = -1;
        for (uint32_t k = 0; k < n_list; ++k) {
          const Prim& p = prims[list[k]];
          if (p.near_t >= best) break;
          const float tt = intersect(p, d);
          if (tt < best) {
            best = tt;
            hit = list[k];
          }
        }
        if (hit >= 0) {
          const Prim& p = prims[hit];
          const Eigen::Vector3f n = normal_C(p, d, best);
          const float shade = 0.55f + 0.45f * std::max(0.0f, n.dot(light_C));
          px[0] = static_cast<uint8_t>(p.colour[0] * shade + 0.5f);
          px[1] = static_cast<uint8_t>(p.colour[1] * shade + 0.5f);
          px[2] = static_cast<uint8_t>(p.colour[2] * shade + 0.5f);
          ++counts[hit];
        } else if (on_ground) {
          const float fi = (o_W_f.x() + best * r0.dot(d) - gx0) * inv_texel;
          const float fj = (o_W_f.y() + best * r1.dot(d) - gy0) * inv_texel;
          // Truncation is floor here: negative coordinates are rejected first.
          if (g.valid && fi >= 0.0f && fj >= 0.0f && fi < tex_w && fj < tex_h) {
            const physics::Rgb& c = g.palette[g.index[static_cast<size_t>(fj) * g.w + static_cast<size_t>(fi)]];
            px[0] = c.r;
            px[1] = c.g;
            px[2] = c.b;
          } else {
            std::memcpy(px, kFloorGrey, 3);
          }
        } else {
          std::memcpy(px, kBackground, 3);
        }
      }
    }
    noise.apply_row(rgb, y, frame);
    encode_row(format, y, rgb, w, out + static_cast<size_t>(y) * row_bytes(format, w));
  }

  void render_share(int thread) {
    std::fill(hit_counts[thread].begin(), hit_counts[thread].end(), 0u);
    for (int ty = thread; ty < tiles_y; ty += threads) {
      const int y_end = std::min(h, (ty + 1) * kTile);
      for (int y = ty * kTile; y < y_end; ++y) shade_row(y, thread);
    }
  }

  void worker_loop(int index) {
    uint64_t seen = 0;
    for (;;) {
      {
        std::unique_lock<std::mutex> lock(mutex);
        start_cv.wait(lock, [&] { return stop || generation != seen; });
        if (stop) return;
        seen = generation;
      }
      render_share(index);
      {
        std::lock_guard<std::mutex> lock(mutex);
        if (--pending == 0) done_cv.notify_one();
      }
    }
  }

  void run_all() {
    for (auto& c : hit_counts) c.resize(prims.size());
    if (threads > 1) {
      {
        std::lock_guard<std::mutex> lock(mutex);
        pending = threads - 1;
        ++generation;
      }
      start_cv.notify_all();
    }
    render_share(0);
    if (threads > 1) {
      std::unique_lock<std::mutex> lock(mutex);
      done_cv.wait(lock, [&] { return pending == 0; });
    }
    for (Group& g : groups) g.px = 0;
    for (size_t i = 0; i < prims.size(); ++i) {
      if (prims[i].group < 0) continue;
      uint32_t sum = 0;
      for (const auto& c : hit_counts) sum += c[i];
      groups[prims[i].group].px += sum;
    }
  }

  // True when some primitive other than those of `exclude_group` lies on the segment camera -> p_W.
  bool occluded(const Eigen::Vector3d& p_W, int exclude_group) const {
    const Eigen::Vector3f v = R_WC_f.transpose() * (p_W.cast<float>() - o_W_f);
    const float dist = v.norm();
    if (dist < 1e-6f) return false;
    const Eigen::Vector3f d = v / dist;
    for (const Prim& p : prims) {
      if (p.near_t >= dist) break;
      if (exclude_group >= 0 && p.group == exclude_group) continue;
      if (intersect(p, d) < dist * (1.0f - 1e-4f) - 1e-4f) return true;
    }
    return false;
  }

  bool project_W(const Eigen::Vector3d& p_W, Eigen::Vector2d* px) const {
    const Eigen::Vector3d p_C = R_WC_f.cast<double>().transpose() * (p_W - o_W_f.cast<double>());
    return lens.project(p_C, px);
  }

  bool in_image(const Eigen::Vector2d& px) const {
    return px.x() >= -0.5 && px.y() >= -0.5 && px.x() <= w - 0.5 && px.y() <= h - 0.5;
  }

  void fill_annotations(FrameAnnotations* a, bool with_pixels) {
    a->count = 0;
    a->dropped = 0;
    auto push = [a](const Annotation& item) {
      if (a->count < kMaxAnnotations) {
        a->items[a->count++] = item;
      } else {
        ++a->dropped;
      }
    };
    const Eigen::Vector3d o_W = o_W_f.cast<double>();
    for (size_t gi = 0; gi < groups.size(); ++gi) {
      const Group& g = groups[gi];
      Annotation item;
      item.kind = g.kind;
      item.object_id = g.id;
      set_reference(g.ref_W, o_W, &item);
      Eigen::AlignedBox2d box;
      Eigen::Vector2d px;
      for (int c = 0; c < 8; ++c) {
        if (project_W(g.box_W.corner(static_cast<Eigen::AlignedBox3d::CornerType>(c)), &px)) box.extend(px);
      }
      if (project_W(g.box_W.center(), &px)) box.extend(px);
      if (item.in_fov) box.extend(Eigen::Vector2d(item.u_px, item.v_px));
      set_bbox(box, &item);
      if (with_pixels) {
        item.visible_px = g.px;
        item.visible = g.px > 0 ? 1 : 0;
      } else {
        bool seen = false;
        const Eigen::Vector3d samples[2] = {g.box_W.center(), g.ref_W};
        for (const Eigen::Vector3d& sample : samples) {
          Eigen::Vector2d q;
          if (project_W(sample, &q) && in_image(q) && !occluded(sample, static_cast<int>(gi))) seen = true;
        }
        item.visible = seen ? 1 : 0;
      }
      push(item);
    }
    for (size_t i = 0; i < features.size(); ++i) {
      const physics::FieldFeature& f = features[i];
      Annotation item;
      item.kind = f.type == physics::FieldFeatureType::kL   ? AnnotationKind::kLineL
                  : f.type == physics::FieldFeatureType::kT ? AnnotationKind::kLineT
                                                            : AnnotationKind::kLineX;
      item.object_id = static_cast<uint16_t>(i);
      item.heading_rad = static_cast<float>(f.heading_rad);
      set_reference(f.position_W, o_W, &item);
      Eigen::AlignedBox2d box;
      if (item.in_fov) box.extend(Eigen::Vector2d(item.u_px, item.v_px));
      set_bbox(box, &item);
      item.visible = (item.in_fov && !occluded(f.position_W + Eigen::Vector3d(0, 0, 0.003), -1)) ? 1 : 0;
      push(item);
    }
  }

  void set_reference(const Eigen::Vector3d& ref_W, const Eigen::Vector3d& o_W, Annotation* item) const {
    item->x_w_m = static_cast<float>(ref_W.x());
    item->y_w_m = static_cast<float>(ref_W.y());
    item->z_w_m = static_cast<float>(ref_W.z());
    item->distance_m = static_cast<float>((ref_W - o_W).norm());
    Eigen::Vector2d px;
    if (project_W(ref_W, &px)) {
      item->u_px = static_cast<float>(px.x());
      item->v_px = static_cast<float>(px.y());
      item->in_fov = in_image(px) ? 1 : 0;
    } else {
      item->u_px = item->v_px = std::numeric_limits<float>::quiet_NaN();
      item->in_fov = 0;
    }
  }

  void set_bbox(const Eigen::AlignedBox2d& box, Annotation* item) const {
    if (box.isEmpty()) return;
    const Eigen::Vector2d lo = box.min().cwiseMax(Eigen::Vector2d(-0.5, -0.5));
    const Eigen::Vector2d hi = box.max().cwiseMin(Eigen::Vector2d(w - 0.5, h - 0.5));
    if (lo.x() > hi.x() || lo.y() > hi.y()) return;
    item->bbox_min_u = static_cast<float>(lo.x());
    item->bbox_min_v = static_cast<float>(lo.y());
    item->bbox_max_u = static_cast<float>(hi.x());
    item->bbox_max_v = static_cast<float>(hi.y());
  }
};

Renderer::Renderer(const LensConfig& lens, int width_px, int height_px, PixelFormat format, int threads) {
  if (threads < 1 || threads > 16) throw std::invalid_argument("Renderer: threads must lie in 1..16");
  if (is_yuv422(format) && (width_px % 2) != 0) throw std::invalid_argument("Renderer: YUV422 needs an even width");
  impl_ = std::make_unique<Impl>(lens, width_px, height_px, format, threads);
}

Renderer::~Renderer() = default;

void Renderer::render(const physics::SceneView& scene, const Eigen::Isometry3d& X_WC, uint64_t frame, uint8_t* out,
                      FrameAnnotations* annotations) {
  Impl& s = *impl_;
  s.prepare(scene, X_WC);
  s.cull_tiles();
  s.frame = frame;
  s.out = out;
  s.run_all();
  if (annotations != nullptr) s.fill_annotations(annotations, true);
}

void Renderer::annotate(const physics::SceneView& scene, const Eigen::Isometry3d& X_WC, FrameAnnotations* annotations) {
  impl_->prepare(scene, X_WC);
  impl_->fill_annotations(annotations, false);
}

void Renderer::set_noise(const NoiseConfig& config) { impl_->noise.configure(config); }
void Renderer::set_field_features(std::vector<physics::FieldFeature> features) {
  impl_->features = std::move(features);
}
const Lens& Renderer::lens() const noexcept { return impl_->lens; }
PixelFormat Renderer::format() const noexcept { return impl_->format; }
int Renderer::width_px() const noexcept { return impl_->w; }
int Renderer::height_px() const noexcept { return impl_->h; }
RenderStats Renderer::last_stats() const noexcept { return impl_->stats; }

}  // namespace doppel::camera
