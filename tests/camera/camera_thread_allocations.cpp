// The camera thread allocates nothing per frame: after its first frame, rendering, publishing and
// taking settings changes (sent over the settings topic, republished in the camera's info) call no
// operator new on that thread. Its own executable, because it replaces the global operator new;
// RouDi runs inside it (CTest resource lock `roudi`).
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "allocation_counter.h"
#include "camera/client.h"
#include "camera/renderer.h"
#include "camera/streaming.h"
#include "demo_scene.h"

namespace doppel::camera {
namespace {

using namespace std::chrono_literals;

TEST(CameraThreadAllocations, FramesAndSettingsChangesAllocateNothing) {
  CameraConfig config;
  config.name = "alloc_cam";
  config.width_px = 160;
  config.height_px = 120;
  config.lens = fisheye_from_hfov(LensModel::kEquidistant, 160, 120, 120.0);
  config.mount.kind = CameraMount::Kind::kWorld;
  StreamingHost host({config});
  CameraStream sut(host, config);
  FrameSubscriber sub("alloc_cam");
  const physics::SceneView scene = make_demo_scene(2);
  Eigen::Isometry3d X_WC = Eigen::Isometry3d::Identity();
  X_WC.linear() << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  X_WC.translation() = Eigen::Vector3d(-1.0, 0.1, 0.5);
  std::atomic<bool> stop{false};
  std::atomic<uint64_t> frames{0};
  std::atomic<uint64_t> counted_frames{0};
  std::atomic<bool> warm{false};
  std::thread camera_thread([&] {
    sut.render_and_publish(scene, X_WC, 0.0);  // the first frame sizes the renderer's buffers
    sut.poll_settings();
    warm = true;
    doppel::testing::count_allocations_on_this_thread(true);
    for (uint64_t i = 1; !stop; ++i) {
      if (sut.render_and_publish(scene, X_WC, 0.05 * static_cast<double>(i))) ++counted_frames;
      ++frames;
      std::this_thread::sleep_for(2ms);
    }
    doppel::testing::count_allocations_on_this_thread(false);
  });
  while (!warm) std::this_thread::sleep_for(1ms);

  // Settings changes from a client while frames flow; the subscriber keeps taking frames.
  for (int change = 0; change < 4; ++change) {
    NoiseConfig noise;
    noise.gaussian_sigma = change % 2 == 0 ? 3.0 : 0.0;
    noise.salt_pepper_fraction = 0.001 * change;
    set_camera_noise("alloc_cam", noise, 5.0);
    for (int i = 0; i < 5; ++i) sub.wait_take(0.1);
  }
  stop = true;
  camera_thread.join();

  EXPECT_EQ(sut.stats().settings_applied, 4u);
  EXPECT_GT(counted_frames.load(), 10u);
  EXPECT_EQ(doppel::testing::counted_allocations(), 0u) << "over " << frames.load() << " frames";
}

}  // namespace
}  // namespace doppel::camera
