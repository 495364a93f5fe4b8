#include "lockstep/coordinator.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <new>
#include <stdexcept>

#include "base/monotonic_clock.h"
#include "lockstep/futex.h"

namespace doppel::lockstep {
namespace {

constexpr int64_t kPollWallNs = 50'000'000;  // settle(): how often stop, liveness and the watchdog are checked

// A process that exited but was not reaped yet still answers kill(0): its /proc state is Z (or X).
bool zombie(int32_t pid) {
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string line;
  std::getline(stat, line);
  const std::size_t close = line.rfind(')');
  return close != std::string::npos && close + 2 < line.size() && (line[close + 2] == 'Z' || line[close + 2] == 'X');
}

bool alive(int32_t pid, int32_t tid) noexcept {
  if (pid <= 0) return true;  // a slot being claimed (the shim sets pid last)
  try {
    if (zombie(pid)) return false;
  } catch (...) {
    // Unreadable /proc: fall back on the signal check.
  }
  if (tid > 0) {
    return ::syscall(SYS_tgkill, pid, tid, 0) == 0 || errno != ESRCH;
  }
  return ::kill(pid, 0) == 0 || errno != ESRCH;
}

std::string thread_name(int32_t pid, int32_t tid) {
  std::ifstream comm("/proc/" + std::to_string(pid) + "/task/" + std::to_string(tid) + "/comm");
  std::string name;
  std::getline(comm, name);
  return name.empty() ? "?" : name;
}

}  // namespace

Coordinator::Coordinator(std::string path, const std::vector<LockstepBus>& buses, const CoordinatorOptions& options)
    : path_(std::move(path)), options_(options), report_(options.report != nullptr ? options.report : &std::cerr),
      watches_(kMaxThreads) {
  if (buses.size() > kMaxBuses) {
    throw std::invalid_argument("lockstep: at most " + std::to_string(kMaxBuses) + " buses");
  }
  for (const LockstepBus& bus : buses) {
    if (bus.link.size() >= kPathBytes || bus.slave.size() >= kPathBytes) {
      throw std::invalid_argument("lockstep: the path " + bus.link + " is too long for the clock file");
    }
  }
  // Built under a temporary name and renamed into place: a controller never maps half a file.
  const std::string temporary = path_ + ".new";
  ::unlink(temporary.c_str());
  const int fd = ::open(temporary.c_str(), O_RDWR | O_CREAT | O_EXCL | O_CLOEXEC | O_NOFOLLOW, 0600);
  if (fd < 0) {
    throw std::runtime_error("lockstep: cannot create the clock file " + temporary + ": " + std::strerror(errno));
  }
  const long page = ::sysconf(_SC_PAGESIZE);
  mapped_bytes_ = (sizeof(ClockFile) + static_cast<std::size_t>(page) - 1) / static_cast<std::size_t>(page) *
                  static_cast<std::size_t>(page);
  void* memory = MAP_FAILED;
  if (::ftruncate(fd, static_cast<off_t>(mapped_bytes_)) == 0) {
    memory = ::mmap(nullptr, mapped_bytes_, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
  }
  const int error = errno;
  ::close(fd);
  if (memory == MAP_FAILED) {
    ::unlink(temporary.c_str());
    throw std::runtime_error("lockstep: cannot map the clock file " + temporary + ": " + std::strerror(error));
  }
  file_ = new (memory) ClockFile();
  file_->epoch_realtime_ns = options.epoch_realtime_ns >= 0 ? options.epoch_realtime_ns : clock_now_ns(CLOCK_REALTIME);
  file_->sim_ns.store(options.start_ns, std::memory_order_relaxed);
  file_->bus_count = static_cast<uint32_t>(buses.size());
  for (std::size_t b = 0; b < buses.size(); ++b) {
    std::memcpy(file_->buses[b].link, buses[b].link.c_str(), buses[b].link.size() + 1);
    std::memcpy(file_->buses[b].slave, buses[b].slave.c_str(), buses[b].slave.size() + 1);
  }
  std::atomic_thread_fence(std::memory_order_release);
  file_->magic = kMagic;
  if (::msync(memory, mapped_bytes_, MS_SYNC) != 0 || ::rename(temporary.c_str(), path_.c_str()) != 0) {
    const int rename_error = errno;
    ::munmap(memory, mapped_bytes_);
    ::unlink(temporary.c_str());
    throw std::runtime_error("lockstep: cannot publish the clock file " + path_ + ": " + std::strerror(rename_error));
  }
}

Coordinator::~Coordinator() {
  if (file_ == nullptr) return;
  file_->open.store(0, std::memory_order_release);
  for (ThreadSlot& slot : file_->threads) {
    if (slot.state.load(std::memory_order_acquire) == kWaiting) wake(slot);
  }
  ::unlink(path_.c_str());
  ::munmap(file_, mapped_bytes_);
}

void Coordinator::wake(ThreadSlot& slot) noexcept {
  slot.state.store(kRunning, std::memory_order_seq_cst);
  slot.wake_seq.fetch_add(1, std::memory_order_seq_cst);
  futex_wake_all(slot.wake_seq);
}

bool Coordinator::settle(const std::atomic<bool>& stop) noexcept {
  for (;;) {
    const uint32_t seq = file_->coordinator_seq.load(std::memory_order_acquire);
    bool running = false;
    for (const ThreadSlot& slot : used()) {
      if (slot.state.load(std::memory_order_acquire) == kRunning) {
        running = true;
        break;
      }
    }
    if (!running) return true;
    if (stop.load(std::memory_order_relaxed)) return false;
    const int64_t before = monotonic_now_ns();
    futex_wait(file_->coordinator_seq, seq, kPollWallNs);
    if (file_->coordinator_seq.load(std::memory_order_acquire) == seq && monotonic_now_ns() - before >= kPollWallNs / 2) {
      remove_gone();
      watch(monotonic_now_ns());
    }
  }
}

void Coordinator::watch(int64_t wall_ns) noexcept {
  for (std::size_t i = 0; i < used().size(); ++i) {
    ThreadSlot& slot = file_->threads[i];
    Watch& w = watches_[i];
    const uint64_t waits = slot.waits.load(std::memory_order_acquire);
    if (slot.state.load(std::memory_order_acquire) != kRunning || waits != w.waits || w.since_wall_ns == 0) {
      w.waits = waits;
      w.since_wall_ns = wall_ns;
      w.reported_wall_ns = 0;
      continue;
    }
    const int64_t ran_ns = wall_ns - w.since_wall_ns;
    const int64_t again_ns = 6 * options_.watchdog_ns;
    if (ran_ns < options_.watchdog_ns || (w.reported_wall_ns != 0 && wall_ns - w.reported_wall_ns < again_ns)) continue;
    w.reported_wall_ns = wall_ns;
    ++watchdog_reports_;
    const int32_t pid = slot.pid.load(std::memory_order_relaxed);
    const int32_t tid = slot.tid.load(std::memory_order_relaxed);
    const uint32_t last = slot.last_call.load(std::memory_order_relaxed);
    std::ostream& out = *report_;
    out << "doppel: lockstep watchdog: controller thread " << tid << " (" << thread_name(pid, tid) << ") of process "
        << pid << " has run " << std::fixed << std::setprecision(1) << static_cast<double>(ran_ns) * 1e-9
        << " s of wall time without a wait doppel can see, so simulation time stands still at " << std::setprecision(3)
        << static_cast<double>(now_ns()) * 1e-9 << " s; its last intercepted call: " << call_name(last);
    if (last == static_cast<uint32_t>(Call::kClockGettime)) {
      out << " (" << slot.clock_reads.load(std::memory_order_relaxed) << " clock reads in a row)";
    }
    out << ". A busy loop, a raw system call or a lock held across a wait is not seen (docs/lockstep.md).\n"
        << std::flush;
  }
}

void Coordinator::remove_gone() noexcept {
  for (ThreadSlot& slot : used()) {
    if (slot.state.load(std::memory_order_acquire) == kFree) continue;
    if (!alive(slot.pid.load(std::memory_order_relaxed), slot.tid.load(std::memory_order_relaxed))) {
      slot.pid.store(0, std::memory_order_relaxed);
      slot.state.store(kFree, std::memory_order_release);
      ++removed_;
    }
  }
}

bool Coordinator::wake_one() noexcept {
  const int64_t now = now_ns();
  const uint64_t events = file_->events.load(std::memory_order_acquire);
  const uint64_t deliveries = file_->deliveries.load(std::memory_order_acquire);
  for (ThreadSlot& slot : used()) {
    if (slot.state.load(std::memory_order_acquire) != kWaiting) continue;
    const uint32_t flags = slot.flags.load(std::memory_order_acquire);
    const bool time_up = (flags & kUntilTime) != 0 && slot.wake_ns.load(std::memory_order_acquire) <= now;
    const bool event = (flags & kNextEvent) != 0 && slot.event_mark.load(std::memory_order_acquire) < events;
    const bool delivery = (flags & kDelivery) != 0 && slot.delivery_mark.load(std::memory_order_acquire) < deliveries;
    if (time_up || event || delivery) {
      wake(slot);
      return true;
    }
  }
  return false;
}

std::size_t Coordinator::threads() const noexcept {
  std::size_t n = 0;
  for (const ThreadSlot& slot : used()) n += slot.state.load(std::memory_order_acquire) != kFree ? 1 : 0;
  return n;
}

bool Coordinator::wait_for_threads(int64_t timeout_ns) noexcept {
  const uint32_t seq = file_->coordinator_seq.load(std::memory_order_acquire);
  remove_gone();
  if (threads() > 0) return true;
  futex_wait(file_->coordinator_seq, seq, timeout_ns);
  return threads() > 0;
}

int64_t Coordinator::earliest_wake_ns() const noexcept {
  int64_t earliest = kNever;
  for (const ThreadSlot& slot : used()) {
    if (slot.state.load(std::memory_order_acquire) != kWaiting) continue;
    if ((slot.flags.load(std::memory_order_acquire) & kUntilTime) == 0) continue;
    earliest = std::min(earliest, slot.wake_ns.load(std::memory_order_acquire));
  }
  return earliest;
}

void Coordinator::advance_to(int64_t sim_ns) noexcept {
  if (sim_ns > now_ns()) file_->sim_ns.store(sim_ns, std::memory_order_release);
  file_->events.fetch_add(1, std::memory_order_acq_rel);
}

uint64_t Coordinator::client_written(std::size_t bus) const noexcept {
  return file_->buses[bus].client_written.load(std::memory_order_acquire);
}

void Coordinator::set_delivered(std::size_t bus, uint64_t total) noexcept {
  if (file_->buses[bus].delivered.load(std::memory_order_relaxed) == total) return;
  file_->buses[bus].delivered.store(total, std::memory_order_release);
  file_->deliveries.fetch_add(1, std::memory_order_acq_rel);
  file_->events.fetch_add(1, std::memory_order_acq_rel);
}

}  // namespace doppel::lockstep
