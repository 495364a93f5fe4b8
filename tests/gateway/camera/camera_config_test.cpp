// Camera settings in robot files (noise per CameraMount) and session files (cameras fixed in the
// field), with file:line:column errors. No RouDi: runs with the gateway unit tests.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

#include "camera/lens.h"
#include "gateway/robot_config.h"

namespace doppel::gateway {
namespace {

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

std::string default_robot_with_camera(const std::string& camera) {
  std::string robot = read_text(std::string(DOPPEL_ROBOTS_DIR) + "/fumanoid-2011.textproto");
  const std::string head_camera = R"(camera { name: "HEAD_CAMERA" body: "head" mount { position_m { x: 0.03 } } })";
  std::size_t at = robot.find(head_camera);
  EXPECT_NE(at, std::string::npos) << "the default robot's camera line changed";
  return robot.replace(at, head_camera.size(), camera);
}

// "line:column" (1-based) of the first `needle` in `text`: where an error about it must point.
std::string position_of(const std::string& text, const std::string& needle) {
  const std::size_t at = text.find(needle);
  EXPECT_NE(at, std::string::npos) << needle;
  const std::size_t line_start = text.rfind('\n', at);
  const std::size_t line = 1 + static_cast<std::size_t>(std::count(text.begin(), text.begin() + at, '\n'));
  const std::size_t column = at - (line_start == std::string::npos ? 0 : line_start + 1) + 1;
  return std::to_string(line) + ":" + std::to_string(column);
}

template <typename Parse>
std::string error_of(Parse parse) {
  try {
    parse();
  } catch (const std::invalid_argument& e) {
    return e.what();
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "no error";
}

TEST(CameraNoiseConfig, UnsetNoiseIsOff) {
  RobotConfig sut = load_robot("fumanoid-2011", DOPPEL_ROBOTS_DIR);

  ASSERT_EQ(sut.cameras.size(), 1u);
  EXPECT_FALSE(sut.cameras[0].config.noise.active());
}

TEST(CameraNoiseConfig, EveryFilterComesFromTheRobotFile) {
  RobotConfig sut = parse_robot(default_robot_with_camera(R"(camera { name: "EYE" body: "head"
      noise { gaussian_sigma: 2.5 shot_noise_gain: 0.4 salt_pepper_fraction: 0.001 vignetting: 0.3
              wb_red_gain: 1.2 wb_blue_gain: 0.9 seed: 77 } })"),
                                "robots/noisy.textproto");

  ASSERT_EQ(sut.cameras.size(), 1u);
  const camera::NoiseConfig& noise = sut.cameras[0].config.noise;
  EXPECT_DOUBLE_EQ(noise.gaussian_sigma, 2.5);
  EXPECT_DOUBLE_EQ(noise.shot_noise_gain, 0.4);
  EXPECT_DOUBLE_EQ(noise.salt_pepper_fraction, 0.001);
  EXPECT_DOUBLE_EQ(noise.vignetting, 0.3);
  EXPECT_DOUBLE_EQ(noise.wb_red_gain, 1.2);
  EXPECT_DOUBLE_EQ(noise.wb_green_gain, 1.0);  // unset gain: neutral
  EXPECT_DOUBLE_EQ(noise.wb_blue_gain, 0.9);
  EXPECT_EQ(noise.seed, 77u);
  EXPECT_TRUE(noise.active());
}

TEST(CameraNoiseConfig, OutOfRangeValuesNameFileLineColumnAndField) {
  const std::string fraction_text = default_robot_with_camera(
      R"(camera { name: "EYE" body: "head" noise { salt_pepper_fraction: 1.5 } })");
  const std::string zero_gain_text =
      default_robot_with_camera(R"(camera { name: "EYE" body: "head" noise { wb_green_gain: 0 } })");
  const std::string negative_text =
      default_robot_with_camera(R"(camera { name: "EYE" body: "head" noise { gaussian_sigma: -1 } })");

  const std::string fraction = error_of([&] { parse_robot(fraction_text, "robots/noisy.textproto"); });
  const std::string zero_gain = error_of([&] { parse_robot(zero_gain_text, "robots/noisy.textproto"); });
  const std::string negative = error_of([&] { parse_robot(negative_text, "robots/noisy.textproto"); });

  EXPECT_EQ(fraction.rfind("robots/noisy.textproto:" + position_of(fraction_text, "salt_pepper_fraction") +
                               ": CameraNoise.salt_pepper_fraction: must lie in [0, 1], got 1.5",
                           0),
            0u)
      << fraction;
  EXPECT_EQ(zero_gain.rfind("robots/noisy.textproto:" + position_of(zero_gain_text, "wb_green_gain") +
                                ": CameraNoise.wb_green_gain:",
                            0),
            0u)
      << zero_gain;
  EXPECT_EQ(negative.rfind("robots/noisy.textproto:" + position_of(negative_text, "gaussian_sigma") +
                               ": CameraNoise.gaussian_sigma: must lie in [0, 255], got -1",
                           0),
            0u)
      << negative;
}

const char* kSession = R"(# two cameras
camera {
  name: "TV"
  pose { position_m { x: 0 y: -3 z: 2.5 } rpy_deg { y: 39.8 z: 90 } }
  width_px: 320 height_px: 180 fps: 10 format: "rgb24" lens: "pinhole" hfov_deg: 90
  noise { gaussian_sigma: 1 }
}
camera {
  name: "GOAL"
  pose { position_m { x: -3.5 z: 1.2 } }
}
)";

TEST(SessionConfig, WorldCamerasTakeTheirSettingsAndPoseFromTheFile) {
  SessionConfig sut = parse_session(kSession, "sessions/two.textproto");

  ASSERT_EQ(sut.world_cameras.size(), 2u);
  const camera::CameraConfig& tv = sut.world_cameras[0].config;
  EXPECT_EQ(tv.name, "TV");
  EXPECT_EQ(tv.mount.kind, camera::CameraMount::Kind::kWorld);
  EXPECT_EQ(tv.width_px, 320);
  EXPECT_EQ(tv.height_px, 180);
  EXPECT_DOUBLE_EQ(tv.fps, 10.0);
  EXPECT_EQ(tv.format, camera::PixelFormat::kRgb24);
  EXPECT_EQ(tv.lens.model, camera::LensModel::kPinhole);
  EXPECT_NEAR(tv.lens.fx_px, 160.0, 1e-6);  // 90 degrees across 320 px
  EXPECT_DOUBLE_EQ(tv.noise.gaussian_sigma, 1.0);
  EXPECT_TRUE(tv.mount.X_WC.translation().isApprox(Eigen::Vector3d(0, -3, 2.5)));
  // Optical axis (camera z): yaw 90 turns it to +y, pitch 39.8 degrees tilts it down.
  const double pitch = 39.8 * std::numbers::pi / 180.0;
  EXPECT_TRUE(tv.mount.X_WC.linear().col(2).isApprox(Eigen::Vector3d(0, std::cos(pitch), -std::sin(pitch)), 1e-9))
      << tv.mount.X_WC.linear();
  // Image x (camera x) runs to the viewer's right: towards +x of the field seen from y < 0.
  EXPECT_TRUE(tv.mount.X_WC.linear().col(0).isApprox(Eigen::Vector3d(1, 0, 0), 1e-9)) << tv.mount.X_WC.linear();
  const camera::CameraConfig& goal = sut.world_cameras[1].config;
  EXPECT_EQ(goal.width_px, 640);  // unset: the default camera
  EXPECT_DOUBLE_EQ(goal.fps, 20.0);
  EXPECT_FALSE(goal.noise.active());
  EXPECT_TRUE(goal.mount.X_WC.linear().col(2).isApprox(Eigen::Vector3d(1, 0, 0), 1e-12));
  EXPECT_EQ(sut.world_cameras[1].location, "sessions/two.textproto:8:1");
}

TEST(SessionConfig, TheShippedSidelineCameraLooksAtTheCentreSpot) {
  SessionConfig sut = load_session(std::string(DOPPEL_SESSIONS_DIR) + "/sideline-camera.textproto");

  ASSERT_EQ(sut.world_cameras.size(), 1u);
  const camera::CameraConfig& tv = sut.world_cameras[0].config;
  EXPECT_EQ(tv.name, "SIDELINE");
  camera::Lens lens(tv.lens, tv.width_px, tv.height_px);
  Eigen::Vector2d px;
  ASSERT_TRUE(lens.project(tv.mount.X_WC.inverse() * Eigen::Vector3d(0, 0, 0), &px));
  // Aimed at atan(2.5 / 3) = 39.81 degrees: the centre spot lies within a few pixels of the image centre.
  EXPECT_NEAR(px.x(), 0.5 * (tv.width_px - 1), 1.0);
  EXPECT_NEAR(px.y(), 0.5 * (tv.height_px - 1), 3.0);
}

TEST(SessionConfig, BadCamerasNameFileLineAndField) {
  auto error_for = [](const std::string& text) {
    return error_of([&] { parse_session(text, "sessions/bad.textproto"); });
  };

  EXPECT_EQ(error_for("camera { pose { } }").rfind("sessions/bad.textproto:1:1: WorldCamera.name: missing", 0), 0u)
      << error_for("camera { pose { } }");
  const std::string twice = "camera { name: \"A\" pose { } }\ncamera { name: \"A\" pose { } }";
  EXPECT_EQ(error_for(twice).rfind("sessions/bad.textproto:2:10: WorldCamera.name: camera 'A' is named twice", 0), 0u)
      << error_for(twice);
  EXPECT_EQ(error_for("camera { name: \"A\" }").rfind("sessions/bad.textproto:1:1: WorldCamera.pose: missing", 0), 0u)
      << error_for("camera { name: \"A\" }");
  const std::string nan_pose = "camera { name: \"A\"\n  pose { position_m { x: nan } } }";
  EXPECT_EQ(error_for(nan_pose).rfind("sessions/bad.textproto:2:10: Pose.position_m: must be finite", 0), 0u)
      << error_for(nan_pose);
  const std::string lens = "camera { name: \"A\" pose { }\n lens: \"fisheye\" }";
  EXPECT_EQ(error_for(lens).rfind("sessions/bad.textproto:2:2: WorldCamera.lens:", 0), 0u) << error_for(lens);
  const std::string noise = "camera { name: \"A\" pose { }\n noise { vignetting: 2 } }";
  EXPECT_EQ(error_for(noise).rfind("sessions/bad.textproto:2:10: CameraNoise.vignetting: must lie in [0, 1], got 2", 0),
            0u)
      << error_for(noise);
  const std::string name = "camera { name: \"a b\" pose { } }";
  EXPECT_EQ(error_for(name).rfind("sessions/bad.textproto:1:10: WorldCamera.name:", 0), 0u) << error_for(name);
  const std::string syntax = "camera {\n name: \"A\"\n posture { } }";
  EXPECT_EQ(error_for(syntax).rfind("sessions/bad.textproto:3:", 0), 0u) << error_for(syntax);
  EXPECT_THROW(load_session("/nonexistent/session.textproto"), std::runtime_error);
}

}  // namespace
}  // namespace doppel::gateway
