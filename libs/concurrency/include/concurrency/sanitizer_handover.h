#pragma once
// ThreadSanitizer sees only the synchronisation of instrumented code. Memory handed from one
// thread to another through a channel built without it (iceoryx's shared-memory queues: Debian's
// libiceoryx is not instrumented) looks racy to it although the channel orders every access. The
// sender calls handing_over(memory) just before passing the memory on, the receiver taken_over(memory)
// just after getting it; the pair is the release/acquire the channel performs out of TSan's sight.
// Without -fsanitize=thread both are empty.

#if defined(__SANITIZE_THREAD__)
#include <sanitizer/tsan_interface.h>
#endif

namespace doppel::concurrency {

// Sender, just before `memory` leaves this thread (publish, or give a borrowed chunk back). rt-safe.
inline void handing_over([[maybe_unused]] const void* memory) noexcept {
#if defined(__SANITIZE_THREAD__)
  __tsan_release(const_cast<void*>(memory));
#endif
}

// Receiver, just after `memory` arrived from another thread (take, or loan a recycled chunk). rt-safe.
inline void taken_over([[maybe_unused]] const void* memory) noexcept {
#if defined(__SANITIZE_THREAD__)
  __tsan_acquire(const_cast<void*>(memory));
#endif
}

}  // namespace doppel::concurrency
