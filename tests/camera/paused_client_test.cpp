// Issue 16: a camera client stopped for longer than iceoryx's keep-alive timeout (1.5 s: SIGSTOP, a
// debugger, a suspended laptop) aborted with POPO__CHUNK_LOCKING_ERROR when it continued, and every
// killed client left its socket and lock file in /tmp. The client here is the real doppel-camera.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/file.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "camera/client.h"
#include "camera/renderer.h"
#include "camera/streaming.h"

extern char** environ;

namespace doppel::camera {
namespace {

using namespace std::chrono_literals;

CameraConfig small_camera(const std::string& name) {
  CameraConfig c;
  c.name = name;
  c.width_px = 160;
  c.height_px = 120;
  c.format = PixelFormat::kUyvy;
  c.lens = pinhole_from_hfov(160, 120, 90.0);
  c.mount.kind = CameraMount::Kind::kWorld;
  return c;
}

std::string read_file(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(PausedClient, ASubscriberStoppedForThreeSecondsKeepsReceivingAfterContinue) {
  const CameraConfig config = small_camera("pause_cam");
  StreamingHost host({config});
  ASSERT_TRUE(host.roudi_in_process()) << "needs doppel's own RouDi (another RouDi runs on this machine)";
  CameraStream stream(host, config);
  const physics::SceneView scene = make_demo_scene(0);
  std::atomic<bool> stop{false};
  std::atomic<uint64_t> published{0};
  std::thread camera([&] {
    for (uint64_t i = 0; !stop; ++i) {
      if (stream.render_and_publish(scene, Eigen::Isometry3d::Identity(), 0.01 * static_cast<double>(i))) ++published;
      std::this_thread::sleep_for(10ms);
    }
  });

  const std::string out = ::testing::TempDir() + "doppel_camera_paused.txt";
  std::vector<std::string> args = {DOPPEL_CAMERA_TOOL, "stats", "--camera", "pause_cam", "--seconds", "7"};
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  pid_t client = -1;
  ASSERT_EQ(posix_spawn(&client, argv[0], &actions, nullptr, argv.data(), environ), 0);
  posix_spawn_file_actions_destroy(&actions);

  std::this_thread::sleep_for(1500ms);
  ::kill(client, SIGSTOP);
  const uint64_t published_before_stop = published.load();
  std::this_thread::sleep_for(3000ms);  // twice iceoryx's keep-alive timeout
  ::kill(client, SIGCONT);
  int status = 0;
  for (int i = 0; i < 1500 && ::waitpid(client, &status, WNOHANG) == 0; ++i) std::this_thread::sleep_for(10ms);
  if (::waitpid(client, &status, WNOHANG) == 0) {
    ::kill(client, SIGKILL);
    ::waitpid(client, &status, 0);
    ADD_FAILURE() << "doppel-camera did not end";
  }
  stop = true;
  camera.join();
  const std::string said = read_file(out);
  std::filesystem::remove(out);

  ASSERT_TRUE(WIFEXITED(status)) << "signal " << (WIFSIGNALED(status) ? WTERMSIG(status) : 0) << ": " << said;
  EXPECT_EQ(WEXITSTATUS(status), 0) << said;
  unsigned long long frames = 0;
  ASSERT_EQ(std::sscanf(said.c_str() + said.find("frames "), "frames %llu", &frames), 1) << said;
  // Its queue holds 2 frames over the pause; more than that came after SIGCONT.
  EXPECT_GT(frames, published_before_stop + 20) << said;
  EXPECT_EQ(said.find("Log level"), std::string::npos) << said;
  EXPECT_EQ(said.find("Keepalive"), std::string::npos) << said;
}

// A unix socket at `path`, as iceoryx leaves one behind.
void make_socket(const std::string& path) {
  const int fd = ::socket(AF_UNIX, SOCK_STREAM, 0);
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  std::strncpy(address.sun_path, path.c_str(), sizeof(address.sun_path) - 1);
  ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)), 0) << path;
  ::close(fd);
}

pid_t a_pid_that_is_gone() {
  const pid_t child = ::fork();
  if (child == 0) ::_exit(0);
  ::waitpid(child, nullptr, 0);
  return child;
}

TEST(StaleClientFiles, OnlyThoseOfGoneProcessesWithoutLockHoldersAreRemoved) {
  char dir_template[] = "/tmp/doppel-stale-XXXXXX";
  const std::string dir = ::mkdtemp(dir_template);
  const std::string gone = dir + "/app-" + std::to_string(a_pid_that_is_gone());
  const std::string alive = dir + "/app-" + std::to_string(::getpid());
  const std::string other_app = dir + "/other-" + std::to_string(a_pid_that_is_gone());
  // Its pid is gone, but someone holds the lock (a client in another pid namespace, say).
  const std::string held = dir + "/app-" + std::to_string(a_pid_that_is_gone()) + "9";
  for (const std::string& path : {gone, alive, other_app, held}) {
    make_socket(path);
    std::ofstream(path + ".lock");
  }
  const int holder = ::open((held + ".lock").c_str(), O_RDONLY);
  ASSERT_EQ(::flock(holder, LOCK_EX), 0);

  const int removed = remove_stale_client_files("app", dir);

  EXPECT_EQ(removed, 2);
  EXPECT_FALSE(std::filesystem::exists(gone));
  EXPECT_FALSE(std::filesystem::exists(gone + ".lock"));
  EXPECT_TRUE(std::filesystem::exists(alive));
  EXPECT_TRUE(std::filesystem::exists(other_app));
  EXPECT_TRUE(std::filesystem::exists(held));
  ::close(holder);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace doppel::camera
