// Frame latency and CPU per frame of a vision program reading Doppel's camera through V4L2 under
// the shim (/dev/video0, MMAP buffers, poll + DQBUF) against one reading the same frames through
// the iceoryx client (FrameSubscriber::wait_take), side by side in one run (docs/benchmarks.md).
//
// This process is RouDi and the camera: it renders the demo scene at --fps for each size (YUYV);
// two child processes (this executable again) subscribe at the same time. Latency is "render done"
// (the frame header's publish stamp, CLOCK_MONOTONIC; the V4L2 buffer carries it as its timestamp)
// to the moment the reader holds the frame (wait_take or DQBUF returned). CPU per frame is the
// reader process's user + system time (the V4L2 module's copy thread included) over the frames.
#include <fcntl.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <signal.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "camera/camera_config.h"
#include "camera/client.h"
#include "camera/streaming.h"
#include "demo_scene.h"
#include "latency_stats.h"

namespace {

using doppel::bench::percentiles;

int64_t mono_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
}

double cpu_us() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return (u.ru_utime.tv_sec + u.ru_stime.tv_sec) * 1e6 + u.ru_utime.tv_usec + u.ru_stime.tv_usec;
}

void report(const char* path, int width, int height, const std::vector<double>& latency_us, double cpu_per_frame_us,
            uint64_t gaps) {
  const auto p = percentiles(latency_us);
  std::printf("%-6s %4dx%-4d frames %4zu  latency p50 %7.1f us  p99 %7.1f us  max %7.1f us  CPU %6.1f us/frame  gaps %llu\n",
              path, width, height, p.count, p.p50, p.p99, p.max, cpu_per_frame_us, static_cast<unsigned long long>(gaps));
  std::fflush(stdout);
}

int read_iceoryx(const std::string& camera, int width, int height, int frames) {
  doppel::camera::connect_client("bench-iox");
  doppel::camera::FrameSubscriber sub(camera);
  std::vector<double> latency;
  double cpu0 = 0;
  uint64_t last = 0, gaps = 0;
  while (static_cast<int>(latency.size()) < frames) {
    auto frame = sub.wait_take(5.0);
    if (!frame) return 1;
    const int64_t now = mono_ns();
    if (cpu0 == 0) {
      cpu0 = cpu_us();  // from the first frame on: the subscription's set-up is not per frame
      last = frame->header().sequence;
      continue;
    }
    gaps += frame->header().sequence - last - 1;
    last = frame->header().sequence;
    latency.push_back(static_cast<double>(now - frame->header().publish_mono_ns) / 1e3);
  }
  report("iceoryx", width, height, latency, (cpu_us() - cpu0) / frames, gaps);
  return 0;
}

int read_v4l2(int width, int height, int frames) {
  const int fd = ::open("/dev/video0", O_RDWR | O_NONBLOCK);
  if (fd < 0) return std::perror("open /dev/video0"), 1;
  v4l2_format f{};
  f.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  f.fmt.pix.width = static_cast<uint32_t>(width);
  f.fmt.pix.height = static_cast<uint32_t>(height);
  f.fmt.pix.pixelformat = V4L2_PIX_FMT_YUYV;
  if (ioctl(fd, VIDIOC_S_FMT, &f) != 0) return std::perror("S_FMT"), 1;
  v4l2_requestbuffers rb{};
  rb.count = 4;
  rb.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  rb.memory = V4L2_MEMORY_MMAP;
  if (ioctl(fd, VIDIOC_REQBUFS, &rb) != 0) return std::perror("REQBUFS"), 1;
  for (uint32_t i = 0; i < rb.count; ++i) {
    v4l2_buffer b{};
    b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    b.memory = V4L2_MEMORY_MMAP;
    b.index = i;
    if (ioctl(fd, VIDIOC_QUERYBUF, &b) != 0) return std::perror("QUERYBUF"), 1;
    if (mmap(nullptr, b.length, PROT_READ | PROT_WRITE, MAP_SHARED, fd, b.m.offset) == MAP_FAILED) return std::perror("mmap"), 1;
    if (ioctl(fd, VIDIOC_QBUF, &b) != 0) return std::perror("QBUF"), 1;
  }
  int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (ioctl(fd, VIDIOC_STREAMON, &type) != 0) return std::perror("STREAMON"), 1;
  std::vector<double> latency;
  double cpu0 = 0;
  uint32_t last = 0;
  uint64_t gaps = 0;
  while (static_cast<int>(latency.size()) < frames) {
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, 5000) <= 0) return std::fprintf(stderr, "no frame within 5 s\n"), 1;
    v4l2_buffer b{};
    b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    b.memory = V4L2_MEMORY_MMAP;
    if (ioctl(fd, VIDIOC_DQBUF, &b) != 0) continue;
    const int64_t now = mono_ns();
    const int64_t stamp = static_cast<int64_t>(b.timestamp.tv_sec) * 1000000000 + b.timestamp.tv_usec * 1000;
    if (cpu0 == 0) {
      cpu0 = cpu_us();
      last = b.sequence;
    } else {
      gaps += b.sequence - last - 1;
      last = b.sequence;
      latency.push_back(static_cast<double>(now - stamp) / 1e3);
    }
    ioctl(fd, VIDIOC_QBUF, &b);
  }
  report("v4l2", width, height, latency, (cpu_us() - cpu0) / frames, gaps);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"V4L2 (under the shim) vs iceoryx client: frame latency and CPU per frame", "v4l2_latency"};
  int frames = 300;
  double fps = 60;
  std::string reader;
  std::string camera;
  int width = 0, height = 0;
  app.add_option("--frames", frames, "frames measured per reader and size");
  app.add_option("--fps", fps, "camera rate");
  app.add_option("--reader", reader)->group("");  // the child processes
  app.add_option("--camera", camera)->group("");
  app.add_option("--width", width)->group("");
  app.add_option("--height", height)->group("");
  CLI11_PARSE(app, argc, argv);
  if (reader == "iceoryx") return read_iceoryx(camera, width, height, frames);
  if (reader == "v4l2") return read_v4l2(width, height, frames);

  using namespace doppel::camera;
  std::vector<CameraConfig> cams;
  for (const auto& [w, h] : {std::pair{320, 240}, std::pair{640, 480}}) {
    CameraConfig c;
    c.name = "bench" + std::to_string(w);
    c.width_px = w;
    c.height_px = h;
    c.fps = fps;
    c.lens = pinhole_from_hfov(w, h, 58.0);
    c.mount.kind = CameraMount::Kind::kWorld;
    cams.push_back(c);
  }
  StreamingHost host(cams);
  std::vector<std::unique_ptr<CameraStream>> streams;
  for (const auto& c : cams) streams.push_back(std::make_unique<CameraStream>(host, c));
  const auto scene = make_demo_scene(2);
  Eigen::Isometry3d X_WC = Eigen::Isometry3d::Identity();
  X_WC.linear() << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  X_WC.translation() = Eigen::Vector3d(-1.0, 0.2, 0.5);
  std::printf("v4l2_latency: %d frames per reader at %.0f fps; both readers subscribed at once\n", frames, fps);
  std::fflush(stdout);
  for (std::size_t k = 0; k < cams.size(); ++k) {
    const CameraConfig& c = cams[k];
    std::vector<pid_t> children;
    for (const std::string r : {"iceoryx", "v4l2"}) {
      const pid_t pid = fork();
      if (pid == 0) {
        if (r == "v4l2") {
          setenv("LD_PRELOAD", SHIM_LIBRARY, 1);
          setenv("DOPPEL_SHIM_CAMERAS", ("/dev/video0=" + c.name).c_str(), 1);
          setenv("DOPPEL_SHIM_V4L2", V4L2_MODULE, 1);
        }
        const std::string n = std::to_string(frames), w = std::to_string(c.width_px), h = std::to_string(c.height_px);
        execl("/proc/self/exe", "v4l2_latency", "--reader", r.c_str(), "--camera", c.name.c_str(), "--frames", n.c_str(),
              "--width", w.c_str(), "--height", h.c_str(), static_cast<char*>(nullptr));
        _exit(127);
      }
      children.push_back(pid);
    }
    const auto period = std::chrono::duration<double>(1.0 / fps);
    auto next = std::chrono::steady_clock::now();
    int status = 0;
    std::size_t running = children.size();
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(120);
    for (uint64_t i = 0; running > 0 && std::chrono::steady_clock::now() < give_up; ++i) {
      streams[k]->render_and_publish(scene, X_WC, static_cast<double>(i) / fps);
      next += std::chrono::duration_cast<std::chrono::steady_clock::duration>(period);
      std::this_thread::sleep_until(next);
      for (pid_t& pid : children) {
        if (pid > 0 && waitpid(pid, &status, WNOHANG) == pid) {
          if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) std::fprintf(stderr, "a reader failed (status %d)\n", status);
          pid = -1;
          --running;
        }
      }
    }
    for (pid_t pid : children) {
      if (pid > 0) kill(pid, SIGKILL), waitpid(pid, &status, 0);
    }
  }
  return 0;
}
