#include "allocation_counter.h"

#include <atomic>
#include <cstdlib>
#include <new>

namespace {

thread_local bool counting = false;
std::atomic<uint64_t> allocations{0};

}  // namespace

void* operator new(std::size_t size) {
  if (counting) {
    allocations.fetch_add(1, std::memory_order_relaxed);
  }
  if (void* p = std::malloc(size == 0 ? 1 : size)) {
    return p;
  }
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }

namespace doppel::testing {

void count_allocations_on_this_thread(bool on) noexcept { counting = on; }

uint64_t counted_allocations() noexcept { return allocations.load(std::memory_order_relaxed); }

}  // namespace doppel::testing
