#pragma once
// Lens models: how a direction in the camera frame lands on a pixel and back. A pinhole with
// radial-tangential (Brown-Conrady, OpenCV order k1 k2 p1 p2 k3) distortion, and fisheye lenses
// (equidistant, equisolid, stereographic) whose field of view may reach, but not touch, 180 degrees.
// Not a renderer: the renderer asks a Lens for one ray per pixel once and keeps the table.
//
// Camera frame C (OpenCV): x right, y down, z forward along the optical axis.
// Pixel coordinates: u to the right, v down, the centre of pixel (i, j) is at (i, j).

#include <Eigen/Core>

#include <cstdint>
#include <string>
#include <string_view>

namespace doppel::camera {

enum class LensModel : uint32_t {
  kPinhole = 0,        // r = f tan(theta), then radial-tangential distortion
  kEquidistant = 1,    // r = f theta
  kEquisolid = 2,      // r = 2 f sin(theta / 2)
  kStereographic = 3,  // r = 2 f tan(theta / 2)
};

// Plain values so that it can travel in a frame header in shared memory.
struct LensConfig {
  LensModel model = LensModel::kPinhole;  // projection model
  double fx_px = 500.0;                   // focal length along u, pixels
  double fy_px = 500.0;                   // focal length along v, pixels
  double cx_px = 319.5;                   // principal point u, pixels
  double cy_px = 239.5;                   // principal point v, pixels
  double k1 = 0.0;                        // radial distortion (pinhole only)
  double k2 = 0.0;                        // radial distortion (pinhole only)
  double k3 = 0.0;                        // radial distortion (pinhole only)
  double p1 = 0.0;                        // tangential distortion (pinhole only)
  double p2 = 0.0;                        // tangential distortion (pinhole only)
  double fov_deg = 0.0;  // full field of view, degrees, < 180; directions beyond half of it do not
                         // project. 0 = the model's natural limit (pinhole: the image, fisheye: 179.9)
};

// Pinhole without distortion whose horizontal field of view is `hfov_deg` (0 < hfov < 180).
LensConfig pinhole_from_hfov(int width_px, int height_px, double hfov_deg);
// Fisheye of `model` whose horizontal field of view is `hfov_deg`; the image is filled (the
// diagonal sees more). Throws std::invalid_argument when the diagonal would reach 180 degrees.
LensConfig fisheye_from_hfov(LensModel model, int width_px, int height_px, double hfov_deg);

std::string_view to_string(LensModel model) noexcept;
// Parses "pinhole", "equidistant", "equisolid", "stereographic"; throws std::invalid_argument.
LensModel parse_lens_model(std::string_view name);

class Lens {
 public:
  // Throws std::invalid_argument on non-positive focal lengths, fov_deg outside [0, 180), or a
  // pinhole whose distortion is not monotonic over the image (it could not be inverted).
  Lens(const LensConfig& config, int width_px, int height_px);

  // Projects the point or direction p_C (camera frame, any length > 0) to pixel coordinates.
  // Returns false for points behind the lens's field of view (then `px` is untouched); the pixel
  // may still lie outside the image. rt-safe.
  bool project(const Eigen::Vector3d& p_C, Eigen::Vector2d* px) const noexcept;

  // Unit direction in the camera frame that projects to `px`. Returns false where no direction
  // maps (outside the fisheye's image circle or the pinhole's invertible range). rt-safe.
  bool unproject(const Eigen::Vector2d& px, Eigen::Vector3d* ray_C) const noexcept;

  // Largest angle from the optical axis that projects, radians (< pi/2 for a pinhole, < pi).
  double max_theta_rad() const noexcept { return max_theta_rad_; }
  const LensConfig& config() const noexcept { return config_; }
  int width_px() const noexcept { return width_px_; }
  int height_px() const noexcept { return height_px_; }

 private:
  // Distortion of the normalised pinhole coordinates (x, y) -> (xd, yd).
  Eigen::Vector2d distort(const Eigen::Vector2d& xy) const noexcept;
  bool undistort(const Eigen::Vector2d& xyd, Eigen::Vector2d* xy) const noexcept;
  // Fisheye radius per unit focal length for angle theta, and its inverse.
  double fisheye_r(double theta) const noexcept;
  double fisheye_theta(double r) const noexcept;

  LensConfig config_;
  int width_px_;
  int height_px_;
  double max_theta_rad_ = 0.0;
  double max_r_norm_ = 0.0;  // largest undistorted radius (pinhole) over which distortion is invertible
};

}  // namespace doppel::camera
