// Streaming through iceoryx with RouDi inside the test process (CTest resource lock `roudi`).
#include "camera/streaming.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <vector>

#include "camera/client.h"
#include "camera/renderer.h"
#include "demo_scene.h"

extern char** environ;

namespace doppel::camera {
namespace {

using namespace std::chrono_literals;

CameraConfig small_camera(const std::string& name) {
  CameraConfig c;
  c.name = name;
  c.width_px = 160;
  c.height_px = 120;
  c.format = PixelFormat::kYuyv;
  c.lens = fisheye_from_hfov(LensModel::kEquidistant, 160, 120, 120.0);
  c.mount.kind = CameraMount::Kind::kWorld;
  return c;
}

Eigen::Isometry3d pose_for(uint64_t i) {
  Eigen::Isometry3d X_WC = Eigen::Isometry3d::Identity();
  X_WC.linear() << 0, 0, 1, -1, 0, 0, 0, -1, 0;  // looking along +x
  X_WC.translation() = Eigen::Vector3d(-1.0 + 0.01 * static_cast<double>(i), 0.1, 0.5);
  return X_WC;
}

template <typename Pred>
bool eventually(Pred pred, std::chrono::milliseconds limit = 3000ms) {
  const auto end = std::chrono::steady_clock::now() + limit;
  while (std::chrono::steady_clock::now() < end) {
    if (pred()) return true;
    std::this_thread::sleep_for(5ms);
  }
  return pred();
}

// Publishes a frame every 10 ms of wall time until destroyed.
class PublisherThread {
 public:
  PublisherThread(CameraStream& stream, const physics::SceneView& scene)
      : thread_([this, &stream, &scene] {
          uint64_t i = 0;
          while (!stop_) {
            stream.render_and_publish(scene, pose_for(i % 100), 0.05 * static_cast<double>(i));
            ++i;
            std::this_thread::sleep_for(10ms);
          }
        }) {}
  ~PublisherThread() {
    stop_ = true;
    thread_.join();
  }

 private:
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

// A child process that is killed and reaped when the guard goes.
class Child {
 public:
  explicit Child(const std::vector<std::string>& args, const std::string& stdout_path = "") {
    std::vector<char*> argv;
    for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    if (!stdout_path.empty()) {
      posix_spawn_file_actions_addopen(&actions, 1, stdout_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    }
    if (posix_spawn(&pid_, argv[0], &actions, nullptr, argv.data(), environ) != 0) pid_ = -1;
    posix_spawn_file_actions_destroy(&actions);
  }
  ~Child() {
    if (pid_ > 0) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
  }
  pid_t pid() const { return pid_; }
  // Exit code, or -1 when it does not end within `limit` or died from a signal.
  int wait(std::chrono::milliseconds limit) {
    const auto end = std::chrono::steady_clock::now() + limit;
    while (std::chrono::steady_clock::now() < end) {
      int status = 0;
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
      }
      std::this_thread::sleep_for(10ms);
    }
    return -1;
  }

 private:
  pid_t pid_ = -1;
};

int count_files(const std::filesystem::path& dir, const std::string& ext) {
  int n = 0;
  if (!std::filesystem::exists(dir)) return 0;
  for (const auto& e : std::filesystem::directory_iterator(dir)) n += e.path().extension() == ext ? 1 : 0;
  return n;
}

TEST(StreamingTest, StartsRouDiInsideTheProcessAndSaysSo) {
  StreamingHost sut({small_camera("cam")});

  EXPECT_TRUE(sut.roudi_in_process());
  EXPECT_NE(sut.description().find("inside this process"), std::string::npos);
  EXPECT_TRUE(roudi_running());
  EXPECT_GE(sut.max_payload_bytes(), frame_payload_bytes(small_camera("cam")));
  EXPECT_THROW(StreamingHost({small_camera("other")}), std::logic_error);
}

TEST(StreamingTest, SubscriberReceivesIntactFramesInOrderWithoutACopy) {
  const CameraConfig config = small_camera("cam");
  StreamingHost host({config});
  CameraStream sut(host, config);
  FrameSubscriber sub("cam");
  const physics::SceneView scene = make_demo_scene(6);
  Renderer reference(config.lens, config.width_px, config.height_px, config.format);
  std::vector<uint8_t> expected(frame_bytes(config.format, config.width_px, config.height_px));
  FrameAnnotations expected_truth;
  ASSERT_TRUE(eventually([&] { return sut.has_subscribers(); }));

  for (uint64_t i = 0; i < 20; ++i) {
    ASSERT_TRUE(sut.render_and_publish(scene, pose_for(i), 0.05 * static_cast<double>(i)));
    auto frame = sub.try_take();
    ASSERT_TRUE(frame.has_value()) << i;
    const FrameHeader& h = frame->header();

    reference.render(scene, pose_for(i), h.sequence, expected.data(), &expected_truth);

    EXPECT_EQ(h.sequence, i);
    EXPECT_EQ(h.sim_time_ns, static_cast<int64_t>(i) * 50000000);
    EXPECT_EQ(h.format, static_cast<uint32_t>(PixelFormat::kYuyv));
    EXPECT_EQ(h.width_px, 160);
    EXPECT_EQ(h.height_px, 120);
    EXPECT_STREQ(h.camera_name, "cam");
    EXPECT_TRUE(frame_camera_pose(h).isApprox(pose_for(i), 1e-12));
    EXPECT_LE(h.render_start_mono_ns, h.publish_mono_ns);
    EXPECT_EQ(std::memcmp(frame->pixels(), expected.data(), expected.size()), 0) << i;
    ASSERT_NE(frame->annotations(), nullptr);
    EXPECT_EQ(frame->annotations()->count, expected_truth.count);
  }
  EXPECT_EQ(sub.stats().received, 20u);
  EXPECT_EQ(sub.stats().missed, 0u);
  EXPECT_EQ(sut.stats().published, 20u);
}

TEST(StreamingTest, StalledAndHoardingSubscribersDoNotStallThePublisher) {
  const CameraConfig config = small_camera("cam");
  StreamingHost host({config});
  CameraStream sut(host, config);
  FrameSubscriber stalled("cam");
  FrameSubscriber hoarder("cam");
  FrameSubscriber active("cam");
  const physics::SceneView scene = make_demo_scene(2);
  std::vector<Frame> hoard;
  ASSERT_TRUE(eventually([&] { return stalled.connected() && hoarder.connected() && active.connected(); }));

  bool all_published = true;
  for (uint64_t i = 0; i < 100; ++i) {
    all_published &= sut.render_and_publish(scene, pose_for(i), 0.05 * static_cast<double>(i));
    if (hoard.size() < 2) {
      if (auto f = hoarder.try_take()) hoard.push_back(std::move(*f));
    }
    auto f = active.try_take();
    ASSERT_TRUE(f.has_value());
    EXPECT_EQ(f->header().sequence, i);
  }

  EXPECT_TRUE(all_published);
  EXPECT_EQ(sut.stats().dropped, 0u);
  EXPECT_EQ(active.stats().missed, 0u);
  // The stalled subscriber's queue kept only the newest frames.
  auto oldest_kept = stalled.try_take();
  ASSERT_TRUE(oldest_kept.has_value());
  EXPECT_EQ(oldest_kept->header().sequence, 98u);
}

TEST(StreamingTest, SubscriberCanLeaveAndComeBack) {
  const CameraConfig config = small_camera("cam");
  StreamingHost host({config});
  CameraStream sut(host, config);
  const physics::SceneView scene = make_demo_scene(0);
  uint64_t first_sequence = 0;
  {
    FrameSubscriber sub("cam");
    ASSERT_TRUE(eventually([&] { return sut.has_subscribers(); }));
    ASSERT_TRUE(sut.render_and_publish(scene, pose_for(0), 0.0));
    auto f = sub.try_take();
    ASSERT_TRUE(f.has_value());
    first_sequence = f->header().sequence;
  }
  ASSERT_TRUE(eventually([&] { return !sut.has_subscribers(); }));
  EXPECT_FALSE(sut.render_and_publish(scene, pose_for(1), 0.05));  // nobody listens: nothing rendered

  FrameSubscriber again("cam");
  ASSERT_TRUE(eventually([&] { return sut.has_subscribers(); }));
  ASSERT_TRUE(sut.render_and_publish(scene, pose_for(2), 0.1));
  auto f = again.try_take();

  ASSERT_TRUE(f.has_value());
  EXPECT_EQ(f->header().sequence, first_sequence + 2);
  EXPECT_EQ(sut.stats().skipped_idle, 1u);
}

TEST(StreamingTest, CrashedSubscriberProcessIsReplacedByItsRestart) {
  const CameraConfig config = small_camera("cam");
  StreamingHost host({config});
  CameraStream sut(host, config);
  const physics::SceneView scene = make_demo_scene(2);
  const auto dir = std::filesystem::temp_directory_path() / ("doppel_camera_test_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  PublisherThread publisher(sut, scene);

  {
    Child crashing({DOPPEL_CAMERA_TOOL, "save", "--camera", "cam", "--count", "100000", "--out", (dir / "a").string()});
    ASSERT_GT(crashing.pid(), 0);
    ASSERT_TRUE(eventually([&] { return count_files(dir / "a", ".png") >= 2; }, 10000ms));
    ::kill(crashing.pid(), SIGKILL);
  }
  Child restarted({DOPPEL_CAMERA_TOOL, "save", "--camera", "cam", "--count", "3", "--out", (dir / "b").string()});
  const int exit_code = restarted.wait(15000ms);

  EXPECT_EQ(exit_code, 0);
  EXPECT_EQ(count_files(dir / "b", ".png"), 3);
  EXPECT_EQ(count_files(dir / "b", ".json"), 3);
  EXPECT_EQ(sut.stats().dropped, 0u);
  std::filesystem::remove_all(dir);
}

TEST(StreamingTest, PoolsSizedFromTheCamerasHoldEveryFormatsFrame) {
  // Each frame is larger than every general-purpose pool, so each must fit the pool made for its
  // camera, alignment of the payload included (a loan larger than every pool aborts the process).
  std::vector<CameraConfig> configs;
  for (PixelFormat format : kAllPixelFormats) {
    CameraConfig c = small_camera(std::string("fmt_") + std::string(to_string(format)));
    c.width_px = 640;
    c.height_px = 480;
    c.format = format;
    c.lens = pinhole_from_hfov(640, 480, 90.0);
    configs.push_back(c);
  }
  StreamingOptions options;
  options.chunks_per_camera = 4;
  StreamingHost host(configs, options);
  const physics::SceneView scene = make_demo_scene(0);

  for (const CameraConfig& c : configs) {
    CameraStream sut(host, c);
    FrameSubscriber sub(c.name);
    ASSERT_TRUE(eventually([&] { return sut.has_subscribers(); }));
    for (int i = 0; i < 6; ++i) {
      ASSERT_TRUE(sut.render_and_publish(scene, pose_for(0), 0.0)) << c.name << " frame " << i;
      auto f = sub.try_take();
      ASSERT_TRUE(f.has_value()) << c.name;
      EXPECT_EQ(f->header().pixel_bytes, frame_bytes(c.format, 640, 480));
    }
  }
}

std::string read_file(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(StreamingTest, ToolListsCamerasAndReportsStats) {
  const CameraConfig config = small_camera("tool_cam");
  StreamingHost host({config});
  CameraStream sut(host, config);
  const physics::SceneView scene = make_demo_scene(0);
  PublisherThread publisher(sut, scene);
  const std::string list_out = testing::TempDir() + "doppel_camera_list.txt";
  const std::string stats_out = testing::TempDir() + "doppel_camera_stats.txt";

  Child list({DOPPEL_CAMERA_TOOL, "list"}, list_out);
  const int list_code = list.wait(15000ms);
  Child stats({DOPPEL_CAMERA_TOOL, "stats", "--camera", "tool_cam", "--seconds", "1"}, stats_out);
  const int stats_code = stats.wait(15000ms);
  Child usage({DOPPEL_CAMERA_TOOL, "save", "--count", "0"});
  const int usage_code = usage.wait(15000ms);

  EXPECT_EQ(list_code, 0);
  EXPECT_NE(read_file(list_out).find("tool_cam"), std::string::npos) << read_file(list_out);
  EXPECT_NE(read_file(list_out).find("160x120"), std::string::npos);
  EXPECT_EQ(stats_code, 0);
  EXPECT_NE(read_file(stats_out).find("latency publish->held"), std::string::npos) << read_file(stats_out);
  EXPECT_EQ(usage_code, 2);
  std::filesystem::remove(list_out);
  std::filesystem::remove(stats_out);
}

TEST(StreamingTest, CamerasAreListedWithTheirFormat) {
  const CameraConfig a = small_camera("left");
  CameraConfig b = small_camera("right");
  b.format = PixelFormat::kBayerBggr;
  StreamingHost host({a, b});
  CameraStream left(host, a);
  CameraStream right(host, b);

  const auto sut = list_cameras(2.0);

  ASSERT_EQ(sut.size(), 2u);
  EXPECT_STREQ(sut[0].name, "left");
  EXPECT_STREQ(sut[1].name, "right");
  EXPECT_EQ(sut[1].format, static_cast<uint32_t>(PixelFormat::kBayerBggr));
  EXPECT_EQ(sut[1].width_px, 160);
  EXPECT_EQ(sut[0].pid, ::getpid());
}

TEST(StreamingTest, CameraThatDoesNotFitThePoolsOrRepeatsANameIsRefused) {
  const CameraConfig config = small_camera("cam");
  StreamingHost host({config});
  CameraStream first(host, config);
  CameraConfig big = small_camera("big");
  big.width_px = 4096;
  big.height_px = 3072;
  big.format = PixelFormat::kRgb24;
  big.lens = pinhole_from_hfov(4096, 3072, 60.0);

  EXPECT_THROW(CameraStream(host, big), std::runtime_error);
  EXPECT_TRUE(eventually([&] {
    try {
      CameraStream twin(host, config);
      return false;
    } catch (const std::runtime_error&) {
      return true;
    }
  }));
}

TEST(StreamingTest, NoiseCanBeChangedWhileStreaming) {
  const CameraConfig config = small_camera("cam");
  StreamingHost host({config});
  CameraStream sut(host, config);
  FrameSubscriber sub("cam");
  const physics::SceneView scene = make_demo_scene(0);
  ASSERT_TRUE(eventually([&] { return sut.has_subscribers(); }));
  std::vector<std::vector<uint8_t>> frames;
  NoiseConfig noisy;
  noisy.salt_pepper_fraction = 0.05;
  noisy.vignetting = 0.3;

  for (int i = 0; i < 3; ++i) {
    if (i == 1) sut.set_noise(noisy);
    if (i == 2) sut.set_noise(NoiseConfig{});
    ASSERT_TRUE(sut.render_and_publish(scene, pose_for(0), 0.0));
    auto f = sub.try_take();
    ASSERT_TRUE(f.has_value());
    frames.emplace_back(f->pixels(), f->pixels() + f->header().pixel_bytes);
  }

  EXPECT_NE(frames[0], frames[1]);
  EXPECT_EQ(frames[0], frames[2]);
  EXPECT_THROW(sut.set_noise(NoiseConfig{.gaussian_sigma = -1.0}), std::invalid_argument);
}

}  // namespace
}  // namespace doppel::camera
