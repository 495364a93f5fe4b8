// The simulation thread publishes the viewer's scene without allocating: after setup,
// SimController::begin_tick/end_tick (state every 10 ms, scene every 34 ms through snapshots) call
// no operator new while an HTTP-side reader copies the scene at the same time, and the reader sees
// the scene of the latest publication. Its own executable, because it replaces the global operator new.
#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include "allocation_counter.h"
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
  physics::World world(physics::make_backend(*options.physics), {*robot.body}, {}, world_options);
  SimController sut(&world, {{nullptr, 0, robot.name}}, 5.0, 3.5);

  std::atomic<bool> done{false};
  std::atomic<int> reads{0};
  std::thread reader([&] {  // an HTTP thread polling /api/scene
    while (!done.load()) {
      const control::Scene scene = sut.scene();
      EXPECT_FALSE(scene.shapes.empty());
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
  const control::Scene scene = sut.scene();
  EXPECT_NEAR(scene.sim_time_s, 0.476, 1e-9);
  physics::SceneView now;
  world.fill_scene(now);
  ASSERT_EQ(scene.shapes.size(), now.shapes.size());
}

}  // namespace
}  // namespace doppel::gateway
