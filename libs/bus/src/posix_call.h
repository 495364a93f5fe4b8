#pragma once
// The one place where raw POSIX return values become results: EINTR is retried, EAGAIN /
// EWOULDBLOCK is reported as "would block", anything else as an errno value. Private to bus/.

#include <cerrno>

namespace doppel::bus::detail {

struct SysResult {
  long value = -1;  // the call's return value when ok
  int error = 0;    // errno when not ok; 0 when ok

  bool ok() const noexcept { return error == 0; }
  bool would_block() const noexcept { return error == EAGAIN || error == EWOULDBLOCK; }
};

// Calls `call` (a lambda returning a negative value and setting errno on failure) until it is not
// interrupted by a signal. rt-safe as long as `call` is.
template <class Call>
SysResult posix_call(Call&& call) noexcept {
  for (;;) {
    const long r = static_cast<long>(call());
    if (r >= 0) return {r, 0};
    if (errno == EINTR) continue;
    return {-1, errno != 0 ? errno : EIO};
  }
}

}  // namespace doppel::bus::detail
