#pragma once
// Runs the real `doppel` executable as a child process for integration tests, with its own link
// directory, and stops it with SIGTERM as a user would.

#include <sys/types.h>

#include <cstdint>

#include <string>
#include <utility>
#include <vector>

namespace doppel::testing {

class DoppelProcess {
 public:
  // Starts doppel with `args` plus --link-dir (a fresh temporary directory), --state-dir (a fresh
  // one beside it, unless `args` name one) and, unless `camera`,
  // --no-camera (only one iceoryx RouDi serves a machine: camera tests hold a CTest lock), unless
  // `args` name --viewer, --no-viewer (no test takes the default control port), unless they name
  // --handshake-port, --no-handshake-tcp (nor the handshake's), and
  // waits until `link_name` (e.g. "ttyDXL0") exists in it. Throws std::runtime_error if it does not start.
  DoppelProcess(std::vector<std::string> args, const std::string& link_name = "ttyDXL0", bool camera = false);
  // Stops the process if still running.
  ~DoppelProcess();
  DoppelProcess(const DoppelProcess&) = delete;
  DoppelProcess& operator=(const DoppelProcess&) = delete;

  const std::string& link_dir() const { return link_dir_; }
  std::string link(const std::string& name = "ttyDXL0") const { return link_dir_ + "/" + name; }
  // Sends `signal` and waits for the exit; returns the wait status.
  int stop(int signal = 15);
  // Everything the process wrote to stdout and stderr so far.
  std::string output() const;
  // Waits up to 30 s (a sanitizer build starts slowly) until the output contains `text` (e.g.
  // doppel's "running until" line, printed once it serves every port); returns the output then.
  std::string wait_for_output(const std::string& text) const;
  pid_t pid() const { return pid_; }
  // The run's access token for its TCP listener on `port` (the control API or the handshake), read
  // as every client reads it (contract::find_access_token: LINK_DIR/token-PORT); "" without one.
  std::string access_token(uint16_t port) const;

 private:
  pid_t pid_ = -1;
  std::string link_dir_;
  std::string output_file_;
};

// Path of the doppel executable under test: $DOPPEL_EXECUTABLE if set (a benchmark comparing two
// builds), else the one this build made.
std::string doppel_executable();

// Runs `command` in a shell as a user would type it; returns its exit code and everything it wrote
// to stdout and stderr.
std::pair<int, std::string> run_command(const std::string& command);

}  // namespace doppel::testing
