#pragma once
// The floor of any pty-based bus: a thread that echoes every byte back through a pseudo-terminal,
// measured with the same client code as Doppel, so the ratio between the two is Doppel's cost.

#include <fcntl.h>
#include <pthread.h>
#include <sched.h>
#include <poll.h>
#include <pty.h>
#include <unistd.h>

#include <atomic>
#include <stdexcept>
#include <string>
#include <thread>

namespace doppel::bench {

class PtyEcho {
 public:
  // rt_priority > 0: the echo thread runs SCHED_FIFO at that priority, like the server it stands for.
  explicit PtyEcho(int rt_priority = 0) {
    int slave = -1;
    if (openpty(&master_, &slave, nullptr, nullptr, nullptr) != 0) {
      throw std::runtime_error("openpty failed");
    }
    slave_path_ = ttyname(slave);
    ::close(slave);
    fcntl(master_, F_SETFL, fcntl(master_, F_GETFL) | O_NONBLOCK);
    thread_ = std::thread([this, rt_priority] {
      if (rt_priority > 0) {
        sched_param param{};
        param.sched_priority = rt_priority;
        pthread_setschedparam(pthread_self(), SCHED_FIFO, &param);
      }
      run();
    });
  }
  ~PtyEcho() {
    stop_ = true;
    thread_.join();
    ::close(master_);
  }
  PtyEcho(const PtyEcho&) = delete;
  PtyEcho& operator=(const PtyEcho&) = delete;

  const std::string& path() const { return slave_path_; }

 private:
  void run() {
    unsigned char buffer[4096];
    while (!stop_) {
      pollfd p{master_, POLLIN, 0};
      if (::poll(&p, 1, 50) <= 0) {
        continue;
      }
      if ((p.revents & POLLHUP) != 0) {
        usleep(1000);  // no client connected
        continue;
      }
      ssize_t n = ::read(master_, buffer, sizeof(buffer));
      for (ssize_t done = 0; n > 0 && done < n;) {
        ssize_t w = ::write(master_, buffer + done, static_cast<size_t>(n - done));
        done += w > 0 ? w : 0;
      }
    }
  }

  int master_ = -1;
  std::string slave_path_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace doppel::bench
