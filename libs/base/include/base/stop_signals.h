#pragma once
// How Doppel's long-running commands are stopped: SIGINT and SIGTERM are blocked before any thread
// starts, so every thread inherits the mask and one thread takes them with sigwait() and stops the
// rest in order; a reader that left (SIGPIPE) is an error value of write(), not a signal.

#include <signal.h>

namespace doppel {

// Blocks SIGINT and SIGTERM in the calling thread (and the threads it starts later), ignores
// SIGPIPE, and returns the blocked set for sigwait(). Call before starting threads.
inline sigset_t block_stop_signals() noexcept {
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);
  signal(SIGPIPE, SIG_IGN);
  return stop_signals;
}

}  // namespace doppel
