#pragma once
// Between the serial-port part of the shim (shim.cpp) and its lockstep part (lockstep_shim.cpp).

namespace doppel::shim {

// shim.cpp: the Doppel port behind `fd` (index), -1 when it is not one; the pty its link led to.
int port_index_of_fd(int fd) noexcept;
const char* port_pts(int port) noexcept;

// lockstep_shim.cpp: `fd` is about to be closed; input of a bus `fd` is about to be flushed
// (done = false) or was flushed (done = true). No-ops without lockstep.
void lockstep_closing(int fd) noexcept;
void lockstep_flushing(int fd, int queue, bool done) noexcept;

}  // namespace doppel::shim
