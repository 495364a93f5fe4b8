#include "bus/spin_budget.h"

#include <unistd.h>

namespace doppel::bus {

bool SpinBudget::try_acquire() noexcept {
  int free = free_.load(std::memory_order_relaxed);
  while (free > 0) {
    if (free_.compare_exchange_weak(free, free - 1, std::memory_order_acquire, std::memory_order_relaxed)) return true;
  }
  return false;
}

SpinBudget& SpinBudget::process() noexcept {
  static SpinBudget budget(static_cast<int>(::sysconf(_SC_NPROCESSORS_ONLN)) - 1);
  return budget;
}

}  // namespace doppel::bus
