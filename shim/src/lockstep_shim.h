#pragma once
// Between the serial-port part of the shim (shim.cpp) and its lockstep part (lockstep_shim.cpp).

#include <cstddef>
#include <cstdint>

namespace doppel::shim {

// shim.cpp: the Doppel port behind `fd` (index), -1 when it is not one; the pty its link led to.
int port_index_of_fd(int fd) noexcept;
const char* port_pts(int port) noexcept;

// shim.cpp, for write(): a pty hands what a program writes to doppel in a kernel work item, which
// a program that busy-polls at real-time priority keeps off its own CPU (docs/shim.md, "Writes").
// handover_mark() before the write, await_handover() after it: sleeps in short steps until doppel
// has read the bytes (at most kHandoverLimitNs), as a USB adapter's write() hands them to the
// hardware in the caller's own context. No-ops for a port without doppel's counter.
uint64_t handover_mark(int port) noexcept;
void await_handover(int port, uint64_t mark, std::size_t written) noexcept;

// lockstep_shim.cpp: `fd` is about to be closed; input of a bus `fd` is about to be flushed
// (done = false) or was flushed (done = true). No-ops without lockstep.
void lockstep_closing(int fd) noexcept;
void lockstep_flushing(int fd, int queue, bool done) noexcept;

// lockstep_shim.cpp, for the camera part (v4l2_shim.cpp). True when doppel's clock file is in use
// (the camera module then runs in lockstep); true for the calling thread when its calls are
// simulation time now (false while it bypasses).
bool lockstep_clock() noexcept;
bool lockstep_thread() noexcept;
// Simulation time (ns); the clock reading CLOCK_MONOTONIC gives at simulation time 0.
int64_t lockstep_sim_ns() noexcept;
int64_t lockstep_monotonic_offset_ns() noexcept;
// The calling thread waits until the next event (simulation time advanced, a bus delivered): a
// camera call that would block (DQBUF, read) looks again then.
void lockstep_wait_event() noexcept;
// While one exists, the calling thread's intercepted calls pass straight to libc and the thread
// stays running for doppel (simulation time stands still): the camera module's own work with
// iceoryx (registration, discovery, waiting for a subscription) takes no simulation time and
// cannot depend on how fast RouDi answers. Threads created meanwhile (iceoryx's) bypass for good.
// The calling thread bypasses from now on (it is exiting: the module's and iceoryx's teardown).
void lockstep_bypass_for_good() noexcept;
class LockstepBypass {
 public:
  LockstepBypass() noexcept;
  ~LockstepBypass();
  LockstepBypass(const LockstepBypass&) = delete;
  LockstepBypass& operator=(const LockstepBypass&) = delete;
};

}  // namespace doppel::shim
