#include "camera/lens.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace doppel::camera {
namespace {

constexpr double kDegToRad = std::numbers::pi / 180.0;
constexpr double kNaturalFisheyeFovDeg = 179.9;
// Undistorted radius (tan of the angle) up to which a pinhole's distortion is examined: 89.4 deg.
constexpr double kPinholeMaxRadius = 100.0;

double fisheye_r_of(LensModel model, double theta) noexcept {
  switch (model) {
    case LensModel::kEquidistant: return theta;
    case LensModel::kEquisolid: return 2.0 * std::sin(0.5 * theta);
    case LensModel::kStereographic: return 2.0 * std::tan(0.5 * theta);
    case LensModel::kPinhole: return std::tan(theta);
  }
  return theta;
}

double fisheye_theta_of(LensModel model, double r) noexcept {
  switch (model) {
    case LensModel::kEquidistant: return r;
    case LensModel::kEquisolid: return 2.0 * std::asin(std::min(1.0, 0.5 * r));
    case LensModel::kStereographic: return 2.0 * std::atan(0.5 * r);
    case LensModel::kPinhole: return std::atan(r);
  }
  return r;
}

}  // namespace

std::string_view to_string(LensModel model) noexcept {
  switch (model) {
    case LensModel::kPinhole: return "pinhole";
    case LensModel::kEquidistant: return "equidistant";
    case LensModel::kEquisolid: return "equisolid";
    case LensModel::kStereographic: return "stereographic";
  }
  return "unknown";
}

LensModel parse_lens_model(std::string_view name) {
  for (LensModel m : {LensModel::kPinhole, LensModel::kEquidistant, LensModel::kEquisolid,
                      LensModel::kStereographic}) {
    if (to_string(m) == name) return m;
  }
  throw std::invalid_argument("unknown lens model '" + std::string(name) +
                              "' (pinhole, equidistant, equisolid, stereographic)");
}

LensConfig pinhole_from_hfov(int width_px, int height_px, double hfov_deg) {
  if (width_px <= 0 || height_px <= 0) throw std::invalid_argument("pinhole_from_hfov: image size must be positive");
  if (!(hfov_deg > 0.0 && hfov_deg < 180.0)) {
    throw std::invalid_argument("pinhole_from_hfov: hfov_deg must lie in (0, 180), got " + std::to_string(hfov_deg));
  }
  LensConfig c;
  c.model = LensModel::kPinhole;
  c.fx_px = c.fy_px = 0.5 * width_px / std::tan(0.5 * hfov_deg * kDegToRad);
  c.cx_px = 0.5 * (width_px - 1);
  c.cy_px = 0.5 * (height_px - 1);
  return c;
}

LensConfig fisheye_from_hfov(LensModel model, int width_px, int height_px, double hfov_deg) {
  if (model == LensModel::kPinhole) throw std::invalid_argument("fisheye_from_hfov: pinhole is not a fisheye model");
  if (width_px <= 0 || height_px <= 0) throw std::invalid_argument("fisheye_from_hfov: image size must be positive");
  if (!(hfov_deg > 0.0 && hfov_deg < 180.0)) {
    throw std::invalid_argument("fisheye_from_hfov: hfov_deg must lie in (0, 180), got " + std::to_string(hfov_deg));
  }
  LensConfig c;
  c.model = model;
  c.fx_px = c.fy_px = 0.5 * width_px / fisheye_r_of(model, 0.5 * hfov_deg * kDegToRad);
  c.cx_px = 0.5 * (width_px - 1);
  c.cy_px = 0.5 * (height_px - 1);
  const double corner_r = std::hypot(0.5 * width_px, 0.5 * height_px) / c.fx_px;
  const double corner_theta = fisheye_theta_of(model, corner_r);
  if (model == LensModel::kEquisolid && corner_r >= 2.0) {
    throw std::invalid_argument("fisheye_from_hfov: an equisolid lens with hfov " + std::to_string(hfov_deg) +
                                " deg cannot fill the image corners");
  }
  if (2.0 * corner_theta >= kNaturalFisheyeFovDeg * kDegToRad) {
    throw std::invalid_argument("fisheye_from_hfov: hfov " + std::to_string(hfov_deg) +
                                " deg gives a diagonal field of view of 180 deg or more");
  }
  return c;
}

Lens::Lens(const LensConfig& config, int width_px, int height_px)
    : config_(config), width_px_(width_px), height_px_(height_px) {
  if (width_px <= 0 || height_px <= 0) throw std::invalid_argument("Lens: image size must be positive");
  if (!(config.fx_px > 0.0) || !(config.fy_px > 0.0)) {
    throw std::invalid_argument("Lens: focal lengths must be positive");
  }
  if (!(config.fov_deg >= 0.0 && config.fov_deg < 180.0)) {
    throw std::invalid_argument("Lens: fov_deg must lie in [0, 180), got " + std::to_string(config.fov_deg));
  }
  if (config.model == LensModel::kPinhole) {
    // Largest undistorted radius over which r_d(r) = r (1 + k1 r^2 + k2 r^4 + k3 r^6) still grows:
    // beyond that fold two directions would share a pixel and unprojection could not be exact.
    double r = 0.0;
    double last_good = 0.0;
    while (r < kPinholeMaxRadius) {
      const double r2 = r * r;
      const double slope = 1.0 + 3.0 * config.k1 * r2 + 5.0 * config.k2 * r2 * r2 + 7.0 * config.k3 * r2 * r2 * r2;
      if (slope <= 1e-3) break;
      last_good = r;
      r += 1e-3 * (1.0 + r);
    }
    max_r_norm_ = last_good;
    if (max_r_norm_ <= 0.0) throw std::invalid_argument("Lens: pinhole distortion folds at the optical axis");
    max_theta_rad_ = std::atan(max_r_norm_);
    if (config.fov_deg > 0.0) {
      max_theta_rad_ = std::min(max_theta_rad_, 0.5 * config.fov_deg * kDegToRad);
      max_r_norm_ = std::tan(max_theta_rad_);
    }
  } else {
    const double fov = config.fov_deg > 0.0 ? config.fov_deg : kNaturalFisheyeFovDeg;
    max_theta_rad_ = 0.5 * fov * kDegToRad;
    max_r_norm_ = fisheye_r(max_theta_rad_);
  }
}

double Lens::fisheye_r(double theta) const noexcept { return fisheye_r_of(config_.model, theta); }
double Lens::fisheye_theta(double r) const noexcept { return fisheye_theta_of(config_.model, r); }

Eigen::Vector2d Lens::distort(const Eigen::Vector2d& xy) const noexcept {
  const double x = xy.x();
  const double y = xy.y();
  const double r2 = x * x + y * y;
  const double radial = 1.0 + r2 * (config_.k1 + r2 * (config_.k2 + r2 * config_.k3));
  return {x * radial + 2.0 * config_.p1 * x * y + config_.p2 * (r2 + 2.0 * x * x),
          y * radial + config_.p1 * (r2 + 2.0 * y * y) + 2.0 * config_.p2 * x * y};
}

bool Lens::undistort(const Eigen::Vector2d& xyd, Eigen::Vector2d* xy) const noexcept {
  // Newton's method on distort(xy) = xyd with the analytic Jacobian, starting from xyd.
  Eigen::Vector2d p = xyd;
  for (int i = 0; i < 50; ++i) {
    const Eigen::Vector2d err = distort(p) - xyd;
    if (err.squaredNorm() < 1e-30) break;
    const double x = p.x();
    const double y = p.y();
    const double r2 = x * x + y * y;
    const double radial = 1.0 + r2 * (config_.k1 + r2 * (config_.k2 + r2 * config_.k3));
    const double dradial = config_.k1 + r2 * (2.0 * config_.k2 + 3.0 * config_.k3 * r2);  // d radial / d r2
    Eigen::Matrix2d J;
    J(0, 0) = radial + 2.0 * x * x * dradial + 2.0 * config_.p1 * y + 6.0 * config_.p2 * x;
    J(0, 1) = 2.0 * x * y * dradial + 2.0 * config_.p1 * x + 2.0 * config_.p2 * y;
    J(1, 0) = 2.0 * x * y * dradial + 2.0 * config_.p1 * x + 2.0 * config_.p2 * y;
    J(1, 1) = radial + 2.0 * y * y * dradial + 6.0 * config_.p1 * y + 2.0 * config_.p2 * x;
    const double det = J(0, 0) * J(1, 1) - J(0, 1) * J(1, 0);
    if (std::abs(det) < 1e-12) return false;
    p.x() -= (J(1, 1) * err.x() - J(0, 1) * err.y()) / det;
    p.y() -= (-J(1, 0) * err.x() + J(0, 0) * err.y()) / det;
    if (!p.allFinite() || p.norm() > 2.0 * max_r_norm_ + 1.0) return false;
  }
  if ((distort(p) - xyd).norm() > 1e-12 * (1.0 + xyd.norm())) return false;
  if (p.norm() > max_r_norm_) return false;
  *xy = p;
  return true;
}

bool Lens::project(const Eigen::Vector3d& p_C, Eigen::Vector2d* px) const noexcept {
  const double rho = std::hypot(p_C.x(), p_C.y());
  const double theta = std::atan2(rho, p_C.z());
  if (!(theta <= max_theta_rad_)) return false;
  if (config_.model == LensModel::kPinhole) {
    if (p_C.z() <= 0.0) return false;
    const Eigen::Vector2d xy(p_C.x() / p_C.z(), p_C.y() / p_C.z());
    if (xy.norm() > max_r_norm_) return false;
    const Eigen::Vector2d d = distort(xy);
    *px = {config_.fx_px * d.x() + config_.cx_px, config_.fy_px * d.y() + config_.cy_px};
    return true;
  }
  if (rho <= 0.0) {
    if (p_C.z() <= 0.0) return false;
    *px = {config_.cx_px, config_.cy_px};
    return true;
  }
  const double r = fisheye_r(theta);
  *px = {config_.cx_px + config_.fx_px * r * p_C.x() / rho, config_.cy_px + config_.fy_px * r * p_C.y() / rho};
  return true;
}

bool Lens::unproject(const Eigen::Vector2d& px, Eigen::Vector3d* ray_C) const noexcept {
  const Eigen::Vector2d m((px.x() - config_.cx_px) / config_.fx_px, (px.y() - config_.cy_px) / config_.fy_px);
  if (!m.allFinite()) return false;
  if (config_.model == LensModel::kPinhole) {
    Eigen::Vector2d xy;
    if (!undistort(m, &xy)) return false;
    *ray_C = Eigen::Vector3d(xy.x(), xy.y(), 1.0).normalized();
    return true;
  }
  const double r = m.norm();
  if (r > max_r_norm_) return false;
  if (r <= 0.0) {
    *ray_C = Eigen::Vector3d::UnitZ();
    return true;
  }
  const double theta = fisheye_theta(r);
  const double s = std::sin(theta) / r;
  *ray_C = Eigen::Vector3d(s * m.x(), s * m.y(), std::cos(theta));
  return true;
}

}  // namespace doppel::camera
