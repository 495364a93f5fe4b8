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

}  // namespace doppel::shim
