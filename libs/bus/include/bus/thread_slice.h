#pragma once
// The calling thread's EEVDF slice (Linux 6.12+: sched_attr's sched_runtime for SCHED_OTHER), which
// decides how soon a woken bus thread may preempt the task holding its core. Shared by the bus
// server, which asks for a short one, and its tests, which read it back.

#include <cstdint>
#include <optional>

namespace doppel::bus {

// The slice the calling thread has (0 = the kernel's default); nullopt without sched_getattr.
std::optional<uint64_t> thread_slice_ns() noexcept;

// Asks for a slice of `slice_ns` (0 = the kernel's default) for the calling thread if it runs
// SCHED_OTHER; returns the one it had, nullopt when nothing changed (another policy, or a kernel
// without sched_setattr).
std::optional<uint64_t> request_thread_slice_ns(uint64_t slice_ns) noexcept;

}  // namespace doppel::bus
