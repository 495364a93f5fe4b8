#include "camera/camera_config.h"

#include <stdexcept>
#include <string>

namespace doppel::camera {

Eigen::Isometry3d camera_looking_along_x(const Eigen::Vector3d& offset_B) {
  Eigen::Matrix3d R_BC;
  // Columns: camera x (right) = -y_B, camera y (down) = -z_B, camera z (forward) = x_B.
  R_BC << 0.0, 0.0, 1.0,  //
      -1.0, 0.0, 0.0,     //
      0.0, -1.0, 0.0;
  Eigen::Isometry3d X_BC = Eigen::Isometry3d::Identity();
  X_BC.linear() = R_BC;
  X_BC.translation() = offset_B;
  return X_BC;
}

CameraConfig default_head_camera() {
  CameraConfig c;
  c.name = "head";
  c.width_px = 640;
  c.height_px = 480;
  c.fps = 20.0;
  c.format = PixelFormat::kYuyv;
  c.lens = fisheye_from_hfov(LensModel::kEquidistant, c.width_px, c.height_px, 120.0);
  c.mount.kind = CameraMount::Kind::kBody;
  c.mount.body = "head";
  c.mount.X_BC = camera_looking_along_x({0.05, 0.0, 0.03});
  return c;
}

void validate(const CameraConfig& c) {
  auto fail = [&c](const std::string& what) {
    throw std::invalid_argument("camera '" + c.name + "': " + what);
  };
  if (c.name.empty() || c.name.size() > 63) fail("name must have 1..63 characters");
  for (char ch : c.name) {
    const bool ok = (ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') || (ch >= '0' && ch <= '9') || ch == '_' ||
                    ch == '.' || ch == '/' || ch == '-';
    if (!ok) fail("name may hold only letters, digits and _ . / -");
  }
  if (c.width_px < 2 || c.width_px > 8192 || c.height_px < 2 || c.height_px > 8192) {
    fail("resolution must lie within 2..8192 pixels, got " + std::to_string(c.width_px) + "x" +
         std::to_string(c.height_px));
  }
  if (is_yuv422(c.format) && (c.width_px % 2) != 0) fail("YUV422 needs an even width");
  if (!(c.fps > 0.0 && c.fps <= 1000.0)) fail("fps must lie in (0, 1000], got " + std::to_string(c.fps));
  if (!(c.exposure_s >= 0.0 && c.exposure_s <= 1.0)) fail("exposure_s must lie in [0, 1]");
  if (c.render_threads < 1 || c.render_threads > 16) fail("render_threads must lie in 1..16");
  if (c.mount.kind == CameraMount::Kind::kBody && c.mount.body.empty()) fail("a body mount needs a body name");
  try {
    Lens lens(c.lens, c.width_px, c.height_px);
    validate(c.noise);
  } catch (const std::invalid_argument& e) {
    fail(e.what());
  }
}

Eigen::Isometry3d camera_pose_W(const CameraMount& mount, const Eigen::Isometry3d& X_WB) noexcept {
  return mount.kind == CameraMount::Kind::kBody ? Eigen::Isometry3d(X_WB * mount.X_BC) : mount.X_WC;
}

}  // namespace doppel::camera
