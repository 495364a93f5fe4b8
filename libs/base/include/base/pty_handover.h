#pragma once
// The hand-over counter doppel keeps beside each port link (`ttyDXL0.received`), shared by the
// port that publishes it (bus/pty_port.h) and the preload library that waits on it (shim/).
//
// Why: a pty hands the bytes a program writes to doppel in a kernel work item (tty flip buffer,
// an unbound kworker) that the scheduler often queues on the writer's own CPU. A program that then
// busy-polls for the answer at real-time priority (the DARwIn-OP framework's SCHED_RR 31 motion
// timer) keeps that CPU, so doppel does not see its packet until the poll has timed out; with the
// other core busy nothing else runs the work item. A USB adapter's write() hands the bytes to the
// hardware in the caller's own context, so on a robot the packet leaves at once. doppel counts the
// bytes it has read from the port in this file; the preload library lets write() return once
// doppel has them, sleeping in short steps meanwhile (the CPU is free for the work item).
//
// Layout: 8 bytes, one std::atomic<uint64_t> (lock-free, address-free on the platforms Doppel
// builds for), bytes read from every client of the port since doppel created it, never
// decreasing. Written by doppel's bus thread only.

#include <atomic>
#include <cstddef>
#include <cstdint>

namespace doppel {

inline constexpr const char* kHandoverSuffix = ".received";  // <link>.received
inline constexpr std::size_t kHandoverFileBytes = sizeof(uint64_t);
// A write waits at most this long for doppel (stopped or stalled: the program then goes on).
inline constexpr int64_t kHandoverLimitNs = 100'000'000;
// One sleep while it waits: short against a packet's wire time, long enough to leave the CPU.
inline constexpr long kHandoverPauseNs = 20'000;

static_assert(std::atomic<uint64_t>::is_always_lock_free, "the hand-over counter is shared between processes");

}  // namespace doppel
