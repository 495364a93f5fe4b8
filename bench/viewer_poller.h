#pragma once
// The web viewer's traffic without a browser: a thread that polls doppel's API at the rates the
// viewer page does (/api/scene at 20 Hz, /api/state at 10 Hz, /api/buses at 2 Hz, a robot camera's
// still about 3 times a second), so that a benchmark measures what serving an open viewer costs.
// Shared by viewer_load and default_latency.

#include <httplib.h>

#include <atomic>
#include <chrono>
#include <string>
#include <thread>

namespace doppel::bench {

// Polls the API on 127.0.0.1:`port` at the page's rates until destroyed.
class Poller {
 public:
  // `camera`: the robot camera whose still the page shows ("" = none).
  Poller(int port, std::string camera) : thread_([this, port, camera] {
    httplib::Client client("127.0.0.1", port);
    client.set_keep_alive(true);
    const auto start = std::chrono::steady_clock::now();
    for (int tick = 0; !stop_.load(); ++tick) {  // 100 ms ticks of the page's timers
      for (int k = 0; k < 2; ++k) {
        if (!client.Get("/api/scene")) ++failures;
        if (k == 0 && !client.Get("/api/state")) ++failures;
        if (k == 0 && tick % 5 == 0 && !client.Get("/api/buses")) ++failures;
        if (k == 1 && tick % 3 == 0 && !camera.empty() && !client.Get("/api/camera/" + camera)) ++failures;
        std::this_thread::sleep_until(start + std::chrono::milliseconds(100 * tick + 50 * (k + 1)));
      }
    }
  }) {}
  ~Poller() {
    stop_ = true;
    thread_.join();
  }
  Poller(const Poller&) = delete;
  Poller& operator=(const Poller&) = delete;
  std::atomic<int> failures{0};

 private:
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace doppel::bench
