// Noise settings as users give them: range checks with readable messages, and changes sent to a
// running camera over its settings topic (what `doppel-camera noise` does), confirmed with the
// frame from which they apply. RouDi runs inside the test process (CTest resource lock `roudi`).
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <fcntl.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <vector>

#include "camera/client.h"
#include "camera/noise.h"
#include "camera/renderer.h"
#include "camera/streaming.h"
#include "concurrency/sanitizer_handover.h"
#include "iceoryx_posh/popo/untyped_publisher.hpp"
#include "demo_scene.h"

extern char** environ;

namespace doppel::camera {
namespace {

using namespace std::chrono_literals;

std::string message_of(const NoiseConfig& config) {
  try {
    validate(config);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "valid";
}

TEST(NoiseSettings, OutOfRangeValuesAreNamedWithTheirRange) {
  EXPECT_EQ(message_of(NoiseConfig{.gaussian_sigma = -1.0}), "NoiseConfig.gaussian_sigma must lie in [0, 255], got -1");
  EXPECT_EQ(message_of(NoiseConfig{.salt_pepper_fraction = 1.5}),
            "NoiseConfig.salt_pepper_fraction must lie in [0, 1], got 1.5");
  EXPECT_EQ(message_of(NoiseConfig{.wb_blue_gain = 0.0}), "NoiseConfig.wb_blue_gain must lie in [0.001, 100], got 0");
  EXPECT_EQ(invalid_noise_field(NoiseConfig{.vignetting = std::nan("")}), "vignetting");
  EXPECT_EQ(invalid_noise_field(NoiseConfig{.shot_noise_gain = std::numeric_limits<double>::infinity()}),
            "shot_noise_gain");
  EXPECT_EQ(invalid_noise_field(NoiseConfig{}), "");
  EXPECT_EQ(invalid_noise_field(NoiseConfig{.gaussian_sigma = 255.0, .salt_pepper_fraction = 1.0}), "");
}

TEST(NoiseSettings, DescriptionListsTheActiveFilters) {
  EXPECT_EQ(describe(NoiseConfig{}), "off");
  EXPECT_EQ(describe(NoiseConfig{.seed = 5}), "off");  // a seed alone changes nothing
  EXPECT_EQ(describe(NoiseConfig{.gaussian_sigma = 2.0, .salt_pepper_fraction = 0.001, .seed = 7}),
            "gaussian 2, salt-pepper 0.001, seed 7");
  EXPECT_EQ(describe(NoiseConfig{.vignetting = 0.25, .wb_red_gain = 1.2}),
            "vignetting 0.25, white-balance 1.2,1,1, seed 0");
}

CameraConfig small_camera(const std::string& name) {
  CameraConfig c;
  c.name = name;
  c.width_px = 160;
  c.height_px = 120;
  c.format = PixelFormat::kRgb24;
  c.lens = fisheye_from_hfov(LensModel::kEquidistant, 160, 120, 120.0);
  c.mount.kind = CameraMount::Kind::kWorld;
  return c;
}

Eigen::Isometry3d looking_along_x() {
  Eigen::Isometry3d X_WC = Eigen::Isometry3d::Identity();
  X_WC.linear() << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  X_WC.translation() = Eigen::Vector3d(-1.0, 0.1, 0.5);
  return X_WC;
}

// The camera thread of a doppel: a frame of the still scene every 5 ms of wall time.
class CameraThread {
 public:
  CameraThread(CameraStream& stream, const physics::SceneView& scene)
      : thread_([this, &stream, &scene] {
          for (uint64_t i = 0; !stop_; ++i) {
            stream.render_and_publish(scene, looking_along_x(), 0.05 * static_cast<double>(i));
            std::this_thread::sleep_for(5ms);
          }
        }) {}
  ~CameraThread() {
    stop_ = true;
    thread_.join();
  }

 private:
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

TEST(NoiseSettings, SettingsSentToARunningCameraApplyFromTheConfirmedFrame) {
  const CameraConfig config = small_camera("settings_cam");
  StreamingHost host({config});
  CameraStream sut(host, config);
  FrameSubscriber sub("settings_cam", SubscriberOptions{.queue_capacity = 64});
  const physics::SceneView scene = make_demo_scene(0);
  std::optional<CameraThread> camera_thread(std::in_place, sut, scene);
  NoiseConfig noisy;
  noisy.gaussian_sigma = 6.0;
  noisy.salt_pepper_fraction = 0.01;
  noisy.seed = 3;
  std::map<uint64_t, std::vector<uint8_t>> frames;
  for (int i = 0; i < 50 && frames.empty(); ++i) {  // frames flow before the change
    if (auto f = sub.wait_take(0.1)) {
      frames[f->header().sequence].assign(f->pixels(), f->pixels() + f->header().pixel_bytes);
    }
  }
  ASSERT_FALSE(frames.empty());

  const CameraInfo confirmed = set_camera_noise("settings_cam", noisy, 5.0);

  EXPECT_STREQ(confirmed.name, "settings_cam");
  EXPECT_DOUBLE_EQ(confirmed.noise.gaussian_sigma, 6.0);
  EXPECT_DOUBLE_EQ(confirmed.noise.salt_pepper_fraction, 0.01);
  EXPECT_EQ(confirmed.noise.seed, 3u);
  EXPECT_NE(confirmed.noise_request_id, 0u);
  // Frames before the confirmed one are clean and equal; from it on they carry the noise.
  const auto end = std::chrono::steady_clock::now() + 5s;
  while (std::chrono::steady_clock::now() < end &&
         (frames.empty() || frames.rbegin()->first < confirmed.noise_from_sequence + 2)) {
    if (auto f = sub.wait_take(0.1)) {
      frames[f->header().sequence].assign(f->pixels(), f->pixels() + f->header().pixel_bytes);
    }
  }
  std::vector<uint8_t> clean;
  int clean_frames = 0;
  int noisy_frames = 0;
  for (const auto& [sequence, pixels] : frames) {
    if (sequence < confirmed.noise_from_sequence) {
      if (clean.empty()) clean = pixels;
      EXPECT_EQ(pixels, clean) << sequence;
      ++clean_frames;
    }
  }
  ASSERT_GT(clean_frames, 0) << "no frame before " << confirmed.noise_from_sequence;
  for (const auto& [sequence, pixels] : frames) {
    if (sequence >= confirmed.noise_from_sequence) {
      EXPECT_NE(pixels, clean) << sequence;
      ++noisy_frames;
    }
  }
  EXPECT_GE(noisy_frames, 2);
  camera_thread.reset();  // noise() belongs to the camera thread: read it once that has ended
  EXPECT_DOUBLE_EQ(sut.noise().gaussian_sigma, 6.0);
  EXPECT_EQ(sut.stats().settings_applied, 1u);
  const auto listed = list_cameras(2.0);
  ASSERT_EQ(listed.size(), 1u);
  EXPECT_DOUBLE_EQ(listed[0].noise.gaussian_sigma, 6.0);  // what `doppel-camera list` shows
  EXPECT_THROW(set_camera_noise("settings_cam", NoiseConfig{.vignetting = 2.0}), std::invalid_argument);
  EXPECT_THROW(set_camera_noise("no_such_cam", NoiseConfig{}, 0.5), std::runtime_error);
}

TEST(NoiseSettings, OutOfRangeRequestFromAnotherClientIsRefusedAndCounted) {
  const CameraConfig config = small_camera("guarded_cam");
  StreamingHost host({config});
  CameraStream sut(host, config);
  iox::popo::PublisherOptions options;
  options.historyCapacity = 1;
  iox::popo::UntypedPublisher rogue({"DoppelCamera", "guarded_cam", "settings"}, options);
  const auto until = std::chrono::steady_clock::now() + 3s;
  while (!rogue.hasSubscribers() && std::chrono::steady_clock::now() < until) std::this_thread::sleep_for(5ms);
  ASSERT_TRUE(rogue.hasSubscribers());
  NoiseRequest bad;
  bad.request_id = 99;
  bad.noise.salt_pepper_fraction = 7.0;
  void* chunk = rogue.loan(sizeof(NoiseRequest), alignof(NoiseRequest)).value();
  std::memcpy(chunk, &bad, sizeof(bad));
  concurrency::handing_over(chunk);
  rogue.publish(chunk);

  bool changed = false;
  const auto end = std::chrono::steady_clock::now() + 3s;
  while (sut.stats().settings_rejected == 0 && std::chrono::steady_clock::now() < end) {
    changed = changed || sut.poll_settings();
    std::this_thread::sleep_for(5ms);
  }

  EXPECT_EQ(sut.stats().settings_rejected, 1u);
  EXPECT_FALSE(changed);
  EXPECT_FALSE(sut.noise().active());
  const auto listed = list_cameras(2.0);
  ASSERT_EQ(listed.size(), 1u);
  EXPECT_EQ(listed[0].settings_rejected, 1u);
  EXPECT_EQ(listed[0].noise_request_id, 0u);
}

// Runs `args` and returns (exit code, stdout + stderr).
std::pair<int, std::string> run_tool(const std::vector<std::string>& args) {
  const std::string out = ::testing::TempDir() + "doppel_camera_noise.txt";
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  pid_t pid = -1;
  if (posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ) != 0) return {-1, "spawn failed"};
  posix_spawn_file_actions_destroy(&actions);
  int status = 0;
  for (int i = 0; i < 3000 && ::waitpid(pid, &status, WNOHANG) == 0; ++i) std::this_thread::sleep_for(10ms);
  if (::waitpid(pid, &status, WNOHANG) == 0) {
    ::kill(pid, SIGKILL);
    ::waitpid(pid, &status, 0);
    return {-1, "timed out"};
  }
  std::ifstream in(out);
  std::stringstream text;
  text << in.rdbuf();
  std::filesystem::remove(out);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, text.str()};
}

TEST(NoiseSettings, ToolChangesTheGivenSettingsAndKeepsTheOthers) {
  CameraConfig config = small_camera("tool_noise_cam");
  config.noise.vignetting = 0.2;
  config.noise.seed = 9;
  StreamingHost host({config});
  CameraStream sut(host, config);
  const physics::SceneView scene = make_demo_scene(0);
  std::optional<CameraThread> camera_thread(std::in_place, sut, scene);

  auto [code, out] = run_tool({DOPPEL_CAMERA_TOOL, "noise", "--camera", "tool_noise_cam", "--gaussian", "2",
                               "--white-balance", "1.1,1,0.9"});
  auto [list_code, list] = run_tool({DOPPEL_CAMERA_TOOL, "list"});
  auto [off_code, off] = run_tool({DOPPEL_CAMERA_TOOL, "noise", "--camera", "tool_noise_cam", "--off"});
  auto [bad_code, bad] = run_tool({DOPPEL_CAMERA_TOOL, "noise", "--camera", "tool_noise_cam", "--vignetting", "x"});
  auto [none_code, none] = run_tool({DOPPEL_CAMERA_TOOL, "noise", "--camera", "tool_noise_cam"});
  camera_thread.reset();  // noise() belongs to the camera thread: read it once that has ended
  const NoiseConfig after_off = sut.noise();  // the two refused runs after --off change nothing

  EXPECT_EQ(code, 0) << out;
  EXPECT_NE(out.find("camera tool_noise_cam: noise gaussian 2, vignetting 0.2, white-balance 1.1,1,0.9, seed 9 from frame"),
            std::string::npos)
      << out;
  EXPECT_EQ(list_code, 0) << list;
  EXPECT_NE(list.find("gaussian 2, vignetting 0.2"), std::string::npos) << list;
  EXPECT_EQ(off_code, 0) << off;
  EXPECT_FALSE(after_off.active());
  EXPECT_EQ(bad_code, 2) << bad;
  EXPECT_NE(bad.find("--vignetting needs a number, got 'x'"), std::string::npos) << bad;
  EXPECT_EQ(none_code, 2) << none;
}

}  // namespace
}  // namespace doppel::camera
