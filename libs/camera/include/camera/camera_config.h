#pragma once
// What one simulated camera is: name, resolution, rate, pixel format, lens, noise and where it is
// mounted (on a body of a robot, moving with it, or fixed in the world). Setup values only; the
// gateway turns the mount into a camera pose X_WC each frame.

#include <Eigen/Geometry>

#include <string>

#include "camera/lens.h"
#include "camera/noise.h"
#include "camera/pixel_format.h"

namespace doppel::camera {

struct CameraMount {
  enum class Kind : uint8_t {
    kBody,   // linked viewpoint: X_WC = X_WB * X_BC, moves with the body (head servo)
    kWorld,  // free viewpoint: X_WC fixed (or moved by the gateway)
  };
  Kind kind = Kind::kBody;
  std::string body = "head";  // robot-description body name (kBody)
  Eigen::Isometry3d X_BC = Eigen::Isometry3d::Identity();  // camera in body frame (kBody)
  Eigen::Isometry3d X_WC = Eigen::Isometry3d::Identity();  // camera in world frame (kWorld)
};

// Which instant of the exposure the frame's exposure_time_ns names.
enum class ExposureStamp : uint8_t { kStart, kMiddle, kEnd };

struct CameraConfig {
  std::string name = "head";                    // unique per machine; 1..63 chars of [A-Za-z0-9_./-]
  int width_px = 640;                           // even (YUV422 pairs), 2..8192
  int height_px = 480;                          // 2..8192
  double fps = 20.0;                            // frames per second of simulation time, 0 < fps <= 1000
  PixelFormat format = PixelFormat::kYuyv;      // what the sensor delivers
  LensConfig lens;                              // intrinsics for width_px x height_px
  NoiseConfig noise;                            // initial filters (changeable while running)
  CameraMount mount;                            // linked or free viewpoint
  double exposure_s = 0.01;                     // exposure duration, s, >= 0
  ExposureStamp stamp = ExposureStamp::kMiddle;  // which instant the exposure time stamp names
  bool annotations = true;                      // attach ground truth to every frame
  int render_threads = 1;                       // renderer threads for this camera, 1..16
  int robot_file_order = 0;                     // place among its robot's cameras in the robot file
};

// Camera frame (x right, y down, z forward) looking along the body's x axis (body: x forward,
// y left, z up), placed at `offset_B` in the body frame.
Eigen::Isometry3d camera_looking_along_x(const Eigen::Vector3d& offset_B);

// The 2011 robot's head camera: 640x480 YUYV at 20 fps through an equidistant fisheye with a 120 deg
// horizontal field of view (about 150 deg across the diagonal), on body "head", 5 cm in front of and
// 3 cm above the head frame, looking forward.
CameraConfig default_head_camera();

// Throws std::invalid_argument with the camera's name and the offending field.
void validate(const CameraConfig& config);

// Camera pose in the world: the mount's X_WC (kWorld) or X_WB * X_BC (kBody). rt-safe.
Eigen::Isometry3d camera_pose_W(const CameraMount& mount, const Eigen::Isometry3d& X_WB) noexcept;

}  // namespace doppel::camera
