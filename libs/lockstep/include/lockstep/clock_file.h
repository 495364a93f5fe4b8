#pragma once
// The lockstep clock file: one shared-memory page set that `doppel --lockstep` creates in its link
// directory and the preload library (libdoppel_shim.so under `doppel-run --lockstep`) maps into the
// controller's process. It holds the simulation time, one slot per controller thread (running, or
// waiting for a time and/or the next event) and per-bus byte counters. Everything in it is a
// lock-free atomic; threads of both processes block on its futex words (FUTEX_WAIT, not PRIVATE).
// docs/lockstep.md describes the protocol. Header-only, std + Linux only: the shim links no C++
// runtime.

#include <atomic>
#include <cstddef>
#include <cstdint>

namespace doppel::lockstep {

inline constexpr uint64_t kMagic = 0x4b434f4c4c505044ULL;  // "DPPLLOCK"
inline constexpr uint32_t kVersion = 1;
inline constexpr std::size_t kMaxThreads = 256;  // controller threads at once (a slot is freed at thread exit)
inline constexpr std::size_t kMaxBuses = 32;
inline constexpr std::size_t kPathBytes = 256;
inline constexpr const char* kClockFileName = "lockstep.clock";  // in doppel's link directory
inline constexpr const char* kClockVariable = "DOPPEL_LOCKSTEP";  // the file's path, set by doppel-run
// CLOCK_MONOTONIC and CLOCK_BOOTTIME read this much more than the simulation time: a machine that
// has been up for 1000 s. Many programs take a zero time stamp for "never".
inline constexpr int64_t kMonotonicOffsetNs = 1'000'000'000'000;
inline constexpr int64_t kNever = INT64_MAX;

enum ThreadState : uint32_t {
  kFree = 0,
  kRunning = 1,  // doppel waits for it before simulation time advances
  kWaiting = 2,  // parked on its futex until doppel wakes it (see WaitFlags)
};

enum WaitFlags : uint32_t {
  kUntilTime = 1,   // wake when simulation time reaches wake_ns
  kNextEvent = 2,   // wake at the next event after event_mark: time advanced or bus bytes delivered
  kPeer = 4,        // blocked on another controller thread (condition variable, semaphore): doppel never wakes it, the peer does
  kDelivery = 8,    // wake when a bus delivered bytes after delivery_mark (a poll of bus descriptors only)
};

// The intercepted call a thread made last (the watchdog names it).
enum class Call : uint32_t {
  kNone, kStart, kClockGettime, kGettimeofday, kTime, kNanosleep, kClockNanosleep, kUsleep, kSleep,
  kPoll, kPpoll, kSelect, kPselect, kEpollWait, kTimerfdRead, kBusRead, kBusWrite, kCondWait,
  kCondTimedwait, kSemWait, kSemTimedwait, kJoin, kRead, kCamera, kCount,
};

inline const char* call_name(uint32_t call) noexcept {
  static constexpr const char* kNames[] = {
      "none", "thread start", "clock_gettime", "gettimeofday", "time", "nanosleep", "clock_nanosleep",
      "usleep", "sleep", "poll", "ppoll", "select", "pselect", "epoll_wait", "read(timerfd)",
      "read(bus)", "write(bus)", "pthread_cond_wait", "pthread_cond_timedwait", "sem_wait",
      "sem_timedwait", "pthread_join", "read/recv (blocking)", "VIDIOC_DQBUF/read(camera)",
  };
  static_assert(sizeof(kNames) / sizeof(kNames[0]) == static_cast<std::size_t>(Call::kCount));
  return call < static_cast<uint32_t>(Call::kCount) ? kNames[call] : "?";
}

// One controller thread. Written by the thread (state -> kWaiting, the wait fields, activity) and by
// doppel (state -> kRunning when it wakes it; kFree for a thread that died).
struct alignas(64) ThreadSlot {
  std::atomic<uint32_t> state{kFree};
  std::atomic<uint32_t> wake_seq{0};    // futex word the thread sleeps on; doppel bumps it to wake it
  std::atomic<uint32_t> flags{0};       // WaitFlags of the current wait
  std::atomic<uint32_t> last_call{0};   // Call
  std::atomic<int64_t> wake_ns{kNever};     // kUntilTime: simulation time to wake at
  std::atomic<uint64_t> event_mark{0};      // kNextEvent: ClockFile::events when the wait began
  std::atomic<uint64_t> delivery_mark{0};   // kDelivery: ClockFile::deliveries when the wait began
  std::atomic<uint64_t> calls{0};           // intercepted calls since the thread started (watchdog)
  std::atomic<uint64_t> waits{0};           // waits begun since the thread started (watchdog)
  std::atomic<uint64_t> clock_reads{0};     // clock reads in a row, since the thread last waited or made another call
  std::atomic<int32_t> pid{0};
  std::atomic<int32_t> tid{0};
};

// One bus of doppel. Byte counters are totals since doppel started, so that each side knows how
// many bytes the pty still has in flight: doppel reads until it has what the controller wrote
// before it waited, the controller's reads wait until the pty holds what doppel delivered.
struct alignas(64) BusSlot {
  char slave[kPathBytes] = {};  // the pty's slave (/dev/pts/N), written before the file is published
  char link[kPathBytes] = {};   // the stable link (ttyDXL<n>)
  std::atomic<uint64_t> client_written{0};  // bytes the controller wrote (shim)
  std::atomic<uint64_t> client_read{0};     // bytes the controller read or discarded (shim)
  std::atomic<uint64_t> delivered{0};       // bytes doppel wrote to the pty (doppel)
};

struct ClockFile {
  uint64_t magic = 0;  // kMagic once the file is complete
  uint32_t version = kVersion;
  uint32_t bus_count = 0;
  int64_t epoch_realtime_ns = 0;            // CLOCK_REALTIME = this + simulation time
  std::atomic<int64_t> sim_ns{0};           // simulation time (doppel writes, everyone reads)
  std::atomic<uint64_t> events{0};          // bumped when time advances or a bus delivers bytes
  std::atomic<uint64_t> deliveries{0};      // bumped when a bus delivers bytes
  std::atomic<uint32_t> slots_used{0};      // threads[0, slots_used) were ever claimed (doppel scans no further)
  std::atomic<uint32_t> coordinator_seq{0};  // futex word doppel sleeps on; threads bump it when they wait or leave
  std::atomic<uint32_t> open{1};            // 0 once doppel stops: every call passes through again
  BusSlot buses[kMaxBuses];
  ThreadSlot threads[kMaxThreads];
};

static_assert(std::atomic<int64_t>::is_always_lock_free && std::atomic<uint64_t>::is_always_lock_free &&
              std::atomic<uint32_t>::is_always_lock_free && std::atomic<int32_t>::is_always_lock_free);
static_assert(sizeof(std::atomic<uint32_t>) == 4, "futex words are 32 bit");

}  // namespace doppel::lockstep
