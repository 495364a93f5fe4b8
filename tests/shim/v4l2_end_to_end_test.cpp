// End-to-end: the real doppel (DARwIn-OP robot: HEAD_CAMERA 320x240 YUYV at 30 fps; the sideline
// session camera SIDELINE 960x540) and real V4L2 clients from Debian under doppel-run: v4l2-ctl and
// v4l2-compliance (v4l-utils) and OpenCV's cv2.VideoCapture (python3-opencv). Expected values come
// from the V4L2 spec (YUYV: 2 bytes per pixel) and from a pinhole of the sideline camera's pose.
// doppel starts RouDi, so the executable holds the `roudi` lock.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <regex>
#include <string>
#include <vector>

#include "doppel_process.h"

namespace doppel::testing {
namespace {

class V4l2Device : public ::testing::Test {
 protected:
  V4l2Device()
      : doppel_({"--robot", "darwin-op", "--timing", "fast", "--viewer", "0", "--session",
                 std::string(DOPPEL_SESSIONS_DIR) + "/sideline-camera.textproto"},
                "ttyDXL0", /*camera=*/true) {
    const std::string output = doppel_.wait_for_output("simulation control on http://127.0.0.1:");
    std::smatch match;
    if (std::regex_search(output, match, std::regex(R"(simulation control on http://127\.0\.0\.1:(\d+))"))) {
      url_ = "http://127.0.0.1:" + match[1].str();
    }
    doppel_.wait_for_output("running until");
  }

  std::pair<int, std::string> run(const std::string& options, const std::string& program) {
    return run_command(std::string(DOPPEL_RUN) + " --link-dir " + doppel_.link_dir() + " " + options + " -- " + program);
  }
  std::pair<int, std::string> ctl(const std::string& arguments) {
    return run_command(std::string(DOPPEL_CTL) + " --url " + url_ + " --link-dir " + doppel_.link_dir() + " " + arguments);
  }
  std::string file(const std::string& name) const { return doppel_.link_dir() + "/" + name; }

  DoppelProcess doppel_;
  std::string url_;
};

std::vector<uint8_t> read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<uint8_t>(std::istreambuf_iterator<char>(in), {});
}

TEST_F(V4l2Device, V4l2CtlSeesDoppelsDriverAndTheCamerasFormat) {
  const auto [code, output] = run("", "v4l2-ctl -d /dev/video0 --all");
  ASSERT_EQ(code, 0) << output;
  EXPECT_NE(output.find("Driver name      : doppel"), std::string::npos) << output;
  EXPECT_NE(output.find("Card type        : HEAD_CAMERA"), std::string::npos) << output;
  EXPECT_NE(output.find("Width/Height      : 320/240"), std::string::npos) << output;
  EXPECT_NE(output.find("'YUYV'"), std::string::npos) << output;
  EXPECT_NE(output.find("brightness"), std::string::npos) << output;
  EXPECT_NE(output.find("Frames per second: 30.000 (30/1)"), std::string::npos) << output;  // G_PARM: 1/30 s
}

TEST_F(V4l2Device, V4l2CtlStreamsWholeFramesThroughMmap) {
  const std::string out = file("frames.yuyv");
  const auto [code, output] = run("", "v4l2-ctl -d /dev/video0 --stream-mmap --stream-count=30 --stream-to=" + out);
  ASSERT_EQ(code, 0) << output;
  EXPECT_EQ(std::filesystem::file_size(out), 30u * 320u * 240u * 2u) << output;
}

TEST_F(V4l2Device, ControlsChangeThePixels) {
  // Saturation 0: every chroma byte (odd bytes of YUYV) is neutral, 128.
  const std::string grey = file("grey.yuyv");
  auto [code, output] = run("", "v4l2-ctl -d /dev/video0 -c saturation=0 --stream-mmap --stream-count=3 --stream-to=" + grey);
  ASSERT_EQ(code, 0) << output;
  const std::vector<uint8_t> g = read_bytes(grey);
  ASSERT_EQ(g.size(), 3u * 153600u);
  std::size_t neutral = 0;
  for (std::size_t i = 1; i < g.size(); i += 2) neutral += g[i] == 128 ? 1 : 0;
  EXPECT_EQ(neutral, g.size() / 2);
  // Manual exposure of twice the default (334 x 100 us at 30 fps): no pixel darker, most brighter.
  const std::string normal = file("normal.yuyv");
  const std::string bright = file("bright.yuyv");
  std::tie(code, output) = run("", "v4l2-ctl -d /dev/video0 --stream-mmap --stream-count=1 --stream-to=" + normal);
  ASSERT_EQ(code, 0) << output;
  std::tie(code, output) = run("", "v4l2-ctl -d /dev/video0 -c auto_exposure=1,exposure_time_absolute=334 "
                                   "--stream-mmap --stream-count=1 --stream-to=" + bright);
  ASSERT_EQ(code, 0) << output;
  const std::vector<uint8_t> n = read_bytes(normal);
  const std::vector<uint8_t> b = read_bytes(bright);
  ASSERT_EQ(n.size(), b.size());
  double mean_n = 0, mean_b = 0;
  for (std::size_t i = 0; i < n.size(); i += 2) {
    mean_n += n[i];
    mean_b += b[i];
  }
  EXPECT_GT(mean_b, mean_n * 1.3) << "mean luma " << mean_n / (n.size() / 2) << " -> " << mean_b / (n.size() / 2);
}

// v4l2-compliance with streaming (-s: MMAP and USERPTR with poll, select and epoll, read()): every
// test passes, control events (select's exception set) included.
TEST_F(V4l2Device, CompliancePassesEveryTest) {
  const auto [code, output] = run("", "v4l2-compliance -d /dev/video0 -s10");
  std::smatch match;
  ASSERT_TRUE(std::regex_search(output, match, std::regex(R"(Total for doppel device /dev/video0: (\d+), Succeeded: (\d+), Failed: (\d+))")))
      << output;
  EXPECT_EQ(match[3].str(), "0") << output;
  EXPECT_EQ(match[1].str(), match[2].str()) << output;
  EXPECT_EQ(code, 0) << output;
  EXPECT_NE(output.find("test VIDIOC_(UN)SUBSCRIBE_EVENT/DQEVENT: OK"), std::string::npos) << output;
  EXPECT_NE(output.find("test MMAP (epoll): OK"), std::string::npos) << output;
  EXPECT_NE(output.find("test USERPTR (select): OK"), std::string::npos) << output;
  EXPECT_NE(output.find("test read/write: OK"), std::string::npos) << output;
}

// Control events by the V4L2 spec (v4l2_events.c): the initial event, another descriptor's changes,
// merging, feedback, flags of inactive controls, order, poll/select/pselect, unsubscribing, blocking
// DQEVENT and poll, and EINVAL for what the device does not raise.
TEST_F(V4l2Device, ControlEventsReachEveryWatcher) {
  const auto [code, output] = run("", std::string(V4L2_EVENTS) + " /dev/video0");
  EXPECT_EQ(code, 0) << output;
  EXPECT_NE(output.find("\n0 failed\n"), std::string::npos) << output;
  EXPECT_EQ(output.find("FAIL"), std::string::npos) << output;
}

// The session's sideline camera: at (0, -3, 2.5) m looking along +y, tilted down 39.8 degrees;
// pinhole of 90 degrees across 960 px: f = 480 px, centre (479.5, 269.5).
Eigen::Vector2d sideline_pixel(const Eigen::Vector3d& p_W) {
  const double pitch = 39.8 * std::numbers::pi / 180.0;
  const Eigen::Vector3d z_C(0.0, std::cos(pitch), -std::sin(pitch));
  const Eigen::Vector3d x_C(1.0, 0.0, 0.0);
  const Eigen::Vector3d y_C = z_C.cross(x_C);
  const Eigen::Vector3d d = p_W - Eigen::Vector3d(0.0, -3.0, 2.5);
  return {479.5 + 480.0 * d.dot(x_C) / d.dot(z_C), 269.5 + 480.0 * d.dot(y_C) / d.dot(z_C)};
}

TEST_F(V4l2Device, OpenCvSeesTheBallWhereDoppelPutsIt) {
  constexpr double kBallRadius = 0.0335;  // physics/field.h: the 6.7 cm tennis ball
  for (const Eigen::Vector2d& ball : {Eigen::Vector2d(1.0, 1.0), Eigen::Vector2d(-1.5, -0.5)}) {
    const auto [ctl_code, ctl_output] = ctl("ball " + std::to_string(ball.x()) + " " + std::to_string(ball.y()));
    ASSERT_EQ(ctl_code, 0) << ctl_output;
    const auto [code, output] = run("--camera /dev/video0=SIDELINE", std::string("/usr/bin/python3 ") + OPENCV_BALL + " 0 960 540 10");
    ASSERT_EQ(code, 0) << output;
    EXPECT_NE(output.find("size 960 540"), std::string::npos) << output;
    std::smatch match;
    ASSERT_TRUE(std::regex_search(output, match, std::regex(R"(ball ([0-9.]+) ([0-9.]+) (\d+))"))) << output;
    const Eigen::Vector2d seen(std::stod(match[1].str()), std::stod(match[2].str()));
    const Eigen::Vector2d expected = sideline_pixel({ball.x(), ball.y(), kBallRadius});
    EXPECT_LT((seen - expected).norm(), 3.0) << "seen " << seen.transpose() << ", pinhole " << expected.transpose();
    EXPECT_GT(std::stoi(match[3].str()), 20) << output;
  }
}

// The DARwIn-OP's head camera is mounted upside down: ROBOTIS' own driver (LinuxCamera::CaptureFrame)
// flips every frame horizontally and vertically before its vision looks. So in the frames the
// device gives, a ball that moves to the robot's left moves right. The robot stands at (-1.0, -0.8)
// facing +x (its start pose); the ball 60 cm ahead on its centre line, then 15 cm to its left.
TEST_F(V4l2Device, TheDarwinOpHeadCameraIsMountedUpsideDownAsOnTheRobot) {
  std::vector<double> u;
  for (const double y : {-0.8, -0.65}) {
    const auto [ctl_code, ctl_output] = ctl("ball -0.4 " + std::to_string(y));
    ASSERT_EQ(ctl_code, 0) << ctl_output;
    const auto [code, output] = run("", std::string("/usr/bin/python3 ") + OPENCV_BALL + " 0 320 240 10");
    ASSERT_EQ(code, 0) << output;
    std::smatch match;
    ASSERT_TRUE(std::regex_search(output, match, std::regex(R"(ball ([0-9.]+) ([0-9.]+) (\d+))"))) << output;
    u.push_back(std::stod(match[1].str()));
  }
  EXPECT_NEAR(u[0], 159.5, 8.0) << "the camera sits on the head's centre line";
  EXPECT_GT(u[1], u[0] + 20.0) << "ahead at u = " << u[0] << ", 15 cm to the left at u = " << u[1];
}

TEST_F(V4l2Device, AMissingCameraIsAMissingDevice) {
  const auto [code, output] = run("", "/usr/bin/python3 -c \"import os\ntry:\n  os.open('/dev/video3', os.O_RDWR)\nexcept OSError as e:\n  print('errno', e.errno)\"");
  EXPECT_EQ(code, 0) << output;
  EXPECT_NE(output.find("errno 2"), std::string::npos) << output;
  EXPECT_NE(output.find("doppel publishes no camera #3"), std::string::npos) << output;
}

// /dev/video<n> is the n-th camera of the robot file, not of the alphabet: the darwin-op with a
// second camera written after HEAD_CAMERA whose name sorts first.
TEST(V4l2DoppelRun, DevicesFollowTheRobotFilesCameraOrder) {
  std::ifstream shipped(std::string(DOPPEL_ROBOTS_DIR) + "/darwin-op.textproto");
  std::string robot((std::istreambuf_iterator<char>(shipped)), {});
  const std::string head = "hfov_deg: 58 }";
  const std::size_t at = robot.find(head);
  ASSERT_NE(at, std::string::npos);
  robot.insert(at + head.size(), "\n  camera { name: \"A_CHEST\" body: \"trunk\" width_px: 320 height_px: 240 fps: 30 "
                                 "format: \"yuyv\" lens: \"pinhole\" hfov_deg: 58 }");
  const std::string path = std::filesystem::temp_directory_path() / ("two-cameras-" + std::to_string(::getpid()) + ".textproto");
  std::ofstream(path) << robot;
  DoppelProcess doppel({"--robot", path, "--timing", "fast", "--no-viewer"}, "ttyDXL0", /*camera=*/true);
  doppel.wait_for_output("running until");
  for (const auto& [device, card] : {std::pair{"/dev/video0", "HEAD_CAMERA"}, std::pair{"/dev/video1", "A_CHEST"}}) {
    const auto [code, output] = run_command(std::string(DOPPEL_RUN) + " --link-dir " + doppel.link_dir() +
                                            " -- v4l2-ctl -d " + device + " --info");
    EXPECT_EQ(code, 0) << output;
    EXPECT_NE(output.find(std::string("Card type        : ") + card), std::string::npos) << device << "\n" << output;
  }
  std::filesystem::remove(path);
}

TEST(V4l2DoppelRun, ABadCameraOptionIsNamed) {
  const auto [code, output] = run_command(std::string(DOPPEL_RUN) + " --camera video0 -- true");
  EXPECT_EQ(code, 2) << output;
  EXPECT_NE(output.find("--camera video0: expected /dev/video<N>=CAMERA"), std::string::npos) << output;
}

}  // namespace
}  // namespace doppel::testing
