// A camera fixed in the field from a session file streams from doppel, sees the field where a
// pinhole of its pose says, and its noise changes while doppel runs (doppel-camera noise), taking
// effect from the frame the tool reports. Drives doppel and doppel-camera as a user would; doppel
// starts RouDi, so this executable holds the `roudi` lock.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <filesystem>
#include <numbers>
#include <string>
#include <vector>

#include "camera/image_io.h"
#include "doppel_process.h"

namespace doppel::testing {
namespace {

std::string tool(const std::string& args) { return std::string(DOPPEL_CAMERA_TOOL) + " " + args; }

// "... from frame N" in the tool's confirmation.
long from_frame(const std::string& output) {
  const std::size_t at = output.find("from frame ");
  return at == std::string::npos ? -1 : std::stol(output.substr(at + 11));
}

struct Saved {
  long sequence = -1;
  std::string rgb;
  int width_px = 0;
  int height_px = 0;
};

// Saves the next frame of `camera` into `dir` (fresh) and reads it back.
Saved save_one(const std::string& camera, const std::string& dir) {
  std::filesystem::remove_all(dir);
  auto [code, output] = run_command(tool("save --camera " + camera + " --count 1 --out " + dir));
  EXPECT_EQ(code, 0) << output;
  Saved saved;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (entry.path().extension() == ".png") {
      const std::string stem = entry.path().stem().string();  // CAMERA_00000123
      saved.sequence = std::stol(stem.substr(stem.rfind('_') + 1));
      camera::read_png_rgb(entry.path().string(), &saved.rgb, &saved.width_px, &saved.height_px);
    }
  }
  return saved;
}

// The session's camera: at (0, -3, 2.5) m looking along +y, tilted down by 39.8 degrees; image x
// runs along the field's +x. Pinhole of 90 degrees across 960 px: f = 480 px, centre (479.5, 269.5).
Eigen::Vector2d sideline_pixel(const Eigen::Vector3d& p_W) {
  const double pitch = 39.8 * std::numbers::pi / 180.0;
  const Eigen::Vector3d z_C(0.0, std::cos(pitch), -std::sin(pitch));
  const Eigen::Vector3d x_C(1.0, 0.0, 0.0);
  const Eigen::Vector3d y_C = z_C.cross(x_C);
  const Eigen::Vector3d d = p_W - Eigen::Vector3d(0.0, -3.0, 2.5);
  return {479.5 + 480.0 * d.dot(x_C) / d.dot(z_C), 269.5 + 480.0 * d.dot(y_C) / d.dot(z_C)};
}

struct Rgb {
  int r, g, b;
};

Rgb pixel(const Saved& frame, const Eigen::Vector2d& px) {
  const long x = std::lround(px.x());
  const long y = std::lround(px.y());
  const std::size_t i = 3 * static_cast<std::size_t>(y * frame.width_px + x);
  return {static_cast<uint8_t>(frame.rgb[i]), static_cast<uint8_t>(frame.rgb[i + 1]),
          static_cast<uint8_t>(frame.rgb[i + 2])};
}

TEST(WorldCamera, SidelineCameraSeesTheFieldAndItsNoiseChangesWhileRunning) {
  DoppelProcess doppel({"--timing", "fast", "--physics", "none", "--session",
                        std::string(DOPPEL_SESSIONS_DIR) + "/sideline-camera.textproto"},
                       "ttyDXL0", /*camera=*/true);
  const std::string started = doppel.wait_for_output("running until");
  EXPECT_NE(started.find("camera 'SIDELINE' fixed in the field at (0, -3, 2.5) m"), std::string::npos) << started;
  auto [list_code, list] = run_command(tool("list"));
  ASSERT_EQ(list_code, 0) << list;
  EXPECT_NE(list.find("SIDELINE"), std::string::npos) << list;
  EXPECT_NE(list.find("(world)"), std::string::npos) << list;
  EXPECT_NE(list.find("gaussian 1.5, seed 11"), std::string::npos) << list;  // from the session file

  // Noise off: consecutive frames of the still field are identical.
  auto [off_code, off] = run_command(tool("noise --camera SIDELINE --off"));
  ASSERT_EQ(off_code, 0) << off;
  const long off_from = from_frame(off);
  const Saved clean = save_one("SIDELINE", doppel.link_dir() + "/clean");
  const Saved clean_again = save_one("SIDELINE", doppel.link_dir() + "/clean_again");
  ASSERT_EQ(clean.width_px, 960);
  ASSERT_EQ(clean.height_px, 540);
  EXPECT_GE(clean.sequence, off_from);
  EXPECT_GT(clean_again.sequence, clean.sequence);
  EXPECT_TRUE(clean.rgb == clean_again.rgb);

  // The field where the lens puts it: the ball on the centre spot is orange, the centre circle's
  // line white, the carpet inside it green.
  const Rgb ball = pixel(clean, sideline_pixel({0.0, 0.0, 0.0335}));
  EXPECT_GT(ball.r, 200);
  EXPECT_LT(ball.b, 80);
  EXPECT_GT(ball.r - ball.g, 60);
  // Centre circle of 1.2 m diameter (Rules 2011, H), drawn with its 5 cm line centred on the 0.6 m radius.
  for (double angle_deg : {45.0, 135.0, 225.0, 315.0}) {
    const double a = angle_deg * std::numbers::pi / 180.0;
    const Rgb line = pixel(clean, sideline_pixel({0.6 * std::cos(a), 0.6 * std::sin(a), 0.002}));
    EXPECT_GT(std::min({line.r, line.g, line.b}), 200) << angle_deg;
  }
  const Rgb carpet = pixel(clean, sideline_pixel({0.3, 0.15, 0.0}));
  EXPECT_GT(carpet.g, carpet.r + 50);
  EXPECT_GT(carpet.g, carpet.b + 50);

  // Noise on while running: frames from the reported one on differ from the clean frame.
  auto [on_code, on] = run_command(tool("noise --camera SIDELINE --gaussian 8 --salt-pepper 0.01"));
  ASSERT_EQ(on_code, 0) << on;
  const long on_from = from_frame(on);
  EXPECT_GT(on_from, clean_again.sequence) << on;
  EXPECT_NE(on.find("gaussian 8, salt-pepper 0.01"), std::string::npos) << on;
  const Saved noisy = save_one("SIDELINE", doppel.link_dir() + "/noisy");
  EXPECT_GE(noisy.sequence, on_from);
  ASSERT_EQ(noisy.rgb.size(), clean.rgb.size());
  std::size_t differing = 0;
  for (std::size_t i = 0; i < clean.rgb.size(); ++i) differing += clean.rgb[i] != noisy.rgb[i] ? 1 : 0;
  EXPECT_GT(differing, clean.rgb.size() / 2);  // sigma 8 changes most values
  auto [list_on_code, list_on] = run_command(tool("list"));
  EXPECT_NE(list_on.find("gaussian 8, salt-pepper 0.01"), std::string::npos) << list_on;

  // Off again: the clean frame comes back byte for byte.
  auto [off_again_code, off_again] = run_command(tool("noise --camera SIDELINE --off"));
  ASSERT_EQ(off_again_code, 0) << off_again;
  const Saved clean_later = save_one("SIDELINE", doppel.link_dir() + "/clean_later");
  EXPECT_GE(clean_later.sequence, from_frame(off_again));
  EXPECT_TRUE(clean_later.rgb == clean.rgb);

  // Bad values never reach doppel: a usage error naming the option and its range.
  auto [bad_code, bad] = run_command(tool("noise --camera SIDELINE --salt-pepper 2"));
  EXPECT_EQ(bad_code, 2) << bad;
  EXPECT_NE(bad.find("--salt-pepper 2: NoiseConfig.salt_pepper_fraction must lie in [0, 1], got 2"),
            std::string::npos)
      << bad;
  auto [unknown_code, unknown] = run_command(tool("noise --camera NO_SUCH_CAMERA --gaussian 1"));
  EXPECT_EQ(unknown_code, 1) << unknown;
  EXPECT_NE(unknown.find("no camera 'NO_SUCH_CAMERA'"), std::string::npos) << unknown;
}

TEST(WorldCamera, StreamsBesideTheRobotsHeadCamera) {
  DoppelProcess doppel({"--timing", "fast", "--session", std::string(DOPPEL_SESSIONS_DIR) + "/sideline-camera.textproto"},
                       "ttyDXL0", /*camera=*/true);
  doppel.wait_for_output("running until");  // every camera is offered
  auto [list_code, list] = run_command(tool("list"));

  ASSERT_EQ(list_code, 0) << list;
  EXPECT_NE(list.find("HEAD_CAMERA"), std::string::npos) << list;
  EXPECT_NE(list.find("SIDELINE"), std::string::npos) << list;
  auto [noise_code, noise] = run_command(tool("noise --camera HEAD_CAMERA --vignetting 0.4"));
  EXPECT_EQ(noise_code, 0) << noise;
  EXPECT_NE(noise.find("vignetting 0.4"), std::string::npos) << noise;
}

TEST(WorldCamera, BadSessionFileStopsDoppelWithFileAndLine) {
  const std::string session = ::testing::TempDir() + "bad_session.textproto";
  {
    FILE* file = std::fopen(session.c_str(), "w");
    std::fputs("camera {\n  name: \"TV\"\n  pose { }\n  noise { salt_pepper_fraction: 3 }\n}\n", file);
    std::fclose(file);
  }
  auto [code, output] = run_command(doppel_executable() + " --no-camera --link-dir " + ::testing::TempDir() +
                            "bad_session_links --session " + session);

  EXPECT_NE(code, 0) << output;
  EXPECT_NE(output.find(session + ":4:11: CameraNoise.salt_pepper_fraction: must lie in [0, 1], got 3"),
            std::string::npos)
      << output;
  std::filesystem::remove(session);
}

}  // namespace
}  // namespace doppel::testing
