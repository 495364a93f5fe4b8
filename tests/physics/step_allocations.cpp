// The physics step does not allocate after setup (a real-time requirement): every malloc of the
// process is counted while a standing robot is stepped, on both engines. ODE and Bullet allocate
// through malloc, so replacing malloc/calloc/realloc here (forwarding to glibc) sees them all. Its
// own executable, because it replaces malloc for the whole process; not under AddressSanitizer or
// ThreadSanitizer, which own malloc themselves.

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstddef>

#include "rigs.h"
#include "urdf/urdf_import.h"

namespace {
std::atomic<bool> g_counting{false};
std::atomic<long> g_allocations{0};

// A place for a debugger breakpoint: every counted allocation passes here.
[[gnu::noinline, maybe_unused]] void count_allocation() { g_allocations.fetch_add(1, std::memory_order_relaxed); }
}  // namespace

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr bool kCountingMalloc = false;
#else
constexpr bool kCountingMalloc = true;

extern "C" {
void* __libc_malloc(size_t size);
void* __libc_calloc(size_t count, size_t size);
void* __libc_realloc(void* block, size_t size);
}

extern "C" void* malloc(size_t size) {
  if (g_counting.load(std::memory_order_relaxed)) count_allocation();
  return __libc_malloc(size);
}

extern "C" void* calloc(size_t count, size_t size) {
  if (g_counting.load(std::memory_order_relaxed)) count_allocation();
  return __libc_calloc(count, size);
}

extern "C" void* realloc(void* block, size_t size) {
  if (g_counting.load(std::memory_order_relaxed)) count_allocation();
  return __libc_realloc(block, size);
}
#endif

namespace doppel::physics {
namespace {

class AllocationTest : public ::testing::TestWithParam<std::string> {};

TEST_P(AllocationTest, StepDoesNotAllocateAfterWarmUp) {
  if (!kCountingMalloc) GTEST_SKIP() << "the sanitizer owns malloc";
  WorldOptions options;  // with the ball
  auto world = test::make_world(GetParam(), {test::shipped_robot("fumanoid-2011"), test::shipped_robot("fumanoid-2011")},
                                options);
  test::DrivenRobot driven(*world, 0);
  SceneView view;
  world->fill_scene(view);
  driven.enable_all();
  driven.run(0.5);  // warm-up: contact pools and solver buffers reach their working size

  g_allocations = 0;
  g_counting = true;
  for (int i = 0; i < 1000; ++i) {
    driven.step();
    if (i % 40 == 0) world->fill_scene(view);
  }
  g_counting = false;

  EXPECT_EQ(g_allocations.load(), 0);
}

// A robot added and another removed while the world runs: the add and the remove allocate (they
// may), the steps after them do not.
TEST_P(AllocationTest, StepDoesNotAllocateAfterARobotWasAddedAndAnotherRemoved) {
  if (!kCountingMalloc) GTEST_SKIP() << "the sanitizer owns malloc";
  WorldOptions options;
  auto world = test::make_world(GetParam(), {test::shipped_robot("fumanoid-2011"), test::shipped_robot("fumanoid-2011")},
                                options);
  test::DrivenRobot driven(*world, 0);
  driven.enable_all();
  driven.run(0.2);
  RobotPlacement far;
  far.position_m = Eigen::Vector3d(3.0, 2.0, 0.0);
  world->add_robot(test::shipped_robot("fumanoid-2011"), far);
  world->remove_robot(1);
  SceneView view;
  world->fill_scene(view);
  driven.run(0.5);  // warm-up after the change

  g_allocations = 0;
  g_counting = true;
  for (int i = 0; i < 1000; ++i) {
    driven.step();
    if (i % 40 == 0) world->fill_scene(view);
  }
  g_counting = false;

  EXPECT_EQ(g_allocations.load(), 0);
}

// The same for a body from a URDF (tests/urdf/data/test-biped.textproto): convex-hull feet on
// both engines (ODE's dCreateConvex, Bullet's btConvexHullShape), hulls in the scene view.
TEST_P(AllocationTest, StepWithConvexHullsDoesNotAllocateAfterWarmUp) {
  if (!kCountingMalloc) GTEST_SKIP() << "the sanitizer owns malloc";
  auto world = test::make_world(
      GetParam(), {compile_robot(urdf::load_robot_file(std::string(DOPPEL_URDF_TEST_DATA) + "/test-biped.textproto"),
                                 doppel::body::motor_catalog())});
  test::DrivenRobot driven(*world, 0);
  SceneView view;
  world->fill_scene(view);
  driven.enable_all();
  driven.run(0.5);

  g_allocations = 0;
  g_counting = true;
  for (int i = 0; i < 1000; ++i) {
    driven.step();
    if (i % 40 == 0) world->fill_scene(view);
  }
  g_counting = false;

  EXPECT_EQ(g_allocations.load(), 0);
}

// BAM's load-dependent friction (M6): the weight each joint carries is summed every step from the
// bodies beyond it, in lists made at setup.
TEST_P(AllocationTest, StepWithBamFrictionDoesNotAllocateAfterWarmUp) {
  if (!kCountingMalloc) GTEST_SKIP() << "the sanitizer owns malloc";
  auto world = test::make_world(GetParam(), {test::robot_from_text(R"(name: "bam-arm"
bus { name: "b" baud_bps: 1000000 protocol: PROTOCOL_1 supply_voltage_v: 15
      device { id: 1 model: "MX-64" name: "A" } device { id: 2 model: "MX-106" name: "B" } }
figure {
  motor_friction: FRICTION_BAM_M6
  body { name: "base" pose { position_m { z: 0.05 } } shape { box { size_m { x: 0.6 y: 0.6 z: 0.1 } } } mass_kg: 80 }
  body { name: "upper" pose { position_m { x: 0.1 z: 0.5 } } shape { box { size_m { x: 0.2 y: 0.03 z: 0.03 } } } mass_kg: 0.3 }
  body { name: "lower" pose { position_m { x: 0.3 z: 0.5 } } shape { box { size_m { x: 0.2 y: 0.03 z: 0.03 } } } mass_kg: 0.2 }
  link { name: "A" type: LINK_REVOLUTE parent: "base" child: "upper" anchor_m { z: 0.5 } axis { y: 1 } motor { bus: 0 id: 1 } }
  link { name: "B" type: LINK_REVOLUTE parent: "upper" child: "lower" anchor_m { x: 0.2 z: 0.5 } axis { y: 1 }
         motor { bus: 0 id: 2 } }
})")});
  test::DrivenRobot driven(*world, 0);
  driven.enable_all();
  driven.run(0.5);

  g_allocations = 0;
  g_counting = true;
  for (int i = 0; i < 1000; ++i) {
    driven.command(0).goal_position_rad = 0.3 * std::sin(0.01 * i);
    driven.command(1).goal_position_rad = -0.3 * std::sin(0.01 * i);
    driven.step();
  }
  g_counting = false;

  EXPECT_EQ(g_allocations.load(), 0);
}

TEST(AllocationCounterTest, CountsAllocations) {
  if (!kCountingMalloc) GTEST_SKIP() << "the sanitizer owns malloc";
  g_allocations = 0;
  g_counting = true;
  void* volatile block = malloc(32);
  g_counting = false;
  free(block);

  EXPECT_EQ(g_allocations.load(), 1);
}

INSTANTIATE_TEST_SUITE_P(Engines, AllocationTest, ::testing::ValuesIn(engine_names()),
                         [](const ::testing::TestParamInfo<std::string>& param) { return param.param; });

}  // namespace
}  // namespace doppel::physics
