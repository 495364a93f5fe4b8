// A camera publisher for the V4L2 tests and benchmark that need no simulation: iceoryx RouDi in
// this process and one camera `--name` (pinhole, 58 deg like the DARwIn-OP's) rendering the demo
// scene (field, the ball at (0.5, 0.2)) from a fixed pose at --fps, until SIGTERM/SIGINT. Prints
// "publishing NAME" once frames flow.
#include <signal.h>

#include <CLI/CLI.hpp>

#include <atomic>
#include <chrono>
#include <iostream>
#include <thread>

#include "camera/camera_config.h"
#include "camera/streaming.h"
#include "demo_scene.h"

namespace {
std::atomic<bool> g_stop{false};
void on_signal(int) { g_stop = true; }
}  // namespace

int main(int argc, char** argv) {
  using namespace doppel::camera;
  CLI::App app{"Publishes one rendered camera over iceoryx for the V4L2 tests", "camera_source"};
  CameraConfig config;
  config.name = "source";
  config.width_px = 320;
  config.height_px = 240;
  config.fps = 30;
  std::string format = "yuyv";
  app.add_option("--name", config.name);
  app.add_option("--width", config.width_px);
  app.add_option("--height", config.height_px);
  app.add_option("--fps", config.fps);
  app.add_option("--format", format);
  CLI11_PARSE(app, argc, argv);
  config.format = parse_pixel_format(format);
  config.lens = pinhole_from_hfov(config.width_px, config.height_px, 58.0);
  config.mount.kind = CameraMount::Kind::kWorld;
  config.mount.body = "head";
  ::signal(SIGTERM, on_signal);
  ::signal(SIGINT, on_signal);
  StreamingHost host({config});
  CameraStream stream(host, config);
  const doppel::physics::SceneView scene = make_demo_scene(2);
  Eigen::Isometry3d X_WC = Eigen::Isometry3d::Identity();
  X_WC.linear() << 0, 0, 1, -1, 0, 0, 0, -1, 0;  // optical axis along +x, image x along -y
  X_WC.translation() = Eigen::Vector3d(-1.0, 0.2, 0.5);
  std::cout << "publishing " << config.name << std::endl;
  const auto period = std::chrono::duration<double>(1.0 / config.fps);
  auto next = std::chrono::steady_clock::now();
  for (uint64_t i = 0; !g_stop; ++i) {
    stream.render_and_publish(scene, X_WC, static_cast<double>(i) / config.fps);
    next += std::chrono::duration_cast<std::chrono::steady_clock::duration>(period);
    std::this_thread::sleep_until(next);
  }
  return 0;
}
