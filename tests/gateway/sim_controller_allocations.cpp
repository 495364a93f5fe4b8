// The simulation thread publishes the viewer's scene without allocating: after setup,
// SimController::begin_tick/end_tick (state every 10 ms, scene every 34 ms through snapshots) call
// no operator new while an HTTP-side reader copies the scene at the same time, and the reader sees
// the scene of the latest publication. Its own executable, because it replaces the global operator new.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <fstream>
#include <thread>

#include "allocation_counter.h"
#include "camera/camera_config.h"
#include "camera/image_io.h"
#include "gateway/options.h"
#include "gateway/robot_config.h"
#include "physics/engines.h"
#include "physics/field.h"
#include "physics/world.h"
#include "sim_controller.h"

namespace doppel::gateway {
namespace {

TEST(SimControllerAllocations, PublishingTheSceneAllocatesNothingAndTheReaderSeesIt) {
  RobotConfig robot = load_robot("fumanoid-2011", DOPPEL_ROBOTS_DIR);
  ASSERT_TRUE(robot.body.has_value());
  const Options options;
  physics::WorldOptions world_options;
  world_options.hold = physics::HoldMode::kReleased;  // the robot falls: every scene differs
  world_options.field = physics::field_shapes();
  physics::World world(physics::make_backend(*options.world.physics), {*robot.body}, {}, world_options);
  SimController sut(&world, {{nullptr, 0, robot.name, &robot}}, 5.0, 3.5);

  std::atomic<bool> done{false};
  std::atomic<int> reads{0};
  std::thread reader([&] {  // an HTTP thread polling /api/scene and rendering a camera's stills
    while (!done.load()) {
      const contract::Scene scene = sut.scene();
      EXPECT_FALSE(scene.shapes.empty());
      EXPECT_TRUE(sut.camera_still(robot.cameras[0].config.name).ok());
      reads.fetch_add(1);
    }
  });
  for (int tick = 0; tick < 500; ++tick) {
    doppel::testing::count_allocations_on_this_thread(true);
    const bool advancing = sut.begin_tick();
    if (advancing) world.step();
    sut.end_tick(world.time_ns());
    doppel::testing::count_allocations_on_this_thread(false);
    ASSERT_TRUE(advancing);
  }
  while (reads.load() < 3) std::this_thread::yield();
  done = true;
  reader.join();
  EXPECT_EQ(doppel::testing::counted_allocations(), 0u) << "over 500 ticks";

  // The last publication was at tick 34 * 14 = 476: 476 ms of simulation time.
  const contract::Scene scene = sut.scene();
  EXPECT_NEAR(scene.sim_time_s, 0.476, 1e-9);
  physics::SceneView now;
  world.fill_scene(now);
  ASSERT_EQ(scene.shapes.size(), now.shapes.size());

  // The state of tick 500 carries what the IMU and foot boards measured in that step (the world's
  // readouts), and where the head camera is.
  const contract::SimState state = sut.state();
  ASSERT_EQ(state.robots.size(), 1u);
  const contract::RobotState& r = state.robots[0];
  std::size_t imus = 0, feet = 0;
  for (std::size_t b = 0; b < robot.buses.size(); ++b) {
    for (const DeviceConfig& device : robot.buses[b].devices) {
      if (const auto imu = world.find_imu(0, static_cast<uint32_t>(b), device.id)) {
        ASSERT_LT(imus, r.imus.size());
        const physics::ImuState expected = world.imu(*imu);
        EXPECT_EQ(r.imus[imus].id, device.id);
        EXPECT_EQ(r.imus[imus].name, device.name);
        EXPECT_EQ(r.imus[imus].roll_rad, expected.roll_rad);
        EXPECT_EQ(r.imus[imus].pitch_rad, expected.pitch_rad);
        EXPECT_EQ(r.imus[imus].gyro_rad_s, expected.w_WS_S_rad_s);
        ++imus;
      }
      if (const auto foot = world.find_foot(0, static_cast<uint32_t>(b), device.id)) {
        ASSERT_LT(feet, r.feet.size());
        EXPECT_EQ(r.feet[feet].id, device.id);
        EXPECT_EQ(r.feet[feet].force_n, world.foot(*foot).force_n);
        ++feet;
      }
    }
  }
  EXPECT_EQ(r.imus.size(), imus);
  EXPECT_EQ(r.feet.size(), feet);
  EXPECT_GE(imus, 1u) << "the FUmanoid has an IMU";
  EXPECT_GE(feet, 2u) << "the FUmanoid has a foot board per foot";
  ASSERT_EQ(r.cameras.size(), robot.cameras.size());
  ASSERT_GE(r.cameras.size(), 1u);
  const Eigen::Isometry3d X_WC =
      camera::camera_pose_W(robot.cameras[0].config.mount, world.body_pose(0, robot.cameras[0].body));
  EXPECT_NEAR(r.cameras[0].position[0], X_WC.translation().x(), 1e-12);
  EXPECT_NEAR(r.cameras[0].position[2], X_WC.translation().z(), 1e-12);
  for (const auto& ray : r.cameras[0].corner_rays) {
    EXPECT_NEAR(std::hypot(ray[0], ray[1], ray[2]), 1.0, 1e-9);
    EXPECT_GT(ray[2], -1.0) << "a corner ray of a field of view below 360 degrees";
  }
  // The still: a PNG of the camera's size showing the carpet (green above red and blue) below the
  // horizon; an unknown camera is refused with the names of those there are.
  std::this_thread::sleep_for(SimController::kStillPeriod);  // a new still, of the last scene
  const contract::Result<contract::CameraStill> answer = sut.camera_still(r.cameras[0].name);
  ASSERT_TRUE(answer.ok()) << answer.error().message;
  const contract::CameraStill& still = answer.value();
  EXPECT_NEAR(still.sim_time_s, 0.476, 1e-9);
  const std::string path = ::testing::TempDir() + "/sim_controller_still.png";
  { std::ofstream(path, std::ios::binary) << still.png; }
  std::string rgb;
  int width = 0, height = 0;
  camera::read_png_rgb(path, &rgb, &width, &height);
  EXPECT_EQ(width, robot.cameras[0].config.width_px);
  EXPECT_EQ(height, robot.cameras[0].config.height_px);
  int green = 0;
  for (std::size_t i = 0; i + 2 < rgb.size(); i += 3) {
    const int red = static_cast<uint8_t>(rgb[i]), g = static_cast<uint8_t>(rgb[i + 1]), blue = static_cast<uint8_t>(rgb[i + 2]);
    green += g > red + 20 && g > blue + 20;
  }
  EXPECT_GT(green, width * height / 20) << "the carpet should fill part of the picture";
  const contract::Result<contract::CameraStill> unknown = sut.camera_still("tail");
  ASSERT_FALSE(unknown.ok());
  EXPECT_EQ(unknown.error().kind, contract::ErrorKind::kNotFound);
  const std::string& message = unknown.error().message;
  EXPECT_NE(message.find("no camera 'tail' (robot cameras: " + r.cameras[0].name + ")"), std::string::npos) << message;
  EXPECT_LT(r.cameras[0].corner_rays[0][0], 0.0) << "top-left: x left";
  EXPECT_LT(r.cameras[0].corner_rays[0][1], 0.0) << "top-left: y up";
  EXPECT_GT(r.cameras[0].corner_rays[2][0], 0.0) << "bottom-right: x right";
  EXPECT_GT(r.cameras[0].corner_rays[2][1], 0.0) << "bottom-right: y down";
}

}  // namespace
}  // namespace doppel::gateway
