#include "port_table.h"

#include <sys/syscall.h>
#include <time.h>
#include <unistd.h>

#include "base/pty_handover.h"

namespace doppel::shim {
namespace {

Port g_ports[kMaxMappings];
std::size_t g_port_count = 0;
std::atomic<uint8_t> g_fd_port[kMaxFds];  // 0 = not Doppel's, else port index + 1

int64_t monotonic_ns() noexcept {
  timespec t{};
  ::syscall(SYS_clock_gettime, CLOCK_MONOTONIC, &t);  // not through this library's clock_gettime (lockstep)
  return static_cast<int64_t>(t.tv_sec) * 1'000'000'000 + t.tv_nsec;
}

}  // namespace

Port& port_slot(std::size_t index) noexcept { return g_ports[index]; }
void set_port_count(std::size_t count) noexcept { g_port_count = count; }
std::size_t port_count() noexcept { return g_port_count; }

int port_index_of_fd(int fd) noexcept {
  if (fd < 0 || fd >= kMaxFds) return -1;
  return static_cast<int>(g_fd_port[fd].load(std::memory_order_acquire)) - 1;
}

Port* port_of_fd(int fd) noexcept {
  const int port = port_index_of_fd(fd);
  return port < 0 ? nullptr : &g_ports[port];
}

bool track(int fd, int port) noexcept {
  if (fd >= kMaxFds) return false;
  if (fd >= 0) g_fd_port[fd].store(static_cast<uint8_t>(port + 1), std::memory_order_release);
  return true;
}

void copy_fd(int from, int to) noexcept {
  if (to < 0 || to >= kMaxFds) return;
  const uint8_t p = (from >= 0 && from < kMaxFds) ? g_fd_port[from].load(std::memory_order_acquire) : 0;
  g_fd_port[to].store(p, std::memory_order_release);
}

void untrack(int fd) noexcept {
  if (fd >= 0 && fd < kMaxFds) g_fd_port[fd].store(0, std::memory_order_release);
}

const char* port_pts(int port) noexcept { return port >= 0 && static_cast<std::size_t>(port) < g_port_count ? g_ports[port].pts : ""; }

uint64_t handover_mark(int port) noexcept {
  if (port < 0 || static_cast<std::size_t>(port) >= g_port_count || g_ports[port].received == nullptr) return 0;
  return g_ports[port].received->load(std::memory_order_acquire);
}

void await_handover(int port, uint64_t mark, std::size_t written) noexcept {
  if (port < 0 || static_cast<std::size_t>(port) >= g_port_count || written == 0) return;
  Port& p = g_ports[port];
  if (p.received == nullptr) return;
  // Doppel's count once it has these bytes: after everything this process wrote before (expected)
  // or, if that is behind, after what doppel had read before this write (mark).
  uint64_t before = p.expected.load(std::memory_order_relaxed);
  uint64_t target = 0;
  do {
    target = (before > mark ? before : mark) + written;
  } while (!p.expected.compare_exchange_weak(before, target, std::memory_order_relaxed));
  const int64_t give_up = monotonic_ns() + kHandoverLimitNs;
  const timespec pause{0, kHandoverPauseNs};
  while (p.received->load(std::memory_order_acquire) < target) {
    if (monotonic_ns() > give_up) {
      // Doppel is not reading (stopped, or stalled): count from what it has, not from a backlog.
      p.expected.store(p.received->load(std::memory_order_acquire), std::memory_order_relaxed);
      return;
    }
    ::syscall(SYS_clock_nanosleep, CLOCK_MONOTONIC, 0, &pause, nullptr);  // a sleep: this CPU is free meanwhile
  }
}

}  // namespace doppel::shim
