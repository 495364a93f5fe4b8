#pragma once
// doppel's side of lockstep time (docs/lockstep.md): creates and owns the clock file, lets the
// controller's threads run until every one of them waits, wakes them one at a time when their
// wait is over, and advances simulation time only when nobody runs. The simulation thread calls
// it; it decides nothing about physics or buses (the gateway's lockstep loop does).
//
// A watchdog (wall time) names a thread that runs too long without a wait the shim can see, and a
// thread whose process or thread is gone is removed, so a controller that crashes or is killed
// never stops the simulation for good.

#include <atomic>
#include <cstdint>
#include <iosfwd>
#include <span>
#include <string>
#include <vector>

#include "lockstep/clock_file.h"

namespace doppel::lockstep {

struct CoordinatorOptions {
  int64_t watchdog_ns = 5'000'000'000;  // wall time a thread may run without waiting before it is reported
  int64_t epoch_realtime_ns = -1;        // CLOCK_REALTIME at simulation time 0; < 0 = the wall clock now
  int64_t start_ns = 0;                  // simulation time at start (the world's)
  std::ostream* report = nullptr;        // watchdog messages; nullptr = std::cerr
};

struct LockstepBus {
  std::string link;   // ttyDXL<n>
  std::string slave;  // /dev/pts/N behind it
};

class Coordinator {
 public:
  // Creates the clock file at `path` (replacing a stale one) and publishes it. Throws
  // std::runtime_error naming the path when it cannot, std::invalid_argument for too many buses.
  Coordinator(std::string path, const std::vector<LockstepBus>& buses, const CoordinatorOptions& options = {});
  // Closes the clock (every waiting thread wakes and passes through from then on), removes the file.
  ~Coordinator();
  Coordinator(const Coordinator&) = delete;
  Coordinator& operator=(const Coordinator&) = delete;

  const std::string& path() const noexcept { return path_; }
  int64_t now_ns() const noexcept { return file_->sim_ns.load(std::memory_order_acquire); }
  // The simulation clock, for components that read time (bus::BusServerOptions::clock).
  const std::atomic<int64_t>& clock() const noexcept { return file_->sim_ns; }

  // Blocks until no registered thread runs (true), or until `stop` (false). Runs the watchdog and
  // removes threads that are gone while it waits.
  bool settle(const std::atomic<bool>& stop) noexcept;
  // Wakes the first waiting thread (slot order) whose wait is over at the current time. True if it
  // woke one (call settle() again before anything else).
  bool wake_one() noexcept;
  // Registered threads (running or waiting).
  std::size_t threads() const noexcept;
  // Blocks (wall time, at most `timeout_ns`) until a thread registers; true if one is registered.
  bool wait_for_threads(int64_t timeout_ns) noexcept;
  // The earliest simulation time a waiting thread wants to be woken at; kNever if none.
  int64_t earliest_wake_ns() const noexcept;
  // Advances simulation time (never backwards) and counts an event.
  void advance_to(int64_t sim_ns) noexcept;
  // Bus counters (docs/lockstep.md): what the controller wrote, and what doppel delivered so far.
  uint64_t client_written(std::size_t bus) const noexcept;
  void set_delivered(std::size_t bus, uint64_t total) noexcept;

  // Times the watchdog reported a thread; threads removed because they were gone.
  uint64_t watchdog_reports() const noexcept { return watchdog_reports_; }
  uint64_t threads_removed() const noexcept { return removed_; }

 private:
  struct Watch {
    uint64_t waits = 0;       // the slot's wait count when the coordinator last saw it change
    int64_t since_wall_ns = 0;  // wall time since the thread has been running without a wait
    int64_t reported_wall_ns = 0;  // last report, 0 = none for this stretch
  };
  void watch(int64_t wall_ns) noexcept;
  void remove_gone() noexcept;
  void wake(ThreadSlot& slot) noexcept;
  // The slots ever claimed (the rest are free).
  std::span<ThreadSlot> used() const noexcept {
    const uint32_t n = file_->slots_used.load(std::memory_order_acquire);
    return {file_->threads, n < kMaxThreads ? n : kMaxThreads};
  }

  std::string path_;
  CoordinatorOptions options_;
  std::ostream* report_;
  ClockFile* file_ = nullptr;
  std::size_t mapped_bytes_ = 0;
  std::vector<Watch> watches_;
  uint64_t watchdog_reports_ = 0;
  uint64_t removed_ = 0;
};

}  // namespace doppel::lockstep
