// Delivery latency of one camera frame, publish -> subscriber holds it, measured in one run for
//   iceoryx with a busy-polling subscriber, iceoryx with a WaitSet subscriber, and the same bytes
//   written to a Unix domain stream socket (what the thesis used) and read by a blocking reader,
// at 320x240, 640x480, 1280x720 and 1920x1080 YUYV. RouDi runs inside this process. Each iteration
// publishes one frame and waits for it; the reported time is the delivery latency only (rendering
// happens before the clock starts; the iceoryx frames are loaned and published unrendered, the socket
// frame is rendered once before the loop). Counters: p50_us, p99_us.
#include <benchmark/benchmark.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <cstring>
#include <iostream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "base/monotonic_clock.h"
#include "camera/client.h"
#include "camera/renderer.h"
#include "camera/streaming.h"
#include "demo_scene.h"

namespace {

using namespace doppel::camera;

struct Size {
  int w, h;
};
constexpr Size kSizes[] = {{320, 240}, {640, 480}, {1280, 720}, {1920, 1080}};

CameraConfig camera_for(Size s) {
  CameraConfig c;
  c.name = "bench_" + std::to_string(s.w) + "x" + std::to_string(s.h);
  c.width_px = s.w;
  c.height_px = s.h;
  c.format = PixelFormat::kYuyv;
  c.lens = pinhole_from_hfov(s.w, s.h, 90.0);
  c.mount.kind = CameraMount::Kind::kWorld;
  c.annotations = false;
  return c;
}

std::unique_ptr<StreamingHost> g_host;
std::vector<std::unique_ptr<CameraStream>> g_streams;

void report(benchmark::State& state, std::vector<double>& samples_us) {
  if (samples_us.empty()) return;
  std::sort(samples_us.begin(), samples_us.end());
  state.counters["p50_us"] = samples_us[samples_us.size() / 2];
  state.counters["p99_us"] = samples_us[static_cast<size_t>(0.99 * static_cast<double>(samples_us.size() - 1))];
  state.counters["bytes"] = static_cast<double>(frame_bytes(PixelFormat::kYuyv, kSizes[state.range(0)].w,
                                                            kSizes[state.range(0)].h));
}

void BM_Iceoryx(benchmark::State& state, bool waitset) {
  CameraStream& stream = *g_streams[state.range(0)];
  std::atomic<int64_t> latency_ns{-1};
  std::atomic<bool> stop{false};
  std::atomic<bool> connected{false};
  std::mutex mutex;
  std::condition_variable cv;
  std::thread subscriber([&] {
    FrameSubscriber sub(stream.config().name);
    while (!sub.connected()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    connected = true;
    while (!stop.load(std::memory_order_relaxed)) {
      std::optional<Frame> frame = waitset ? sub.wait_take(0.05) : sub.try_take();
      if (!frame) continue;
      const int64_t held = doppel::monotonic_now_ns();
      {
        std::lock_guard<std::mutex> lock(mutex);
        latency_ns.store(held - frame->header().publish_mono_ns, std::memory_order_release);
      }
      cv.notify_one();
    }
  });
  while (!connected.load()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  std::vector<double> samples_us;
  double t = 0.0;
  for (auto _ : state) {
    int64_t ns = -1;
    // A frame published while the subscription is still settling can reach nobody: publish again.
    while (ns < 0) {
      latency_ns.store(-1, std::memory_order_relaxed);
      // The pixels are not touched: this measures delivery, not rendering (zero copy either way).
      if (FrameHeader* frame = stream.loan_frame(Eigen::Isometry3d::Identity(), t += 0.05)) {
        stream.publish_frame(frame);
      }
      // Sleep rather than spin: on two cores a spinning waiter would steal the polling
      // subscriber's core and inflate what is measured.
      std::unique_lock<std::mutex> lock(mutex);
      cv.wait_for(lock, std::chrono::milliseconds(200), [&] { return latency_ns.load() >= 0; });
      ns = latency_ns.load();
    }
    state.SetIterationTime(1e-9 * static_cast<double>(ns));
    samples_us.push_back(1e-3 * static_cast<double>(ns));
  }
  stop = true;
  subscriber.join();
  report(state, samples_us);
}

// Moves all `n` bytes through `io` (::read or ::write), resuming after short transfers; false on an
// error or the end of the stream.
template <class Io, class Byte>
bool transfer_all(Io io, int fd, Byte* p, size_t n) {
  while (n > 0) {
    const ssize_t k = io(fd, p, n);
    if (k <= 0) return false;
    p += k;
    n -= static_cast<size_t>(k);
  }
  return true;
}

void BM_UnixSocket(benchmark::State& state) {
  const CameraConfig config = camera_for(kSizes[state.range(0)]);
  Renderer renderer(config.lens, config.width_px, config.height_px, config.format);
  const auto scene = make_demo_scene(0);
  // The frame travels as header + pixels, as the subscriber would need them.
  const size_t bytes = sizeof(FrameHeader) + frame_bytes(config.format, config.width_px, config.height_px);
  std::vector<uint8_t> frame(bytes);
  std::vector<uint8_t> received(bytes);
  int fds[2];
  if (::socketpair(AF_UNIX, SOCK_STREAM, 0, fds) != 0) {
    state.SkipWithError("socketpair failed");
    return;
  }
  std::atomic<int64_t> latency_ns{-1};
  std::thread reader([&] {
    while (transfer_all(::read, fds[1], received.data(), bytes)) {
      const int64_t held = doppel::monotonic_now_ns();
      int64_t sent = 0;
      std::memcpy(&sent, received.data(), sizeof(sent));
      latency_ns.store(held - sent, std::memory_order_release);
      latency_ns.notify_one();
    }
  });
  std::vector<double> samples_us;
  renderer.render(scene, Eigen::Isometry3d::Identity(), 0, frame.data() + sizeof(FrameHeader), nullptr);
  for (auto _ : state) {
    latency_ns.store(-1, std::memory_order_relaxed);
    const int64_t sent = doppel::monotonic_now_ns();
    std::memcpy(frame.data(), &sent, sizeof(sent));
    if (!transfer_all(::write, fds[0], frame.data(), bytes)) {
      state.SkipWithError("write failed");
      break;
    }
    int64_t ns = -1;
    while ((ns = latency_ns.load(std::memory_order_acquire)) < 0) latency_ns.wait(-1, std::memory_order_acquire);
    state.SetIterationTime(1e-9 * static_cast<double>(ns));
    samples_us.push_back(1e-3 * static_cast<double>(ns));
  }
  ::shutdown(fds[0], SHUT_RDWR);
  ::close(fds[0]);
  reader.join();
  ::close(fds[1]);
  report(state, samples_us);
}

void register_all() {
  for (int i = 0; i < static_cast<int>(std::size(kSizes)); ++i) {
    const std::string size = std::to_string(kSizes[i].w) + "x" + std::to_string(kSizes[i].h);
    benchmark::RegisterBenchmark(("latency/iceoryx_poll/" + size).c_str(), BM_Iceoryx, false)
        ->Arg(i)->UseManualTime()->Unit(benchmark::kMicrosecond);
    benchmark::RegisterBenchmark(("latency/iceoryx_waitset/" + size).c_str(), BM_Iceoryx, true)
        ->Arg(i)->UseManualTime()->Unit(benchmark::kMicrosecond);
    benchmark::RegisterBenchmark(("latency/unix_socket/" + size).c_str(), BM_UnixSocket)
        ->Arg(i)->UseManualTime()->Unit(benchmark::kMicrosecond);
  }
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  std::vector<CameraConfig> configs;
  for (Size s : kSizes) configs.push_back(camera_for(s));
  StreamingOptions options;
  options.chunks_per_camera = 8;
  try {
    g_host = std::make_unique<StreamingHost>(configs, options);
    for (const CameraConfig& c : configs) g_streams.push_back(std::make_unique<CameraStream>(*g_host, c));
  } catch (const std::exception& e) {
    std::cerr << "camera_latency: " << e.what() << "\n";
    return 1;
  }
  std::cerr << g_host->description() << "\n";
  register_all();
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  g_streams.clear();
  g_host.reset();
  return 0;
}
