#pragma once
// doppel started as a user starts it (its defaults: camera, viewer, handshake), with a link
// directory watched with inotify from before the start, so that a port's link is seen the moment it
// appears: what a script that opens the port as soon as it exists sees. The viewer and the
// handshake take free ports (0): tests and benchmarks run side by side. Used by the first-answer
// test (tests/gateway/camera) and bench/first_answer.

#include <sys/types.h>

#include <string>
#include <vector>

namespace doppel::testing {

class WatchedDoppel {
 public:
  // Starts doppel_executable() with --link-dir, --state-dir (fresh, in a temporary directory),
  // --viewer 0 --handshake-port 0 and `extra`. Throws std::runtime_error when it cannot.
  explicit WatchedDoppel(std::vector<std::string> extra);
  // Kills doppel if it still runs; removes the temporary directory.
  ~WatchedDoppel();
  WatchedDoppel(const WatchedDoppel&) = delete;
  WatchedDoppel& operator=(const WatchedDoppel&) = delete;

  // Returns the link's path as soon as inotify reports `name` in the link directory (created or
  // renamed into place). Throws when doppel exits first or nothing comes within `guard_ms`.
  std::string wait_for_link(const std::string& name, int guard_ms = 20'000);
  // The names of doppel's threads now (/proc/PID/task/*/comm).
  std::vector<std::string> thread_names() const;
  // SIGTERM, waits for the exit, then everything doppel wrote (its counters come last).
  std::string stop();
  // Everything doppel wrote to stdout and stderr so far.
  std::string output() const;
  pid_t pid() const { return pid_; }

 private:
  std::string dir_;
  std::string links_;
  int inotify_ = -1;
  pid_t pid_ = -1;
};

}  // namespace doppel::testing
