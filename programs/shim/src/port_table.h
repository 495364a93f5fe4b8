#pragma once
// The shim's table of Doppel's ports (libdoppel_shim.so, docs/shim.md): each port the program may
// open, the settings a USB serial adapter keeps for it, and which of the program's descriptors are
// open on which port. The layer below the interposers: the serial-port half (shim.cpp) fills it at
// set-up and tracks descriptors, the lockstep half (lockstep_shim.cpp) looks descriptors up and
// waits for doppel's hand-over on writes; it calls neither. No allocation, no lock: fixed arrays of
// atomics, written before the program's main and read from any thread.

#include <atomic>
#include <cstddef>
#include <cstdint>

#include "shim/ftdi_serial.h"
#include "shim/port_map.h"

namespace doppel::shim {

// Descriptors tracked; a Doppel port opened above this passes through.
inline constexpr int kMaxFds = 4096;

// One of Doppel's ports as the program sees it. Settings are per port (as ftdi_private is per
// device), shared by every descriptor open on it.
struct Port {
  const char* link = nullptr;               // the mapping's link (points into the PortMap)
  char pts[64] = {};                        // what the link pointed at when the library loaded
  char latency_file[kMaxPathBytes + 16] = {};  // <link>.latency_timer (bus/latency_timer_files.h)
  char tty[kMaxPathBytes] = {};             // ttyUSB<n>: its sysfs latency_timer leads to latency_file
  int line = 0;                             // <n> of ttyUSB<n>, TIOCGSERIAL's line
  std::atomic<int> flags{0};
  std::atomic<int> custom_divisor{0};
  std::atomic<int> close_delay{kCloseDelay};
  std::atomic<int> closing_wait{kClosingWait};
  std::atomic<unsigned> dtr_rts{TIOCM_DTR | TIOCM_RTS};
  std::atomic<int> latency_before_low_ms{0};  // the file's value when ASYNC_LOW_LATENCY was set
  // <link>.received (base/pty_handover.h), mapped read-only: bytes doppel has read from the pty.
  // nullptr when doppel publishes none (then writes are not waited for).
  const std::atomic<uint64_t>* received = nullptr;
  std::atomic<uint64_t> expected{0};  // doppel's count once it has read everything written so far
};

// Set-up (the library's constructor, before any descriptor is tracked): slot `index` (below
// kMaxMappings) is filled in place, and the first `count` slots are the ports from then on.
Port& port_slot(std::size_t index) noexcept;
void set_port_count(std::size_t count) noexcept;
std::size_t port_count() noexcept;

// The Doppel port behind `fd` (its index, or the port itself), -1 / nullptr when it is not one.
int port_index_of_fd(int fd) noexcept;
Port* port_of_fd(int fd) noexcept;
// `fd` is open on port `port` from now on; false (nothing tracked) when `fd` is kMaxFds or above.
// A negative `fd` (a failed open) is ignored.
bool track(int fd, int port) noexcept;
// `to` is open on whatever `from` is (dup): a port, or none.
void copy_fd(int from, int to) noexcept;
void untrack(int fd) noexcept;
// The pty port `port`'s link led to when the library loaded, "" for no port.
const char* port_pts(int port) noexcept;

// For write(): a pty hands what a program writes to doppel in a kernel work item, which a program
// that busy-polls at real-time priority keeps off its own CPU (docs/shim.md, "Writes").
// handover_mark() before the write, await_handover() after it: sleeps in short steps until doppel
// has read the bytes (at most kHandoverLimitNs), as a USB adapter's write() hands them to the
// hardware in the caller's own context. No-ops for a port without doppel's counter.
uint64_t handover_mark(int port) noexcept;
void await_handover(int port, uint64_t mark, std::size_t written) noexcept;

}  // namespace doppel::shim
