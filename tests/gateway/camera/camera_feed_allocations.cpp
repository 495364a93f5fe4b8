// The simulation thread hands the scene to the camera thread without locking or allocating: after
// setup, CameraFeed::offer() calls no operator new, and the camera thread renders exactly the scene
// that was offered. Its own executable, because it replaces the global operator new; RouDi runs
// inside it (CTest resource lock `roudi`).
#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <thread>

#include "allocation_counter.h"
#include "camera/client.h"
#include "camera/lens.h"
#include "camera_feed.h"
#include "gateway/options.h"
#include "gateway/robot_config.h"
#include "physics/engines.h"
#include "physics/field.h"
#include "physics/world.h"

namespace doppel::gateway {
namespace {

TEST(CameraFeedAllocations, OfferAllocatesNothingAndTheCameraRendersTheOfferedScene) {
  RobotConfig robot = load_robot("fumanoid-2011", DOPPEL_ROBOTS_DIR);
  ASSERT_TRUE(robot.body.has_value());
  ASSERT_EQ(robot.cameras.size(), 1u);
  camera::CameraConfig& config = robot.cameras[0].config;
  config.name = "feed_alloc_cam";
  config.width_px = 160;
  config.height_px = 120;
  config.lens = camera::fisheye_from_hfov(camera::LensModel::kEquidistant, 160, 120, 120.0);
  const Options options;
  physics::WorldOptions world_options;
  world_options.hold = physics::HoldMode::kReleased;  // the robot falls: every scene differs
  world_options.field = physics::field_shapes();
  physics::World world(physics::make_backend(*options.world.physics), {*robot.body}, {}, world_options);
  CameraFeed sut(&world, {robot.cameras}, {}, options);
  camera::FrameSubscriber subscriber(config.name);
  sut.start();
  const auto connect_deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (!subscriber.connected() && std::chrono::steady_clock::now() < connect_deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ASSERT_TRUE(subscriber.connected());

  // Like the simulation thread: offer after every step. Frame k is due at k / fps (a grid of
  // simulation time) and rendered from the first step at or after it; this loop waits for each
  // frame, so none is skipped and each must carry the time of the step that offered it.
  const int64_t period_ns = static_cast<int64_t>(1e9 / config.fps);
  int64_t next_frame_ns = 0;
  uint64_t offers = 0;
  int frames = 0;
  while (frames < 20) {
    world.step();
    doppel::testing::count_allocations_on_this_thread(true);
    sut.offer(&world, world.time_ns());
    doppel::testing::count_allocations_on_this_thread(false);
    ++offers;
    if (world.time_ns() >= next_frame_ns) {
      const auto frame = subscriber.wait_take(10.0);
      ASSERT_TRUE(frame.has_value()) << "no frame for the scene offered at " << world.time_ns() << " ns";
      EXPECT_EQ(frame->header().sim_time_ns, world.time_ns());
      next_frame_ns = (world.time_ns() / period_ns + 1) * period_ns;
      ++frames;
    }
  }
  sut.stop();

  EXPECT_EQ(doppel::testing::counted_allocations(), 0u) << "over " << offers << " offers";
}

}  // namespace
}  // namespace doppel::gateway
