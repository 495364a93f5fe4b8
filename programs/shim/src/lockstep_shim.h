#pragma once
// What the serial-port part of the shim (shim.cpp) tells its lockstep part (lockstep_shim.cpp), one
// way: the lockstep part calls nothing of shim.cpp, and finds ports through the port table
// (port_table.h) both use.

namespace doppel::shim {

// `fd` is about to be closed; input of a bus `fd` is about to be flushed (done = false) or was
// flushed (done = true). No-ops without lockstep.
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
