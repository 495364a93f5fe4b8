#pragma once
// A Doppel link carried over TCP the way a robot on another machine reaches it: scripts/serve-network
// (ser2net) serves doppel's links on loopback, and socat gives the "robot" a local pty bridged to
// one of them. Used by the network test and the network_latency benchmark.

#include <sys/types.h>

#include <optional>
#include <string>
#include <vector>

namespace doppel::testing {

// The full path of `program` on PATH, or nullopt when it is not installed.
std::optional<std::string> find_program(const std::string& program);

// A loopback TCP port nobody listens on, with the `count` - 1 ports after it free as well (the
// kernel picks it; another process may still take it before we bind it).
int free_loopback_ports(int count);

// A program run in its own process group, its output kept in a file; stopped (SIGTERM, then
// SIGKILL after 5 s) with its whole group when destroyed.
class ChildProcess {
 public:
  explicit ChildProcess(std::vector<std::string> argv);
  ~ChildProcess();
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  // True while it runs.
  bool running();
  std::string output() const;
  void stop();

 private:
  pid_t pid_ = -1;
  std::string output_file_;
};

class NetworkBridge {
 public:
  // Serves every link in `link_dir` with scripts/serve-network from `first_port` at `baud_bps`, and
  // bridges a new pty (`pty_link`) to the `link_index`-th of them with socat. Throws
  // std::runtime_error naming what did not start.
  NetworkBridge(const std::string& link_dir, int first_port, unsigned baud_bps, int link_index,
                const std::string& pty_link, const std::vector<std::string>& extra_serve_args = {});
  ~NetworkBridge();
  NetworkBridge(const NetworkBridge&) = delete;
  NetworkBridge& operator=(const NetworkBridge&) = delete;

  // The robot's side: a pty path a driver opens like a serial port.
  const std::string& path() const { return pty_link_; }
  // What ser2net and socat printed, for failure messages.
  std::string output() const;

 private:
  std::string pty_link_;
  ChildProcess server_;
  std::optional<ChildProcess> socat_;
};

// Path of scripts/serve-network in the source tree.
std::string serve_network_script();

}  // namespace doppel::testing
