#pragma once
// Counts calls of the global operator new made by threads that asked to be counted, so a test can
// prove that a real-time path (a bus thread, the camera thread) allocates nothing. Linking
// doppel::allocation_counter replaces the global operator new of the whole executable: give such
// a test its own executable.

#include <cstdint>

namespace doppel::testing {

// Starts (true) or stops (false) counting the calling thread's allocations.
void count_allocations_on_this_thread(bool on) noexcept;
// Allocations counted so far, all threads.
uint64_t counted_allocations() noexcept;

}  // namespace doppel::testing
