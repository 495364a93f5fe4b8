// The lockstep part of libdoppel_shim.so (docs/lockstep.md): with DOPPEL_LOCKSTEP naming doppel's
// clock file (doppel-run --lockstep), the program's clocks read simulation time and its waits
// (sleeps, timeouts, timers, condition variables, semaphores, reads of a bus that has nothing)
// park the thread in the clock file until doppel wakes it. doppel advances simulation time only
// while every registered thread waits. Without the variable every call passes straight through.
//
// Rules kept here as in shim.cpp: no lock, no C++ runtime, errno as libc leaves it on pass-through;
// the only allocation is one small block per pthread_create.
#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <pthread.h>
#include <semaphore.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/epoll.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <sys/select.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <sys/time.h>
#include <sys/timerfd.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include <atomic>
#include <cstdint>

#include "lockstep/clock_file.h"
#include "lockstep/futex.h"
#include "lockstep_shim.h"
#include "port_table.h"
#include "v4l2_shim.h"

#define SHIM_EXPORT extern "C" __attribute__((visibility("default")))

namespace doppel::shim {
namespace {

using lockstep::Call;
using lockstep::ClockFile;
using lockstep::kNever;
using lockstep::ThreadSlot;

constexpr int64_t kSecond = 1'000'000'000;
constexpr int64_t kSettleWallNs = 1'000'000'000;  // how long a read waits for bytes doppel delivered to cross the pty
constexpr int64_t kSliceWallNs = 1'000'000;       // wall-time slices of condition-variable and semaphore waits
constexpr uint64_t kSpinReads = 1000;             // clock reads in a row taken as a busy wait for time to pass

struct Real {
  int (*clock_gettime)(clockid_t, struct timespec*);
  int (*gettimeofday)(struct timeval*, void*);
  time_t (*time)(time_t*);
  int (*nanosleep)(const struct timespec*, struct timespec*);
  int (*clock_nanosleep)(clockid_t, int, const struct timespec*, struct timespec*);
  int (*usleep)(useconds_t);
  unsigned (*sleep)(unsigned);
  int (*poll)(struct pollfd*, nfds_t, int);
  int (*ppoll)(struct pollfd*, nfds_t, const struct timespec*, const sigset_t*);
  int (*select)(int, fd_set*, fd_set*, fd_set*, struct timeval*);
  int (*pselect)(int, fd_set*, fd_set*, fd_set*, const struct timespec*, const sigset_t*);
  int (*epoll_wait)(int, struct epoll_event*, int, int);
  int (*epoll_pwait)(int, struct epoll_event*, int, int, const sigset_t*);
  ssize_t (*read)(int, void*, size_t);
  ssize_t (*write)(int, const void*, size_t);
  ssize_t (*recv)(int, void*, size_t, int);
  ssize_t (*recvfrom)(int, void*, size_t, int, struct sockaddr*, socklen_t*);
  ssize_t (*recvmsg)(int, struct msghdr*, int);
  ssize_t (*send)(int, const void*, size_t, int);
  ssize_t (*sendto)(int, const void*, size_t, int, const struct sockaddr*, socklen_t);
  ssize_t (*sendmsg)(int, const struct msghdr*, int);
  int (*timerfd_create)(int, int);
  int (*timerfd_settime)(int, int, const struct itimerspec*, struct itimerspec*);
  int (*timerfd_gettime)(int, struct itimerspec*);
  int (*pthread_create)(pthread_t*, const pthread_attr_t*, void* (*)(void*), void*);
  int (*cond_wait)(pthread_cond_t*, pthread_mutex_t*);
  int (*cond_timedwait)(pthread_cond_t*, pthread_mutex_t*, const struct timespec*);
  int (*cond_clockwait)(pthread_cond_t*, pthread_mutex_t*, clockid_t, const struct timespec*);
  int (*cond_signal)(pthread_cond_t*);
  int (*cond_broadcast)(pthread_cond_t*);
  int (*sem_wait)(sem_t*);
  int (*sem_timedwait)(sem_t*, const struct timespec*);
  int (*sem_clockwait)(sem_t*, clockid_t, const struct timespec*);
  int (*sem_trywait)(sem_t*);
  int (*sem_post)(sem_t*);
  int (*join)(pthread_t, void**);
  int (*clockjoin)(pthread_t, void**, clockid_t, const struct timespec*);
};

Real g_real{};
ClockFile* g_clock = nullptr;
pid_t g_pid = 0;
pthread_key_t g_slot_key;
thread_local ThreadSlot* t_slot = nullptr;
thread_local uint64_t t_empty_read_event = UINT64_MAX;  // ClockFile::events at this thread's last empty bus read
thread_local int t_bypass = 0;  // > 0: calls pass through (LockstepBypass; threads made meanwhile)

// What each of this process's threads (by slot) is blocked on, so that the thread that signals or
// posts it marks it running before it can wake (doppel must not advance time in between).
std::atomic<const void*> g_blocked_on[lockstep::kMaxThreads];

// Bus of each Doppel port (index into ClockFile::buses), resolved on first use; -2 = not yet, -1 = none.
std::atomic<int> g_port_bus[64];
std::atomic<int> g_bus_fd[lockstep::kMaxBuses];  // a descriptor the process has open on the bus, -1 = none

// timerfds the program created: they never run in wall time; their expiry is simulation time.
struct VirtualTimer {
  std::atomic<bool> used{false};
  std::atomic<int> clock{CLOCK_MONOTONIC};
  std::atomic<int64_t> next_ns{0};      // simulation time of the next expiry, 0 = disarmed
  std::atomic<int64_t> interval_ns{0};
  std::atomic<bool> nonblocking{false};
};
VirtualTimer g_timers[kMaxFds];

template <typename F>
void resolve(F& f, const char* name, const char* version = nullptr) noexcept {
  void* symbol = version != nullptr ? dlvsym(RTLD_NEXT, name, version) : nullptr;
  if (symbol == nullptr) symbol = dlsym(RTLD_NEXT, name);
  f = reinterpret_cast<F>(symbol);
}

void say(const char* a, const char* b = "", const char* c = "") noexcept {
  const int saved = errno;
  for (const char* part : {"doppel-run shim: lockstep: ", a, b, c, "\n"}) {
    [[maybe_unused]] const ssize_t n = ::syscall(SYS_write, 2, part, strlen(part));
  }
  errno = saved;
}

bool on() noexcept { return g_clock != nullptr && t_bypass == 0 && g_clock->open.load(std::memory_order_acquire) != 0; }
int64_t sim_now() noexcept { return g_clock->sim_ns.load(std::memory_order_acquire); }
int64_t wall_now() noexcept {
  struct timespec ts {};
  g_real.clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<int64_t>(ts.tv_sec) * kSecond + ts.tv_nsec;
}
int64_t ns_of(const struct timespec& ts) noexcept { return static_cast<int64_t>(ts.tv_sec) * kSecond + ts.tv_nsec; }
struct timespec timespec_of(int64_t ns) noexcept {
  struct timespec ts {};
  ts.tv_sec = static_cast<time_t>(ns / kSecond);
  ts.tv_nsec = static_cast<long>(ns % kSecond);
  return ts;
}

void notify_coordinator() noexcept {
  g_clock->coordinator_seq.fetch_add(1, std::memory_order_seq_cst);
  lockstep::futex_wake_all(g_clock->coordinator_seq);
}

void release(ThreadSlot* slot) noexcept {
  if (slot == nullptr || g_clock == nullptr) return;
  g_blocked_on[slot - g_clock->threads].store(nullptr, std::memory_order_relaxed);
  slot->pid.store(0, std::memory_order_relaxed);  // 0 until the next owner sets its own
  slot->state.store(lockstep::kFree, std::memory_order_release);
  notify_coordinator();
}

void mark_woken(const void* object) noexcept;

void release_at_thread_exit(void* slot) {
  mark_woken(reinterpret_cast<const void*>(pthread_self()));  // a thread joining this one runs on
  release(static_cast<ThreadSlot*>(slot));
}

// A free slot, running, for a thread of this process (tid 0: not started yet).
ThreadSlot* claim(pid_t tid) noexcept {
  for (ThreadSlot& slot : g_clock->threads) {
    uint32_t expected = lockstep::kFree;
    if (slot.state.load(std::memory_order_relaxed) != lockstep::kFree) continue;
    // A free slot's pid is 0 (released so): doppel does not remove a slot being claimed.
    if (!slot.state.compare_exchange_strong(expected, lockstep::kRunning, std::memory_order_acq_rel)) continue;
    slot.tid.store(tid, std::memory_order_relaxed);
    slot.calls.store(0, std::memory_order_relaxed);
    slot.clock_reads.store(0, std::memory_order_relaxed);
    slot.last_call.store(static_cast<uint32_t>(Call::kStart), std::memory_order_relaxed);
    slot.pid.store(g_pid, std::memory_order_release);
    const uint32_t index = static_cast<uint32_t>(&slot - g_clock->threads) + 1;
    uint32_t used = g_clock->slots_used.load(std::memory_order_acquire);
    while (used < index && !g_clock->slots_used.compare_exchange_weak(used, index, std::memory_order_acq_rel)) {
    }
    return &slot;
  }
  say("more than 256 controller threads: this one runs unseen (simulation time may pass while it runs)");
  return nullptr;
}

// The calling thread's slot; a thread the shim did not see start (not made by pthread_create)
// registers on its first intercepted call. nullptr when lockstep is off.
ThreadSlot* self() noexcept {
  if (!on()) return nullptr;
  if (t_slot == nullptr) {
    t_slot = claim(static_cast<pid_t>(::syscall(SYS_gettid)));
    if (t_slot != nullptr) pthread_setspecific(g_slot_key, t_slot);
  }
  return t_slot;
}

void touch(ThreadSlot* slot, Call call) noexcept {
  slot->calls.fetch_add(1, std::memory_order_relaxed);
  slot->last_call.store(static_cast<uint32_t>(call), std::memory_order_relaxed);
  if (call != Call::kClockGettime) slot->clock_reads.store(0, std::memory_order_relaxed);
}

// Marks the thread waiting (for `flags`: until `wake_ns`, the next event, a peer) and tells doppel.
void begin_wait(ThreadSlot* slot, uint32_t flags, int64_t wake_ns, Call call) noexcept {
  touch(slot, call);
  slot->clock_reads.store(0, std::memory_order_relaxed);
  slot->flags.store(flags, std::memory_order_relaxed);
  slot->wake_ns.store(wake_ns, std::memory_order_relaxed);
  slot->event_mark.store(g_clock->events.load(std::memory_order_acquire), std::memory_order_relaxed);
  slot->delivery_mark.store(g_clock->deliveries.load(std::memory_order_acquire), std::memory_order_relaxed);
  slot->waits.fetch_add(1, std::memory_order_relaxed);
  slot->state.store(lockstep::kWaiting, std::memory_order_seq_cst);
  notify_coordinator();
}

// Waits (for a time and/or the next event) until doppel wakes the thread.
void park(ThreadSlot* slot, uint32_t flags, int64_t wake_ns, Call call) noexcept {
  begin_wait(slot, flags, wake_ns, call);
  for (;;) {
    const uint32_t seq = slot->wake_seq.load(std::memory_order_acquire);
    if (slot->state.load(std::memory_order_acquire) != lockstep::kWaiting) return;
    if (!on()) {
      slot->state.store(lockstep::kRunning, std::memory_order_release);
      return;
    }
    lockstep::futex_wait(slot->wake_seq, seq, 200'000'000);
  }
}

// False when the thread has no slot (more threads than slots): the caller waits in wall time. A
// wake-up time that has already passed returns at once, as the kernel's sleep does, without a
// hand-over to doppel (which would wake the thread at the same simulation time): a controller that
// overruns its period (clock_nanosleep(TIMER_ABSTIME) behind) costs no round trip per cycle. A
// sleep until now (zero length) lets the program's other threads due now run, then waits for the
// next event (simulation time moves on): on a real machine such a sleep still takes microseconds,
// and a loop of them until the clock reaches a time (the DARwIn-OP framework's LinuxCM730::Sleep
// passes milliseconds to usleep, so its last millisecond is usleep(0)) would else never see it move.
bool sleep_until(int64_t wake_ns, Call call) noexcept {
  ThreadSlot* slot = self();
  if (slot == nullptr) return false;
  const int64_t now = sim_now();
  if (wake_ns < now) {
    touch(slot, call);
    return true;
  }
  if (wake_ns == now) {
    park(slot, lockstep::kNextEvent, kNever, call);
    return true;
  }
  park(slot, lockstep::kUntilTime, wake_ns, call);
  return true;
}

bool virtual_clock(clockid_t clock) noexcept {
  switch (clock) {
    case CLOCK_REALTIME:
    case CLOCK_REALTIME_COARSE:
    case CLOCK_MONOTONIC:
    case CLOCK_MONOTONIC_RAW:
    case CLOCK_MONOTONIC_COARSE:
    case CLOCK_BOOTTIME:
    case CLOCK_TAI:
      return true;
    default:
      return false;
  }
}
bool realtime(clockid_t clock) noexcept { return clock == CLOCK_REALTIME || clock == CLOCK_REALTIME_COARSE || clock == CLOCK_TAI; }

// What `clock` reads at simulation time `sim_ns`, and back.
int64_t clock_at(clockid_t clock, int64_t sim_ns) noexcept {
  return realtime(clock) ? g_clock->epoch_realtime_ns + sim_ns : lockstep::kMonotonicOffsetNs + sim_ns;
}
int64_t sim_at(clockid_t clock, int64_t clock_ns) noexcept {
  return realtime(clock) ? clock_ns - g_clock->epoch_realtime_ns : clock_ns - lockstep::kMonotonicOffsetNs;
}

// A clock read. Many reads in a row without any other intercepted call are a thread spinning
// until time passes: it then waits for the next event instead of stopping the simulation.
void count_clock_read() noexcept {
  ThreadSlot* slot = self();
  if (slot == nullptr) return;
  touch(slot, Call::kClockGettime);
  if (slot->clock_reads.fetch_add(1, std::memory_order_relaxed) + 1 >= kSpinReads) {
    park(slot, lockstep::kNextEvent, kNever, Call::kClockGettime);
  }
}

// The bus behind Doppel port `port` (matched by the pty its link leads to), -1 if doppel has none.
int bus_of_port(int port) noexcept {
  if (port < 0 || port >= 64) return -1;
  int bus = g_port_bus[port].load(std::memory_order_acquire);
  if (bus != -2) return bus;
  bus = -1;
  const char* pts = port_pts(port);
  for (uint32_t b = 0; b < g_clock->bus_count && pts[0] != '\0'; ++b) {
    if (strcmp(g_clock->buses[b].slave, pts) == 0) bus = static_cast<int>(b);
  }
  g_port_bus[port].store(bus, std::memory_order_release);
  return bus;
}

int bus_of_fd(int fd) noexcept {
  if (!on()) return -1;
  const int bus = bus_of_port(port_index_of_fd(fd));
  if (bus >= 0) g_bus_fd[bus].store(fd, std::memory_order_relaxed);
  return bus;
}

int readable_bytes(int fd) noexcept {
  int n = 0;
  return ::syscall(SYS_ioctl, fd, FIONREAD, &n) == 0 ? n : 0;  // not through shim.cpp's ioctl
}

// Totals of ClockFile::BusSlot::delivered known to have crossed the pty (by bus): those bytes stay
// there until the program reads them (client_read) or flushes or closes the bus, so settle() need
// not ask the kernel again.
std::atomic<uint64_t> g_settled[lockstep::kMaxBuses];
// The bus counters (delivered, client_read) when this thread last counted the pty's bytes itself
// (FIONREAD): while they are unchanged, the pty holds delivered - client_read bytes for it. (A
// program that also reads the bus past the shim, through stdio, would make that stale.)
thread_local uint64_t t_checked_delivered[lockstep::kMaxBuses];
thread_local uint64_t t_checked_read[lockstep::kMaxBuses];

// Waits (wall time, bounded) until the pty holds every byte doppel delivered that the program has
// not read: the kernel hands pty bytes over asynchronously, and what a read finds must not depend on that.
void settle(int bus, int fd) noexcept {
  lockstep::BusSlot& b = g_clock->buses[bus];
  const uint64_t delivered = b.delivered.load(std::memory_order_acquire);
  uint64_t read = b.client_read.load(std::memory_order_acquire);
  if (delivered <= read || delivered <= g_settled[bus].load(std::memory_order_acquire)) return;
  const int64_t want = static_cast<int64_t>(delivered - read);
  int64_t give_up = 0;
  for (;;) {
    // A poll of the pty first runs the kernel's pending hand-over (n_tty_poll flushes the port's
    // work item), so the count after it is usually complete: two system calls per delivery.
    struct pollfd p {fd, POLLIN, 0};
    const struct timespec slice = timespec_of(100'000);
    g_real.ppoll(&p, 1, &slice, nullptr);
    const int readable = readable_bytes(fd);
    if (readable >= want) break;
    const int64_t now = wall_now();
    if (give_up == 0) give_up = now + kSettleWallNs;
    if (now > give_up) {
      say("a bus' bytes did not arrive within 1 s; counting them as read");
      read = delivered - static_cast<uint64_t>(readable);
      b.client_read.store(read, std::memory_order_release);
      break;
    }
  }
  t_checked_delivered[bus] = delivered;
  t_checked_read[bus] = read;
  uint64_t settled = g_settled[bus].load(std::memory_order_relaxed);
  while (settled < delivered && !g_settled[bus].compare_exchange_weak(settled, delivered, std::memory_order_acq_rel)) {
  }
}

// Bytes the pty holds for the program on bus `bus` as this thread last counted them, if the
// counters have not moved since (no system call); 0 otherwise.
int checked_pending(int bus) noexcept {
  const lockstep::BusSlot& b = g_clock->buses[bus];
  const uint64_t delivered = b.delivered.load(std::memory_order_acquire);
  const uint64_t read = b.client_read.load(std::memory_order_acquire);
  if (delivered <= read || delivered != t_checked_delivered[bus] || read != t_checked_read[bus]) return 0;
  const uint64_t pending = delivered - read;
  return pending < static_cast<uint64_t>(INT32_MAX) ? static_cast<int>(pending) : INT32_MAX;
}

// Bytes a read of bus `bus` finds now, once settled: checked_pending, else the kernel's count.
int available(int bus, int fd) noexcept {
  const int pending = checked_pending(bus);
  return pending > 0 ? pending : readable_bytes(fd);
}

void settle_all() noexcept {
  for (uint32_t b = 0; b < g_clock->bus_count && b < lockstep::kMaxBuses; ++b) {
    const int fd = g_bus_fd[b].load(std::memory_order_relaxed);
    if (fd >= 0 && port_index_of_fd(fd) >= 0) settle(static_cast<int>(b), fd);
  }
}

void settle_fds(const struct pollfd* fds, nfds_t n) noexcept {
  for (nfds_t i = 0; i < n; ++i) {
    const int bus = bus_of_fd(fds[i].fd);
    if (bus >= 0) settle(bus, fds[i].fd);
  }
}

VirtualTimer* timer_of(int fd) noexcept {
  if (fd < 0 || fd >= kMaxFds || !g_timers[fd].used.load(std::memory_order_acquire)) return nullptr;
  return &g_timers[fd];
}

// Expirations of `timer` up to now (and the timer moved on past them).
uint64_t expire(VirtualTimer& timer) noexcept {
  const int64_t next = timer.next_ns.load(std::memory_order_acquire);
  const int64_t now = sim_now();
  if (next == 0 || now < next) return 0;
  const int64_t interval = timer.interval_ns.load(std::memory_order_relaxed);
  if (interval <= 0) {
    timer.next_ns.store(0, std::memory_order_release);
    return 1;
  }
  const uint64_t count = 1 + static_cast<uint64_t>((now - next) / interval);
  timer.next_ns.store(next + static_cast<int64_t>(count) * interval, std::memory_order_release);
  return count;
}

// poll() semantics over the program's descriptors at the current simulation time: virtual timers
// answer for themselves, the rest is asked of the kernel without waiting. Lowers *wake_ns to the
// earliest timer expiry.
int poll_now(struct pollfd* fds, nfds_t n, int64_t* wake_ns) noexcept {
  // A camera's descriptor is readable once the frames doppel published up to now are in its
  // buffers: the program's thread moves them there itself, so readiness is simulation time's.
  for (nfds_t i = 0; i < n; ++i) {
    if (v4l2_fd(fds[i].fd)) v4l2_pump(fds[i].fd);
  }
  // Only buses asked for input, each holding bytes this thread counted (a reply doppel delivered):
  // readable, without asking the kernel. Anything else (a bus with nothing, other events, other descriptors) is the kernel's.
  constexpr short kInput = POLLIN | POLLRDNORM;
  bool settled_input = n > 0;
  for (nfds_t i = 0; i < n && settled_input; ++i) {
    const int bus = (fds[i].events & ~kInput) == 0 && fds[i].events != 0 ? bus_of_fd(fds[i].fd) : -1;
    settled_input = bus >= 0 && checked_pending(bus) > 0;
  }
  if (settled_input) {
    for (nfds_t i = 0; i < n; ++i) fds[i].revents = fds[i].events;
    return static_cast<int>(n);
  }
  bool timers = false;
  for (nfds_t i = 0; i < n; ++i) timers = timers || timer_of(fds[i].fd) != nullptr;
  const struct timespec zero {};
  if (!timers) return g_real.ppoll(fds, n, &zero, nullptr);
  int ready = 0;
  for (nfds_t i = 0; i < n; ++i) {
    VirtualTimer* timer = timer_of(fds[i].fd);
    if (timer == nullptr) {
      const int r = g_real.ppoll(&fds[i], 1, &zero, nullptr);
      if (r < 0) return r;
      ready += r;
      continue;
    }
    const int64_t next = timer->next_ns.load(std::memory_order_acquire);
    fds[i].revents = next != 0 && next <= sim_now() ? static_cast<short>(fds[i].events & POLLIN) : 0;
    if (next != 0 && next < *wake_ns) *wake_ns = next;
    ready += fds[i].revents != 0 ? 1 : 0;
  }
  return ready;
}

// The poll loop of every intercepted poll/select flavour: ready now, else wait for the next event
// (or the deadline, or a timer's expiry) and look again.
int poll_for(struct pollfd* fds, nfds_t n, int64_t timeout_ns, Call call) noexcept {
  ThreadSlot* slot = self();
  settle_fds(fds, n);
  int64_t timer_wake = kNever;
  int r = poll_now(fds, n, &timer_wake);
  if (r != 0 || timeout_ns == 0) return r;
  if (slot == nullptr) {
    const struct timespec timeout = timespec_of(timeout_ns);
    return g_real.ppoll(fds, n, timeout_ns < 0 ? nullptr : &timeout, nullptr);
  }
  touch(slot, call);
  const int64_t deadline = timeout_ns < 0 ? kNever : sim_now() + timeout_ns;
  // Buses and virtual timers only: nothing can change before a delivery, a timer or the timeout,
  // so the thread sleeps through the events in between. Any other descriptor: every event.
  bool only_ours = true;
  for (nfds_t i = 0; i < n; ++i) only_ours = only_ours && (timer_of(fds[i].fd) != nullptr || bus_of_fd(fds[i].fd) >= 0);
  const uint32_t wake_for = only_ours ? lockstep::kDelivery : lockstep::kNextEvent;
  for (;;) {
    const int64_t wake = timer_wake < deadline ? timer_wake : deadline;
    park(slot, wake_for | (wake != kNever ? lockstep::kUntilTime : 0u), wake, call);
    if (!on()) {
      return g_real.poll(fds, n, timeout_ns < 0 ? -1 : static_cast<int>(timeout_ns / 1'000'000));
    }
    settle_fds(fds, n);
    timer_wake = kNever;
    r = poll_now(fds, n, &timer_wake);
    if (r != 0 || sim_now() >= deadline) return r;
  }
}

int64_t timeout_of(const struct timespec* ts) noexcept { return ts == nullptr ? -1 : ns_of(*ts); }

// A poll as the program asked for it: in simulation time under lockstep, else the kernel's.
int poll_as_asked(struct pollfd* fds, nfds_t n, int64_t timeout_ns, const sigset_t* mask, Call call) noexcept {
  if (on()) return poll_for(fds, n, timeout_ns, call);
  const struct timespec timeout = timespec_of(timeout_ns);
  return g_real.ppoll(fds, n, timeout_ns < 0 ? nullptr : &timeout, mask);
}

bool camera_events_asked(const struct pollfd* fds, nfds_t n) noexcept {
  for (nfds_t i = 0; i < n; ++i) {
    if ((fds[i].events & POLLPRI) != 0 && v4l2_event_fd(fds[i].fd) >= 0) return true;
  }
  return false;
}

bool camera_events_asked(int nfds, const fd_set* ex) noexcept {
  for (int fd = 0; ex != nullptr && fd < nfds && fd < FD_SETSIZE; ++fd) {
    if (FD_ISSET(fd, ex) && v4l2_event_fd(fd) >= 0) return true;
  }
  return false;
}

// poll_as_asked, where a camera descriptor asked for POLLPRI (a waiting control event, V4L2) gets
// it from its event descriptor (v4l2_event_fd), polled beside it for POLLIN. Sets of more than 128
// descriptors are polled as they are.
int poll_with_camera_events(struct pollfd* fds, nfds_t n, int64_t timeout_ns, const sigset_t* mask, Call call) noexcept {
  constexpr nfds_t kMaxPolled = 256;
  if (n > kMaxPolled / 2 || !camera_events_asked(fds, n)) return poll_as_asked(fds, n, timeout_ns, mask, call);
  struct pollfd all[kMaxPolled];
  nfds_t camera_of[kMaxPolled / 2];  // the entry of `fds` each added event descriptor stands for
  nfds_t count = n;
  for (nfds_t i = 0; i < n; ++i) {
    all[i] = fds[i];
    const int events = (fds[i].events & POLLPRI) != 0 ? v4l2_event_fd(fds[i].fd) : -1;
    if (events < 0) continue;
    camera_of[count - n] = i;
    all[count++] = {events, POLLIN, 0};
  }
  const int r = poll_as_asked(all, count, timeout_ns, mask, call);
  if (r < 0) return r;
  for (nfds_t i = 0; i < n; ++i) fds[i].revents = all[i].revents;
  for (nfds_t k = n; k < count; ++k) {
    if ((all[k].revents & POLLIN) != 0) fds[camera_of[k - n]].revents |= POLLPRI;
  }
  int ready = 0;
  for (nfds_t i = 0; i < n; ++i) ready += fds[i].revents != 0 ? 1 : 0;
  return ready;
}

// select() on top of poll_with_camera_events (FD_SETSIZE descriptors at most, as select itself).
int select_for(int nfds, fd_set* rd, fd_set* wr, fd_set* ex, int64_t timeout_ns, const sigset_t* mask, Call call) noexcept {
  struct pollfd fds[FD_SETSIZE];
  nfds_t n = 0;
  for (int fd = 0; fd < nfds && fd < FD_SETSIZE; ++fd) {
    short events = 0;
    if (rd != nullptr && FD_ISSET(fd, rd)) events |= POLLIN;
    if (wr != nullptr && FD_ISSET(fd, wr)) events |= POLLOUT;
    if (ex != nullptr && FD_ISSET(fd, ex)) events |= POLLPRI;
    if (events != 0) fds[n++] = {fd, events, 0};
  }
  const int r = poll_with_camera_events(fds, n, timeout_ns, mask, call);
  if (r < 0) return r;
  if (rd != nullptr) FD_ZERO(rd);
  if (wr != nullptr) FD_ZERO(wr);
  if (ex != nullptr) FD_ZERO(ex);
  int count = 0;
  for (nfds_t i = 0; i < n; ++i) {
    if ((fds[i].revents & POLLNVAL) != 0) {
      errno = EBADF;
      return -1;
    }
    if (rd != nullptr && (fds[i].revents & (POLLIN | POLLHUP | POLLERR)) != 0) FD_SET(fds[i].fd, rd), ++count;
    if (wr != nullptr && (fds[i].revents & (POLLOUT | POLLERR)) != 0) FD_SET(fds[i].fd, wr), ++count;
    if (ex != nullptr && (fds[i].revents & POLLPRI) != 0) FD_SET(fds[i].fd, ex), ++count;
  }
  return count;
}

bool nonblocking(int fd) noexcept { return (::syscall(SYS_fcntl, fd, F_GETFL) & O_NONBLOCK) != 0; }

ssize_t counted_read(int bus, int fd, void* buffer, size_t n) noexcept {
  const ssize_t r = g_real.read(fd, buffer, n);
  if (r > 0) g_clock->buses[bus].client_read.fetch_add(static_cast<uint64_t>(r), std::memory_order_acq_rel);
  return r;
}

// read() of a bus: what the pty holds now; with nothing there, the thread waits for the next event
// as the read's mode says (non-blocking: once per event; VMIN/VTIME: as the tty would).
ssize_t bus_read(int bus, int fd, void* buffer, size_t n) noexcept {
  ThreadSlot* slot = self();
  settle(bus, fd);
  if (slot == nullptr || n == 0 || available(bus, fd) > 0) return counted_read(bus, fd, buffer, n);
  touch(slot, Call::kBusRead);
  struct termios tio {};
  const bool tty = ::tcgetattr(fd, &tio) == 0;
  const cc_t vmin = tty ? tio.c_cc[VMIN] : 1;
  const cc_t vtime = tty ? tio.c_cc[VTIME] : 0;
  if (nonblocking(fd) || (vmin == 0 && vtime == 0)) {
    // The first empty read at an event returns at once (a driver draining stale input); the next
    // one waits for the next event (a driver polling for its reply).
    const uint64_t events = g_clock->events.load(std::memory_order_acquire);
    if (t_empty_read_event != events) {
      t_empty_read_event = events;
    } else {
      park(slot, lockstep::kNextEvent, kNever, Call::kBusRead);
      settle(bus, fd);
      t_empty_read_event = g_clock->events.load(std::memory_order_acquire);
    }
    if (available(bus, fd) > 0) return counted_read(bus, fd, buffer, n);
    // As n_tty_read: in raw mode with VMIN = VTIME = 0 an empty read returns 0 even under
    // O_NONBLOCK (its zero timeout is checked before the flag); otherwise O_NONBLOCK gives EAGAIN.
    // Drivers that add read()'s result to a count (the DARwIn-OP framework's CM730::TxRxPacket,
    // DynamixelSDK's rxPacket) open the port so and rely on the 0.
    const bool raw_no_wait = tty && (tio.c_lflag & ICANON) == 0 && vmin == 0 && vtime == 0;
    if (nonblocking(fd) && !raw_no_wait) {
      errno = EAGAIN;
      return -1;
    }
    return 0;
  }
  const int64_t deadline = vmin == 0 ? sim_now() + static_cast<int64_t>(vtime) * 100'000'000 : kNever;
  const int want = vmin == 0 ? 1 : (vmin < n ? vmin : static_cast<int>(n));
  for (;;) {
    park(slot, lockstep::kNextEvent | (deadline != kNever ? lockstep::kUntilTime : 0u), deadline, Call::kBusRead);
    if (!on()) return g_real.read(fd, buffer, n);
    settle(bus, fd);
    if (available(bus, fd) >= want) return counted_read(bus, fd, buffer, n);
    if (sim_now() >= deadline) return 0;
  }
}

ssize_t timer_read(VirtualTimer& timer, void* buffer, size_t n) noexcept {
  if (n < sizeof(uint64_t)) {
    errno = EINVAL;
    return -1;
  }
  ThreadSlot* slot = self();
  for (;;) {
    const uint64_t count = expire(timer);
    if (count > 0) {
      memcpy(buffer, &count, sizeof count);
      return sizeof count;
    }
    if (timer.nonblocking.load(std::memory_order_relaxed) || slot == nullptr) {
      errno = EAGAIN;
      return -1;
    }
    const int64_t next = timer.next_ns.load(std::memory_order_acquire);
    park(slot, next != 0 ? lockstep::kUntilTime : lockstep::kNextEvent, next != 0 ? next : kNever, Call::kTimerfdRead);
  }
}

// What a peer wait does once a peer marked it running but its wall-time slice ran out before the
// real wake-up arrived: kSpurious returns 0 (a condition variable may wake spuriously: the program
// checks its predicate, which the signaller changed before it signalled); kSticky keeps waiting
// as running (the wake-up follows at once: a post, a thread's exit), for at most kStickyWallNs.
enum class Marked { kSpurious, kSticky };
constexpr int64_t kStickyWallNs = 100'000'000;

// A wait on a condition variable, semaphore or thread: marked waiting on a peer (doppel does not
// wake it, the thread that signals, posts or exits does, through mark_woken), until `deadline` if
// it has one. The real wait runs in wall-time slices so that the thread notices doppel waking it
// at its deadline.
template <typename WaitSlice>
int peer_wait(const void* object, int64_t deadline, Call call, Marked marked, WaitSlice wait_slice) noexcept {
  ThreadSlot* slot = self();
  const std::size_t index = static_cast<std::size_t>(slot - g_clock->threads);
  const uint32_t flags = lockstep::kPeer | (deadline != kNever ? lockstep::kUntilTime : 0u);
  g_blocked_on[index].store(object, std::memory_order_release);
  begin_wait(slot, flags, deadline, call);
  int result = 0;
  int64_t marked_since = 0;
  for (;;) {
    const struct timespec until = timespec_of(wall_now() + kSliceWallNs);
    const int r = wait_slice(&until);
    if (r != ETIMEDOUT) {
      result = r;  // woken (or an error of the real call)
      break;
    }
    if (!on()) {
      result = ETIMEDOUT;
      break;
    }
    if (slot->state.load(std::memory_order_acquire) != lockstep::kRunning) continue;
    if (deadline != kNever && sim_now() >= deadline) {
      result = ETIMEDOUT;  // doppel woke it: its time is up
      break;
    }
    if (marked == Marked::kSpurious) {
      result = 0;
      break;
    }
    if (marked_since == 0) marked_since = wall_now();
    if (wall_now() - marked_since > kStickyWallNs) {
      // Marked for a wake-up another waiter took: wait on.
      marked_since = 0;
      g_blocked_on[index].store(object, std::memory_order_release);
      begin_wait(slot, flags, deadline, call);
    }
  }
  g_blocked_on[index].store(nullptr, std::memory_order_release);
  slot->state.store(lockstep::kRunning, std::memory_order_release);
  return result;
}

// Before a signal, broadcast, post or thread exit: threads of this process blocked on `object`
// run again (for doppel) before they can be woken, so time cannot advance under their feet; `one`
// marks only the first (a semaphore post wakes one waiter).
void mark_woken(const void* object, bool one) noexcept {
  if (!on()) return;
  for (std::size_t i = 0; i < lockstep::kMaxThreads; ++i) {
    if (g_blocked_on[i].load(std::memory_order_acquire) != object) continue;
    uint32_t expected = lockstep::kWaiting;
    if (g_clock->threads[i].state.compare_exchange_strong(expected, lockstep::kRunning, std::memory_order_acq_rel) && one) {
      return;
    }
  }
}

void mark_woken(const void* object) noexcept { mark_woken(object, false); }

// glibc keeps a condition variable's clock in __wrefs bit 1 (__PTHREAD_COND_CLOCK_MONOTONIC_MASK,
// nptl/pthread_cond_common.c, glibc 2.25 and later).
clockid_t clock_of(const pthread_cond_t* cond) noexcept {
  return (cond->__data.__wrefs & 2u) != 0 ? CLOCK_MONOTONIC : CLOCK_REALTIME;
}

int64_t deadline_of(clockid_t clock, const struct timespec* abstime) noexcept {
  return abstime == nullptr ? kNever : sim_at(clock, ns_of(*abstime));
}

struct ThreadStart {
  void* (*routine)(void*);
  void* argument;
  ThreadSlot* slot;
  bool bypass;  // made while its creator bypassed: never registers
};

void* start_thread(void* p) {
  ThreadStart start = *static_cast<ThreadStart*>(p);
  free(p);
  if (start.bypass) t_bypass = 1;
  t_slot = start.slot;
  if (t_slot != nullptr) {
    t_slot->tid.store(static_cast<int32_t>(::syscall(SYS_gettid)), std::memory_order_release);
    pthread_setspecific(g_slot_key, t_slot);
  }
  return start.routine(start.argument);
}

void after_fork_in_child() noexcept {
  g_pid = getpid();
  t_slot = nullptr;  // the parent's; this process registers its thread on its first call
}

// libc's functions, resolved on first need: another constructor of this library (shim.cpp's) or
// of the program may call an interposed function before load() ran.
std::atomic<bool> g_resolved{false};
void resolve_reals() noexcept {
  resolve(g_real.clock_gettime, "clock_gettime");
  resolve(g_real.gettimeofday, "gettimeofday");
  resolve(g_real.time, "time");
  resolve(g_real.nanosleep, "nanosleep");
  resolve(g_real.clock_nanosleep, "clock_nanosleep");
  resolve(g_real.usleep, "usleep");
  resolve(g_real.sleep, "sleep");
  resolve(g_real.poll, "poll");
  resolve(g_real.ppoll, "ppoll");
  resolve(g_real.select, "select");
  resolve(g_real.pselect, "pselect");
  resolve(g_real.epoll_wait, "epoll_wait");
  resolve(g_real.epoll_pwait, "epoll_pwait");
  resolve(g_real.read, "read");
  resolve(g_real.write, "write");
  resolve(g_real.recv, "recv");
  resolve(g_real.recvfrom, "recvfrom");
  resolve(g_real.recvmsg, "recvmsg");
  resolve(g_real.send, "send");
  resolve(g_real.sendto, "sendto");
  resolve(g_real.sendmsg, "sendmsg");
  resolve(g_real.timerfd_create, "timerfd_create");
  resolve(g_real.timerfd_settime, "timerfd_settime");
  resolve(g_real.timerfd_gettime, "timerfd_gettime");
  resolve(g_real.pthread_create, "pthread_create", "GLIBC_2.34");
  // dlsym alone finds glibc's pre-2.3.2 condition variables; the program uses the current ones.
  resolve(g_real.cond_wait, "pthread_cond_wait", "GLIBC_2.3.2");
  resolve(g_real.cond_timedwait, "pthread_cond_timedwait", "GLIBC_2.3.2");
  resolve(g_real.cond_clockwait, "pthread_cond_clockwait");
  resolve(g_real.cond_signal, "pthread_cond_signal", "GLIBC_2.3.2");
  resolve(g_real.cond_broadcast, "pthread_cond_broadcast", "GLIBC_2.3.2");
  resolve(g_real.sem_wait, "sem_wait", "GLIBC_2.34");
  resolve(g_real.sem_timedwait, "sem_timedwait", "GLIBC_2.34");
  resolve(g_real.sem_clockwait, "sem_clockwait");
  resolve(g_real.sem_trywait, "sem_trywait", "GLIBC_2.34");
  resolve(g_real.sem_post, "sem_post", "GLIBC_2.34");
  resolve(g_real.join, "pthread_join", "GLIBC_2.34");
  resolve(g_real.clockjoin, "pthread_clockjoin_np", "GLIBC_2.34");
  g_resolved.store(true, std::memory_order_release);
}

void set_up() noexcept {
  if (!g_resolved.load(std::memory_order_acquire)) resolve_reals();
  for (auto& bus : g_port_bus) bus.store(-2, std::memory_order_relaxed);
  for (auto& fd : g_bus_fd) fd.store(-1, std::memory_order_relaxed);

  const char* path = ::getenv(lockstep::kClockVariable);
  if (path == nullptr || path[0] == '\0') return;
  const int fd = static_cast<int>(::syscall(SYS_openat, AT_FDCWD, path, O_RDWR | O_CLOEXEC));
  if (fd < 0) {
    say(lockstep::kClockVariable, " names a clock file that cannot be opened: ", path);
    return;
  }
  void* memory = ::mmap(nullptr, sizeof(ClockFile), PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
  ::syscall(SYS_close, fd);
  if (memory == MAP_FAILED) {
    say("cannot map the clock file ", path);
    return;
  }
  ClockFile* clock = static_cast<ClockFile*>(memory);
  if (clock->magic != lockstep::kMagic || clock->version != lockstep::kVersion || clock->open.load() == 0) {
    say(path, " is not the clock file of a running doppel --lockstep (of this version); passing everything through");
    ::munmap(memory, sizeof(ClockFile));
    return;
  }
  g_pid = getpid();
  pthread_key_create(&g_slot_key, release_at_thread_exit);
  pthread_atfork(nullptr, nullptr, after_fork_in_child);
  g_clock = clock;
  self();  // the main thread runs from the start
}

__attribute__((constructor)) void load() { set_up(); }

__attribute__((destructor)) void unload() {
  if (g_clock == nullptr) return;
  for (ThreadSlot& slot : g_clock->threads) {
    if (slot.pid.load(std::memory_order_acquire) == g_pid && slot.state.load(std::memory_order_acquire) != lockstep::kFree) {
      release(&slot);
    }
  }
}

}  // namespace

void lockstep_closing(int fd) noexcept {
  if (g_clock == nullptr) return;
  if (VirtualTimer* timer = timer_of(fd)) timer->used.store(false, std::memory_order_release);
  const int bus = bus_of_fd(fd);
  if (bus < 0) return;
  // What the program did not read is gone with the descriptor.
  g_clock->buses[bus].client_read.store(g_clock->buses[bus].delivered.load(std::memory_order_acquire),
                                        std::memory_order_release);
  int expected = fd;
  g_bus_fd[bus].compare_exchange_strong(expected, -1, std::memory_order_relaxed);
}

bool lockstep_clock() noexcept { return g_clock != nullptr; }
bool lockstep_thread() noexcept { return on(); }
int64_t lockstep_sim_ns() noexcept { return g_clock != nullptr ? sim_now() : 0; }
int64_t lockstep_monotonic_offset_ns() noexcept { return lockstep::kMonotonicOffsetNs; }

void lockstep_wait_event() noexcept {
  ThreadSlot* slot = self();
  if (slot == nullptr) {
    const struct timespec millisecond {0, 1'000'000};
    g_real.nanosleep(&millisecond, nullptr);  // more threads than slots: look again in wall time
    return;
  }
  park(slot, lockstep::kNextEvent, kNever, Call::kCamera);
}

void lockstep_bypass_for_good() noexcept { ++t_bypass; }
LockstepBypass::LockstepBypass() noexcept { ++t_bypass; }
LockstepBypass::~LockstepBypass() { --t_bypass; }

void lockstep_flushing(int fd, int queue, bool done) noexcept {
  if (queue == TCOFLUSH || g_clock == nullptr) return;
  const int bus = bus_of_fd(fd);
  if (bus < 0) return;
  if (!done) {
    settle(bus, fd);  // flush exactly what was delivered, not what happened to have crossed the pty
    return;
  }
  g_clock->buses[bus].client_read.store(g_clock->buses[bus].delivered.load(std::memory_order_acquire),
                                        std::memory_order_release);
}

}  // namespace doppel::shim

using namespace doppel::shim;
namespace lockstep = doppel::lockstep;

#define NEED_REAL()                                                        \
  do {                                                                     \
    if (!g_resolved.load(std::memory_order_acquire)) resolve_reals();      \
  } while (false)

SHIM_EXPORT int clock_gettime(clockid_t clock, struct timespec* ts) noexcept {
  NEED_REAL();
  if (!on() || !virtual_clock(clock)) return g_real.clock_gettime(clock, ts);
  count_clock_read();
  *ts = timespec_of(clock_at(clock, sim_now()));
  return 0;
}

SHIM_EXPORT int gettimeofday(struct timeval* tv, void* tz) noexcept {
  NEED_REAL();
  if (!on()) return g_real.gettimeofday(tv, tz);
  count_clock_read();
  const int64_t ns = clock_at(CLOCK_REALTIME, sim_now());
  tv->tv_sec = static_cast<time_t>(ns / kSecond);
  tv->tv_usec = static_cast<suseconds_t>(ns % kSecond / 1000);
  return 0;
}

SHIM_EXPORT time_t time(time_t* out) noexcept {
  NEED_REAL();
  if (!on()) return g_real.time(out);
  count_clock_read();
  const time_t t = static_cast<time_t>(clock_at(CLOCK_REALTIME, sim_now()) / kSecond);
  if (out != nullptr) *out = t;
  return t;
}

SHIM_EXPORT int nanosleep(const struct timespec* request, struct timespec* remaining) {
  NEED_REAL();
  if (!on() || request == nullptr) return g_real.nanosleep(request, remaining);
  if (request->tv_nsec < 0 || request->tv_nsec >= kSecond || request->tv_sec < 0) {
    errno = EINVAL;
    return -1;
  }
  if (!sleep_until(sim_now() + ns_of(*request), Call::kNanosleep)) return g_real.nanosleep(request, remaining);
  if (remaining != nullptr) *remaining = {};
  return 0;
}

SHIM_EXPORT int clock_nanosleep(clockid_t clock, int flags, const struct timespec* request, struct timespec* remaining) {
  NEED_REAL();
  if (!on() || !virtual_clock(clock) || request == nullptr) return g_real.clock_nanosleep(clock, flags, request, remaining);
  if (request->tv_nsec < 0 || request->tv_nsec >= kSecond) return EINVAL;
  const int64_t wake = (flags & TIMER_ABSTIME) != 0 ? sim_at(clock, ns_of(*request)) : sim_now() + ns_of(*request);
  if (!sleep_until(wake, Call::kClockNanosleep)) return g_real.clock_nanosleep(clock, flags, request, remaining);
  if (remaining != nullptr && (flags & TIMER_ABSTIME) == 0) *remaining = {};
  return 0;
}

SHIM_EXPORT int usleep(useconds_t us) {
  NEED_REAL();
  if (!on()) return g_real.usleep(us);
  if (!sleep_until(sim_now() + static_cast<int64_t>(us) * 1000, Call::kUsleep)) return g_real.usleep(us);
  return 0;
}

SHIM_EXPORT unsigned sleep(unsigned seconds) {
  NEED_REAL();
  if (!on()) return g_real.sleep(seconds);
  if (!sleep_until(sim_now() + static_cast<int64_t>(seconds) * kSecond, Call::kSleep)) return g_real.sleep(seconds);
  return 0;
}

// Without lockstep these pass straight to libc unless a camera descriptor asks for its events.
SHIM_EXPORT int poll(struct pollfd* fds, nfds_t n, int timeout_ms) {
  NEED_REAL();
  if (!on() && !camera_events_asked(fds, n)) return g_real.poll(fds, n, timeout_ms);
  return poll_with_camera_events(fds, n, timeout_ms < 0 ? -1 : static_cast<int64_t>(timeout_ms) * 1'000'000, nullptr, Call::kPoll);
}

SHIM_EXPORT int ppoll(struct pollfd* fds, nfds_t n, const struct timespec* timeout, const sigset_t* mask) {
  NEED_REAL();
  if (!on() && !camera_events_asked(fds, n)) return g_real.ppoll(fds, n, timeout, mask);
  return poll_with_camera_events(fds, n, timeout_of(timeout), mask, Call::kPpoll);
}

SHIM_EXPORT int select(int nfds, fd_set* rd, fd_set* wr, fd_set* ex, struct timeval* timeout) {
  NEED_REAL();
  if ((!on() && !camera_events_asked(nfds, ex)) || nfds > FD_SETSIZE) return g_real.select(nfds, rd, wr, ex, timeout);
  const int64_t t = timeout == nullptr ? -1 : static_cast<int64_t>(timeout->tv_sec) * kSecond + timeout->tv_usec * 1000;
  const int r = select_for(nfds, rd, wr, ex, t, nullptr, Call::kSelect);
  if (timeout != nullptr && r == 0) *timeout = {};
  return r;
}

SHIM_EXPORT int pselect(int nfds, fd_set* rd, fd_set* wr, fd_set* ex, const struct timespec* timeout, const sigset_t* mask) {
  NEED_REAL();
  if ((!on() && !camera_events_asked(nfds, ex)) || nfds > FD_SETSIZE) return g_real.pselect(nfds, rd, wr, ex, timeout, mask);
  return select_for(nfds, rd, wr, ex, timeout_of(timeout), mask, Call::kPselect);
}

static int epoll_for(int epfd, struct epoll_event* events, int max, int timeout_ms) noexcept {
  // The descriptors in an epoll set are the kernel's: only its timeout is simulation time (a
  // timerfd in the set never fires: docs/lockstep.md).
  ThreadSlot* slot = self();
  settle_all();
  v4l2_pump(-1);  // every camera of the process: the set may hold any of them
  int r = g_real.epoll_wait(epfd, events, max, 0);
  if (r != 0 || timeout_ms == 0) return r;
  if (slot == nullptr) return g_real.epoll_wait(epfd, events, max, timeout_ms);
  const int64_t deadline = timeout_ms < 0 ? kNever : sim_now() + static_cast<int64_t>(timeout_ms) * 1'000'000;
  for (;;) {
    park(slot, lockstep::kNextEvent | (deadline != kNever ? lockstep::kUntilTime : 0u), deadline, Call::kEpollWait);
    if (!on()) return g_real.epoll_wait(epfd, events, max, timeout_ms);
    settle_all();
    v4l2_pump(-1);
    r = g_real.epoll_wait(epfd, events, max, 0);
    if (r != 0 || sim_now() >= deadline) return r;
  }
}

SHIM_EXPORT int epoll_wait(int epfd, struct epoll_event* events, int max, int timeout_ms) {
  NEED_REAL();
  if (!on()) return g_real.epoll_wait(epfd, events, max, timeout_ms);
  return epoll_for(epfd, events, max, timeout_ms);
}

SHIM_EXPORT int epoll_pwait(int epfd, struct epoll_event* events, int max, int timeout_ms, const sigset_t* mask) {
  NEED_REAL();
  if (!on()) return g_real.epoll_pwait(epfd, events, max, timeout_ms, mask);
  return epoll_for(epfd, events, max, timeout_ms);
}

// Before a blocking read of any other descriptor (pipe, socket, terminal) that has nothing: the
// thread waits for the next events until it has (its writer is another controller thread or
// process, or the world outside, which simulation time does not wait for). `dontwait`: the call
// itself does not block.
static void wait_readable(int fd, bool dontwait) noexcept {
  if (dontwait) return;
  struct pollfd p {fd, POLLIN, 0};
  const struct timespec zero {};
  if (g_real.ppoll(&p, 1, &zero, nullptr) != 0) return;  // readable, closed, or not pollable
  if (nonblocking(fd)) return;
  ThreadSlot* slot = self();
  if (slot == nullptr) return;
  touch(slot, Call::kRead);
  do {
    park(slot, lockstep::kNextEvent, kNever, Call::kRead);
    p.revents = 0;
  } while (on() && g_real.ppoll(&p, 1, &zero, nullptr) == 0);
}

SHIM_EXPORT ssize_t read(int fd, void* buffer, size_t n) {
  if (v4l2_fd(fd)) return v4l2_read(fd, buffer, n);
  NEED_REAL();
  if (!on()) return g_real.read(fd, buffer, n);
  if (VirtualTimer* timer = timer_of(fd)) return timer_read(*timer, buffer, n);
  const int bus = bus_of_fd(fd);
  if (bus >= 0) return bus_read(bus, fd, buffer, n);
  wait_readable(fd, false);
  return g_real.read(fd, buffer, n);
}

SHIM_EXPORT ssize_t recv(int fd, void* buffer, size_t n, int flags) {
  NEED_REAL();
  if (on()) wait_readable(fd, (flags & MSG_DONTWAIT) != 0);
  return g_real.recv(fd, buffer, n, flags);
}

SHIM_EXPORT ssize_t recvfrom(int fd, void* buffer, size_t n, int flags, struct sockaddr* from, socklen_t* from_size) {
  NEED_REAL();
  if (on()) wait_readable(fd, (flags & MSG_DONTWAIT) != 0);
  return g_real.recvfrom(fd, buffer, n, flags, from, from_size);
}

SHIM_EXPORT ssize_t recvmsg(int fd, struct msghdr* message, int flags) {
  NEED_REAL();
  if (on()) wait_readable(fd, (flags & MSG_DONTWAIT) != 0);
  return g_real.recvmsg(fd, message, flags);
}

// Bytes for another controller thread or process (a pipe, a socket): an event, so that a thread
// waiting to read them looks again before simulation time advances.
static void peer_io() noexcept {
  if (on() && t_slot != nullptr) g_clock->events.fetch_add(1, std::memory_order_acq_rel);
}

SHIM_EXPORT ssize_t write(int fd, const void* buffer, size_t n) {
  NEED_REAL();
  const int bus = g_clock != nullptr ? bus_of_fd(fd) : -1;
  // Wall-clock mode: wait until doppel has the bytes (port_table.h, await_handover). Lockstep has its own.
  const int port = g_clock == nullptr ? port_index_of_fd(fd) : -1;
  const uint64_t mark = port >= 0 ? handover_mark(port) : 0;
  const ssize_t r = g_real.write(fd, buffer, n);
  if (port >= 0 && r > 0) {
    const int saved = errno;
    await_handover(port, mark, static_cast<std::size_t>(r));
    errno = saved;
  }
  if (bus >= 0 && r > 0) {
    g_clock->buses[bus].client_written.fetch_add(static_cast<uint64_t>(r), std::memory_order_acq_rel);
    if (ThreadSlot* slot = self()) touch(slot, Call::kBusWrite);
  } else if (r > 0) {
    peer_io();
  }
  return r;
}

SHIM_EXPORT ssize_t send(int fd, const void* buffer, size_t n, int flags) {
  NEED_REAL();
  const ssize_t r = g_real.send(fd, buffer, n, flags);
  if (r > 0) peer_io();
  return r;
}

SHIM_EXPORT ssize_t sendto(int fd, const void* buffer, size_t n, int flags, const struct sockaddr* to, socklen_t to_size) {
  NEED_REAL();
  const ssize_t r = g_real.sendto(fd, buffer, n, flags, to, to_size);
  if (r > 0) peer_io();
  return r;
}

SHIM_EXPORT ssize_t sendmsg(int fd, const struct msghdr* message, int flags) {
  NEED_REAL();
  const ssize_t r = g_real.sendmsg(fd, message, flags);
  if (r > 0) peer_io();
  return r;
}

SHIM_EXPORT int timerfd_create(int clock, int flags) noexcept {
  NEED_REAL();
  const int fd = g_real.timerfd_create(clock, flags);
  if (fd < 0 || fd >= kMaxFds || !on() || !virtual_clock(clock)) return fd;
  VirtualTimer& timer = g_timers[fd];
  timer.clock.store(clock, std::memory_order_relaxed);
  timer.next_ns.store(0, std::memory_order_relaxed);
  timer.interval_ns.store(0, std::memory_order_relaxed);
  timer.nonblocking.store((flags & TFD_NONBLOCK) != 0, std::memory_order_relaxed);
  timer.used.store(true, std::memory_order_release);
  return fd;
}

static void current_setting(VirtualTimer& timer, struct itimerspec* out) noexcept {
  const int64_t next = timer.next_ns.load(std::memory_order_acquire);
  const int64_t left = next == 0 ? 0 : (next > sim_now() ? next - sim_now() : 1);
  out->it_value = timespec_of(left);
  out->it_interval = timespec_of(timer.interval_ns.load(std::memory_order_relaxed));
}

SHIM_EXPORT int timerfd_settime(int fd, int flags, const struct itimerspec* value, struct itimerspec* old) noexcept {
  NEED_REAL();
  VirtualTimer* timer = on() ? timer_of(fd) : nullptr;
  if (timer == nullptr || value == nullptr) return g_real.timerfd_settime(fd, flags, value, old);
  if (value->it_value.tv_nsec < 0 || value->it_value.tv_nsec >= kSecond || value->it_interval.tv_nsec < 0 ||
      value->it_interval.tv_nsec >= kSecond) {
    errno = EINVAL;
    return -1;
  }
  if (old != nullptr) current_setting(*timer, old);
  const int64_t v = ns_of(value->it_value);
  int64_t next = 0;
  if (v != 0) {
    next = (flags & TFD_TIMER_ABSTIME) != 0 ? sim_at(timer->clock.load(std::memory_order_relaxed), v) : sim_now() + v;
    if (next <= 0) next = 1;  // already due (0 means disarmed)
  }
  timer->interval_ns.store(ns_of(value->it_interval), std::memory_order_relaxed);
  timer->next_ns.store(next, std::memory_order_release);
  return 0;
}

SHIM_EXPORT int timerfd_gettime(int fd, struct itimerspec* value) noexcept {
  NEED_REAL();
  VirtualTimer* timer = on() ? timer_of(fd) : nullptr;
  if (timer == nullptr || value == nullptr) return g_real.timerfd_gettime(fd, value);
  current_setting(*timer, value);
  return 0;
}

SHIM_EXPORT int pthread_create(pthread_t* thread, const pthread_attr_t* attr, void* (*routine)(void*), void* argument) {
  NEED_REAL();
  const bool bypassing = g_clock != nullptr && t_bypass > 0;
  if (!on() && !bypassing) return g_real.pthread_create(thread, attr, routine, argument);
  auto* start = static_cast<ThreadStart*>(malloc(sizeof(ThreadStart)));
  if (start == nullptr) return EAGAIN;
  // The new thread runs (for doppel) from before it exists: time cannot pass before it first waits.
  *start = {routine, argument, bypassing ? nullptr : claim(0), bypassing};
  const int r = g_real.pthread_create(thread, attr, start_thread, start);
  if (r != 0) {
    release(start->slot);
    free(start);
  }
  return r;
}

SHIM_EXPORT int pthread_cond_wait(pthread_cond_t* cond, pthread_mutex_t* mutex) {
  NEED_REAL();
  if (self() == nullptr || g_real.cond_clockwait == nullptr) return g_real.cond_wait(cond, mutex);
  return peer_wait(cond, kNever, Call::kCondWait, Marked::kSpurious, [&](const struct timespec* until) {
    return g_real.cond_clockwait(cond, mutex, CLOCK_MONOTONIC, until);
  });
}

SHIM_EXPORT int pthread_cond_timedwait(pthread_cond_t* cond, pthread_mutex_t* mutex, const struct timespec* abstime) {
  NEED_REAL();
  if (self() == nullptr || g_real.cond_clockwait == nullptr) {
    return g_real.cond_timedwait(cond, mutex, abstime);
  }
  return peer_wait(cond, deadline_of(clock_of(cond), abstime), Call::kCondTimedwait, Marked::kSpurious, [&](const struct timespec* until) {
    return g_real.cond_clockwait(cond, mutex, CLOCK_MONOTONIC, until);
  });
}

SHIM_EXPORT int pthread_cond_clockwait(pthread_cond_t* cond, pthread_mutex_t* mutex, clockid_t clock,
                                       const struct timespec* abstime) {
  NEED_REAL();
  if (self() == nullptr || g_real.cond_clockwait == nullptr || !virtual_clock(clock)) {
    return g_real.cond_clockwait(cond, mutex, clock, abstime);
  }
  return peer_wait(cond, deadline_of(clock, abstime), Call::kCondTimedwait, Marked::kSpurious, [&](const struct timespec* until) {
    return g_real.cond_clockwait(cond, mutex, CLOCK_MONOTONIC, until);
  });
}

SHIM_EXPORT int pthread_cond_signal(pthread_cond_t* cond) {
  NEED_REAL();
  mark_woken(cond);
  return g_real.cond_signal(cond);
}

SHIM_EXPORT int pthread_cond_broadcast(pthread_cond_t* cond) {
  NEED_REAL();
  mark_woken(cond);
  return g_real.cond_broadcast(cond);
}

static int sem_result(int r) noexcept {
  if (r == 0) return 0;
  return errno;
}

static int sem_wait_until(sem_t* sem, int64_t deadline, Call call) noexcept {
  if (g_real.sem_trywait(sem) == 0) return 0;
  const int r = peer_wait(sem, deadline, call, Marked::kSticky, [&](const struct timespec* until) {
    return sem_result(g_real.sem_clockwait(sem, CLOCK_MONOTONIC, until));
  });
  if (r == 0) return 0;
  errno = r;
  return -1;
}

SHIM_EXPORT int sem_wait(sem_t* sem) {
  NEED_REAL();
  if (self() == nullptr || g_real.sem_clockwait == nullptr) return g_real.sem_wait(sem);
  return sem_wait_until(sem, kNever, Call::kSemWait);
}

SHIM_EXPORT int sem_timedwait(sem_t* sem, const struct timespec* abstime) {
  NEED_REAL();
  if (self() == nullptr || g_real.sem_clockwait == nullptr) return g_real.sem_timedwait(sem, abstime);
  return sem_wait_until(sem, deadline_of(CLOCK_REALTIME, abstime), Call::kSemTimedwait);
}

SHIM_EXPORT int sem_clockwait(sem_t* sem, clockid_t clock, const struct timespec* abstime) {
  NEED_REAL();
  if (self() == nullptr || g_real.sem_clockwait == nullptr || !virtual_clock(clock)) {
    return g_real.sem_clockwait(sem, clock, abstime);
  }
  return sem_wait_until(sem, deadline_of(clock, abstime), Call::kSemTimedwait);
}

SHIM_EXPORT int sem_post(sem_t* sem) {
  NEED_REAL();
  mark_woken(sem, true);
  return g_real.sem_post(sem);
}

SHIM_EXPORT int pthread_join(pthread_t thread, void** result) {
  NEED_REAL();
  if (self() == nullptr || g_real.clockjoin == nullptr) return g_real.join(thread, result);
  return peer_wait(reinterpret_cast<const void*>(thread), kNever, Call::kJoin, Marked::kSticky, [&](const struct timespec* until) {
    return g_real.clockjoin(thread, result, CLOCK_MONOTONIC, until);
  });
}
