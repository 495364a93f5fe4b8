// TruthService::capture runs on the simulation thread after every step: it must not allocate (a
// replaced global operator new counts this thread's allocations; its own executable).
#include <gtest/gtest.h>

#include "allocation_counter.h"
#include "rigs.h"
#include "truth/truth_service.h"

namespace doppel::truth {
namespace {

TEST(TruthCapture, AllocatesNothingPerStep) {
  auto world = physics::test::make_world(
      "ode", {physics::test::robot_from_text(physics::test::servo_rig("shape { box { size_m { x: 0.1 y: 0.1 z: 0.1 } } } mass_kg: 1"))});
  TruthOptions options;
  options.transport.iceoryx = false;
  options.transport.udp = false;
  TruthService service(options);
  RobotBinding binding;
  binding.has_camera = true;  // the camera path too
  binding.X_BC.translation() = Eigen::Vector3d(0.05, 0.0, 0.1);
  ASSERT_EQ(service.add_robot(0, binding, {}), "");
  for (int i = 0; i < 100; ++i) world->step();  // the engine's own warm-up is not what this counts
  service.capture(*world, world->time_ns());    // takes the binding
  testing::count_allocations_on_this_thread(true);
  for (int i = 0; i < 500; ++i) {
    world->step();
    service.capture(*world, world->time_ns());
  }
  testing::count_allocations_on_this_thread(false);
  EXPECT_EQ(testing::counted_allocations(), 0u);
  EXPECT_EQ(service.stats().samples_dropped, 0u);
}

}  // namespace
}  // namespace doppel::truth
