// Render rate of the CPU renderer for the default scene (2011 field, ball, six robots) seen by the
// default head camera (equidistant fisheye, 120 deg horizontal) from a robot's head, per pixel
// format, at 640x480 and 1280x720, with one and two threads. Ground truth annotations included.
#include <benchmark/benchmark.h>

#include <string>
#include <vector>

#include "camera/camera_config.h"
#include "camera/renderer.h"
#include "demo_scene.h"

namespace {

using namespace doppel::camera;

Eigen::Isometry3d head_pose() {
  Eigen::Isometry3d X_WB = Eigen::Isometry3d::Identity();
  X_WB.translation() = Eigen::Vector3d(-0.5, -0.3, 0.55);
  X_WB.linear() = (Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitY()))
                      .toRotationMatrix();
  return camera_pose_W(default_head_camera().mount, X_WB);
}

void BM_Render(benchmark::State& state, PixelFormat format, int width, int height, int threads) {
  const LensConfig lens = fisheye_from_hfov(LensModel::kEquidistant, width, height, 120.0);
  Renderer renderer(lens, width, height, format, threads);
  const auto scene = make_demo_scene(6);
  const Eigen::Isometry3d X_WC = head_pose();
  std::vector<uint8_t> out(frame_bytes(format, width, height));
  FrameAnnotations annotations;
  uint64_t frame = 0;
  for (auto _ : state) {
    renderer.render(scene, X_WC, frame++, out.data(), &annotations);
    benchmark::DoNotOptimize(out.data());
  }
  state.counters["fps"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["prims"] = renderer.last_stats().primitives;
}

const bool registered = [] {
  struct Size {
    int w, h;
  };
  for (PixelFormat format : kAllPixelFormats) {
    for (Size s : {Size{640, 480}, Size{1280, 720}}) {
      for (int threads : {1, 2}) {
        const std::string name = "render/" + std::string(to_string(format)) + "/" + std::to_string(s.w) + "x" +
                                 std::to_string(s.h) + "/threads:" + std::to_string(threads);
        benchmark::RegisterBenchmark(name.c_str(), BM_Render, format, s.w, s.h, threads)
            ->Unit(benchmark::kMillisecond)
            ->UseRealTime();
      }
    }
  }
  return true;
}();

}  // namespace
