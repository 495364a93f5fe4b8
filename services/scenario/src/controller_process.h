#pragma once
// A scenario's controller: a child process in a process group of its own (so that everything it
// starts goes with it), its stdout and stderr in files, ended with SIGTERM and then SIGKILL. Setup
// code on the main thread; may throw.

#include <sys/types.h>

#include <optional>
#include <string>
#include <vector>

namespace doppel::scenario {

// The program file `name` stands for: with a '/' relative to `folder` (if relative), else the first
// executable `name` in `tool_dirs`, then on PATH. Empty when there is none.
std::string find_program(const std::string& name, const std::string& folder, const std::vector<std::string>& tool_dirs);

class ControllerProcess {
 public:
  // Starts `argv` (argv[0] a resolved path) with stdout and stderr to `output_prefix`.stdout/.stderr.
  // Throws std::runtime_error naming the program when it cannot be started (exec failed).
  ControllerProcess(const std::vector<std::string>& argv, const std::string& output_prefix);
  ~ControllerProcess();  // stop()s
  ControllerProcess(const ControllerProcess&) = delete;
  ControllerProcess& operator=(const ControllerProcess&) = delete;

  // True once it has exited (reaps it without waiting).
  bool exited();
  // Ends it if it still runs (SIGTERM to its group, SIGKILL after `grace_ms`), then kills what is
  // left of its group. Idempotent.
  void stop(int grace_ms = 2000);

  std::optional<int> exit_code() const noexcept { return exit_code_; }   // normal exit
  std::optional<int> signal() const noexcept { return signal_; }         // killed by it
  bool stopped_by_us() const noexcept { return stopped_by_us_; }
  pid_t pid() const noexcept { return pid_; }
  // The last `bytes` of what it wrote (whole lines where possible).
  std::string stderr_tail(std::size_t bytes = 2000) const;
  std::string stdout_tail(std::size_t bytes = 2000) const;

 private:
  void record(int status) noexcept;

  pid_t pid_ = -1;
  bool running_ = false;
  bool stopped_by_us_ = false;
  std::optional<int> exit_code_, signal_;
  std::string stdout_path_, stderr_path_;
};

}  // namespace doppel::scenario
