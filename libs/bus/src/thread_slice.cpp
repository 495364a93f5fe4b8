#include "bus/thread_slice.h"

#include <sched.h>
#include <sys/syscall.h>
#include <unistd.h>

namespace doppel::bus {
namespace {

// The kernel's struct sched_attr (linux/sched/types.h, which clashes with glibc's <sched.h>); glibc
// has no sched_getattr / sched_setattr wrappers.
struct SchedAttr {
  uint32_t size = sizeof(SchedAttr);
  uint32_t sched_policy = 0;
  uint64_t sched_flags = 0;
  int32_t sched_nice = 0;
  uint32_t sched_priority = 0;
  uint64_t sched_runtime = 0;  // SCHED_OTHER since Linux 6.12: the thread's slice (EEVDF custom slice)
  uint64_t sched_deadline = 0;
  uint64_t sched_period = 0;
  uint32_t sched_util_min = 0;
  uint32_t sched_util_max = 0;
};

bool get_attr(SchedAttr& attr) noexcept { return ::syscall(SYS_sched_getattr, 0, &attr, sizeof(attr), 0) == 0; }

}  // namespace

std::optional<uint64_t> thread_slice_ns() noexcept {
  SchedAttr attr;
  if (!get_attr(attr)) return std::nullopt;
  return attr.sched_runtime;
}

std::optional<uint64_t> request_thread_slice_ns(uint64_t slice_ns) noexcept {
  SchedAttr attr;
  if (!get_attr(attr) || attr.sched_policy != SCHED_OTHER) return std::nullopt;
  const uint64_t old_slice = attr.sched_runtime;
  attr.size = sizeof(attr);
  attr.sched_flags = 0;
  attr.sched_runtime = slice_ns;
  if (::syscall(SYS_sched_setattr, 0, &attr, 0) != 0) return std::nullopt;
  return old_slice;
}

}  // namespace doppel::bus
