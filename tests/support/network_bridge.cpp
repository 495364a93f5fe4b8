#include "network_bridge.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <thread>

namespace doppel::testing {

std::string serve_network_script() { return DOPPEL_SOURCE_DIR "/scripts/serve-network"; }

std::optional<std::string> find_program(const std::string& program) {
  const char* path = std::getenv("PATH");
  std::istringstream dirs(path != nullptr ? path : "/usr/bin:/bin:/usr/sbin:/sbin");
  for (std::string dir; std::getline(dirs, dir, ':');) {
    std::string candidate = dir + "/" + program;
    if (!dir.empty() && ::access(candidate.c_str(), X_OK) == 0) {
      return candidate;
    }
  }
  return std::nullopt;
}

namespace {

// True if nothing listens on 127.0.0.1:`port` (we could bind it).
bool loopback_port_free(int port) {
  int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) {
    return false;
  }
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  address.sin_port = htons(static_cast<uint16_t>(port));
  bool free = ::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)) == 0;
  ::close(fd);
  return free;
}

// A port the kernel picks for 127.0.0.1 (an ephemeral one: never a well-known service).
int kernel_picked_port() {
  int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) {
    throw std::runtime_error("socket() failed");
  }
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t length = sizeof(address);
  if (::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)) != 0 ||
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length) != 0) {
    ::close(fd);
    throw std::runtime_error("cannot bind a loopback port");
  }
  ::close(fd);
  return ntohs(address.sin_port);
}

}  // namespace

int free_loopback_ports(int count) {
  for (int attempt = 0; attempt < 100; ++attempt) {
    int first = kernel_picked_port();
    bool all_free = first + count - 1 <= 65535;
    for (int i = 1; i < count && all_free; ++i) {
      all_free = loopback_port_free(first + i);
    }
    if (all_free) {
      return first;
    }
  }
  throw std::runtime_error("no " + std::to_string(count) + " consecutive free loopback ports");
}

ChildProcess::ChildProcess(std::vector<std::string> argv) {
  char file_template[] = "/tmp/doppel-child-XXXXXX";
  int out = ::mkstemp(file_template);
  if (out < 0) {
    throw std::runtime_error("mkstemp failed");
  }
  output_file_ = file_template;
  std::vector<char*> args;
  for (std::string& arg : argv) {
    args.push_back(arg.data());
  }
  args.push_back(nullptr);
  pid_ = ::fork();
  if (pid_ < 0) {
    ::close(out);
    throw std::runtime_error("fork failed");
  }
  if (pid_ == 0) {
    ::setpgid(0, 0);
    ::dup2(out, 1);
    ::dup2(out, 2);
    ::execvp(args[0], args.data());
    _exit(127);
  }
  ::setpgid(pid_, pid_);  // also here, so stop() never races the child's own setpgid
  ::close(out);
}

ChildProcess::~ChildProcess() {
  stop();
  ::unlink(output_file_.c_str());
}

bool ChildProcess::running() {
  if (pid_ <= 0) {
    return false;
  }
  int status = 0;
  if (::waitpid(pid_, &status, WNOHANG) == pid_) {
    ::kill(-pid_, SIGTERM);  // whatever it left in its group
    pid_ = -1;
    return false;
  }
  return true;
}

void ChildProcess::stop() {
  if (pid_ <= 0) {
    return;
  }
  ::kill(-pid_, SIGTERM);
  int status = 0;
  auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (::waitpid(pid_, &status, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() > deadline) {
      ::kill(-pid_, SIGKILL);
      ::waitpid(pid_, &status, 0);
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ::kill(-pid_, SIGKILL);  // ser2net's or socat's own children, if any are left
  pid_ = -1;
}

std::string ChildProcess::output() const {
  std::ifstream in(output_file_);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

NetworkBridge::NetworkBridge(const std::string& link_dir, int first_port, unsigned baud_bps, int link_index,
                             const std::string& pty_link, const std::vector<std::string>& extra_serve_args)
    : pty_link_(pty_link),
      server_([&] {
        std::vector<std::string> argv = {serve_network_script(), "--link-dir", link_dir, "--port",
                                         std::to_string(first_port), "--baud", std::to_string(baud_bps)};
        argv.insert(argv.end(), extra_serve_args.begin(), extra_serve_args.end());
        return argv;
      }()) {
  // socat retries the connection while ser2net starts; the pty appears before it connects, and
  // bytes a driver writes meanwhile wait in the pty until socat forwards them.
  const std::string tcp = "TCP:127.0.0.1:" + std::to_string(first_port + link_index) + ",retry=200,interval=0.05";
  socat_.emplace(std::vector<std::string>{"socat", "PTY,link=" + pty_link_ + ",raw,echo=0", tcp});
  auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (!std::filesystem::exists(pty_link_)) {
    if (!server_.running() || !socat_->running() || std::chrono::steady_clock::now() > deadline) {
      throw std::runtime_error("network bridge to " + pty_link_ + " did not start: " + output());
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

NetworkBridge::~NetworkBridge() {
  socat_.reset();
  server_.stop();
}

std::string NetworkBridge::output() const {
  return "[serve-network] " + server_.output() + " [socat] " + (socat_ ? socat_->output() : std::string());
}

}  // namespace doppel::testing
