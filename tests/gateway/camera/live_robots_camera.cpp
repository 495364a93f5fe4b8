// The cameras of a robot added while doppel runs (contract::RobotHost; docs/robots-at-run-time.md):
// they stream over iceoryx under the name the answer gives, with the settings asked for, and go
// with the robot; bad camera requests are refused naming the field and leave nothing behind. In
// process (a Gateway); its own executable: it starts RouDi, so it holds the `roudi` lock.

#include <gtest/gtest.h>
#include <stdlib.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <string>
#include <thread>

#include "camera/client.h"
#include "camera/pixel_format.h"
#include "camera/streaming.h"
#include "contract/robot_host.h"
#include "gateway/gateway.h"

namespace doppel::testing {
namespace {

namespace fs = std::filesystem;
using contract::Refusal;
using contract::RobotAdded;
using contract::RobotRequest;

class LiveRobotCameras : public ::testing::Test {
 protected:
  void SetUp() override {
    char pattern[] = "/tmp/doppel-live-camera-XXXXXX";
    ASSERT_NE(::mkdtemp(pattern), nullptr);
    dir_ = pattern;
    gateway::Options options;
    options.buses.link_dir = dir_ + "/links";
    options.buses.robots = {"fumanoid-2011"};
    options.buses.robots_dir = DOPPEL_ROBOTS_DIR;
    options.buses.timing = bus::TimingMode::kFast;
    options.viewer.enabled = false;
    options.state.dir.clear();
    link_dir_ = options.buses.link_dir;
    gateway_ = std::make_unique<gateway::Gateway>(options);
    gateway_->start();
  }
  void TearDown() override {
    gateway_.reset();
    std::error_code ignored;
    fs::remove_all(dir_, ignored);
  }

  contract::RobotHost& host() { return gateway_->robot_host(); }

  static bool camera_listed(const std::string& name) {
    const auto cameras = camera::list_cameras(1.0);
    return std::any_of(cameras.begin(), cameras.end(), [&](const camera::CameraInfo& info) { return info.name == name; });
  }

  // A frame of camera `name` within 30 s of wall-clock time (a loaded machine), or none.
  static std::optional<camera::Frame> first_frame(const std::string& name) {
    camera::FrameSubscriber subscriber(name);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    while (std::chrono::steady_clock::now() < deadline) {
      if (auto frame = subscriber.wait_take(1.0)) return frame;
    }
    return std::nullopt;
  }

  void expect_refused(const RobotRequest& request, const std::string& field) {
    const contract::AddResult result = host().add_robot(request);
    ASSERT_TRUE(std::holds_alternative<Refusal>(result)) << field;
    EXPECT_EQ(std::get<Refusal>(result).field, field) << std::get<Refusal>(result).message;
    EXPECT_EQ(host().robots().size(), 1u) << field;
    EXPECT_FALSE(fs::exists(fs::symlink_status(link_dir_ + "/robot1/ttyDXL0"))) << field;
    EXPECT_FALSE(camera_listed("robot1-HEAD_CAMERA")) << field;
  }

  std::string dir_;
  std::string link_dir_;
  std::unique_ptr<gateway::Gateway> gateway_;
};

RobotRequest with_camera(const contract::CameraRequest& camera) {
  RobotRequest request;
  request.robot = "fumanoid-2011";
  request.cameras.push_back(camera);
  return request;
}

contract::CameraRequest head_camera() {
  contract::CameraRequest camera;
  camera.name = "HEAD_CAMERA";
  return camera;
}

TEST_F(LiveRobotCameras, AnAddedRobotsCameraStreamsWithTheAskedSettingsAndGoesWithIt) {
  contract::CameraRequest camera = head_camera();
  camera.width_px = 320;
  camera.height_px = 240;
  camera.format = "bayer_rggb";
  camera.lens = "pinhole";
  camera.hfov_deg = 70.0;
  camera.fps = 30.0;
  const contract::AddResult result = host().add_robot(with_camera(camera));
  ASSERT_TRUE(std::holds_alternative<RobotAdded>(result)) << std::get<Refusal>(result).field << ": "
                                                          << std::get<Refusal>(result).message;
  const RobotAdded& added = std::get<RobotAdded>(result);
  const auto link = std::find_if(added.links.begin(), added.links.end(),
                                 [](const contract::Link& l) { return l.kind == "camera"; });
  ASSERT_NE(link, added.links.end());
  EXPECT_EQ(link->name, "robot1-HEAD_CAMERA");
  EXPECT_EQ(link->location, "iceoryx:DoppelCamera/robot1-HEAD_CAMERA/frames");

  const std::optional<camera::Frame> frame = first_frame(link->name);
  ASSERT_TRUE(frame.has_value()) << "no frame from the added robot's camera";
  EXPECT_EQ(frame->header().width_px, 320);
  EXPECT_EQ(frame->header().height_px, 240);
  EXPECT_EQ(frame->header().format, static_cast<uint32_t>(camera::PixelFormat::kBayerRggb));
  EXPECT_TRUE(camera_listed(link->name));

  EXPECT_FALSE(host().remove_robot(1).has_value());
  EXPECT_FALSE(camera::camera_offered(link->name)) << "the removed robot's camera is still offered";
  EXPECT_FALSE(camera_listed(link->name));
  EXPECT_FALSE(fs::exists(fs::symlink_status(link_dir_ + "/robot1/ttyDXL0")));
  EXPECT_TRUE(first_frame("HEAD_CAMERA").has_value()) << "the first robot's camera streams on";

  // Its name is free again: the same robot comes back with the file's camera.
  const contract::AddResult again = host().add_robot(with_camera(head_camera()));
  ASSERT_TRUE(std::holds_alternative<RobotAdded>(again)) << std::get<Refusal>(again).message;
  const std::optional<camera::Frame> back = first_frame("robot1-HEAD_CAMERA");
  ASSERT_TRUE(back.has_value());
  EXPECT_EQ(back->header().width_px, 640);  // the file's 640x480 YUYV
  EXPECT_EQ(back->header().format, static_cast<uint32_t>(camera::PixelFormat::kYuyv));
}

TEST_F(LiveRobotCameras, BadCameraRequestsAreRefusedNamingTheFieldAndLeaveNothingBehind) {
  contract::CameraRequest unknown = head_camera();
  unknown.name = "TAIL_CAMERA";
  expect_refused(with_camera(unknown), "cameras[0].name");
  contract::CameraRequest format = head_camera();
  format.format = "rgb48";
  expect_refused(with_camera(format), "cameras[0].format");
  contract::CameraRequest odd = head_camera();
  odd.width_px = 321;
  expect_refused(with_camera(odd), "cameras[0].width_px");
  contract::CameraRequest lens = head_camera();
  lens.lens = "fishbowl";
  expect_refused(with_camera(lens), "cameras[0].lens");
  contract::CameraRequest hfov = head_camera();
  hfov.hfov_deg = 200.0;
  expect_refused(with_camera(hfov), "cameras[0].hfov_deg");
  contract::CameraRequest noise = head_camera();
  noise.noise_gaussian_sigma = -1.0;
  expect_refused(with_camera(noise), "cameras[0].noise_gaussian_sigma");
  RobotRequest twice = with_camera(head_camera());
  twice.cameras.push_back(head_camera());
  expect_refused(twice, "cameras[1].name");
  RobotRequest contradiction = with_camera(head_camera());
  contradiction.cameras_off = true;
  expect_refused(contradiction, "cameras");
  // Valid, but its frames (4096 x 4096 RGB, 48 MiB) do not fit the pools iceoryx was started with:
  // refused after the checks, when its stream is made; nothing of the robot is left.
  contract::CameraRequest huge = head_camera();
  huge.width_px = 4096;
  huge.height_px = 4096;
  huge.format = "rgb24";
  expect_refused(with_camera(huge), "cameras[0]");
  EXPECT_TRUE(first_frame("HEAD_CAMERA").has_value()) << "the first robot's camera streams on";
}

}  // namespace
}  // namespace doppel::testing
