#pragma once
// Client-side helpers for the pty tests: what a servo-bus driver does with its serial port,
// written with plain POSIX calls (not with Doppel's code).

#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace doppel::bus::testing {

// A fresh directory (mode 0700) for one test's port link, removed afterwards.
class TempDir {
 public:
  TempDir() {
    static std::atomic<int> counter{0};
    path_ = std::filesystem::temp_directory_path() /
            ("doppel-bus-test-" + std::to_string(::getpid()) + "-" + std::to_string(counter++));
    std::filesystem::create_directory(path_);
    std::filesystem::permissions(path_, std::filesystem::perms::owner_all);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  std::string file(const std::string& name) const { return (path_ / name).string(); }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

// A client's file descriptor, closed when it goes out of scope (also when an ASSERT leaves early).
// Converts to the plain fd for the helpers below and for POSIX calls.
class ClientFd {
 public:
  explicit ClientFd(int fd) : fd_(fd) {}
  ~ClientFd() { close(); }
  ClientFd(const ClientFd&) = delete;
  ClientFd& operator=(const ClientFd&) = delete;

  operator int() const { return fd_; }
  // Closes now (the client hangs up); the destructor then does nothing.
  void close() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }

 private:
  int fd_;
};

// Opens the port as DynamixelSDK does (O_RDWR | O_NOCTTY | O_NONBLOCK).
inline int open_client(const std::string& path) { return ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK); }

// Writes every byte, waiting (up to 5 s in all) while the port's queue is full.
inline bool write_all(int fd, const std::vector<uint8_t>& bytes) {
  std::size_t done = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n > 0) {
      done += static_cast<std::size_t>(n);
      continue;
    }
    if (n < 0 && errno != EAGAIN && errno != EINTR) return false;
    if (std::chrono::steady_clock::now() > deadline) return false;
    pollfd p{fd, POLLOUT, 0};
    ::poll(&p, 1, 10);
  }
  return true;
}

// Reads until `n` bytes came or `timeout` passed; returns what came.
inline std::vector<uint8_t> read_bytes(int fd, std::size_t n, std::chrono::milliseconds timeout) {
  std::vector<uint8_t> out;
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (out.size() < n) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) break;
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, static_cast<int>(left.count())) <= 0) continue;
    uint8_t buffer[256];
    const ssize_t got = ::read(fd, buffer, std::min(sizeof(buffer), n - out.size()));
    if (got > 0) out.insert(out.end(), buffer, buffer + got);
    if (got < 0 && errno != EAGAIN && errno != EINTR) break;
  }
  return out;
}

// Bytes readable right now, without waiting.
inline std::vector<uint8_t> read_available(int fd) {
  std::vector<uint8_t> out;
  uint8_t buffer[256];
  for (;;) {
    const ssize_t got = ::read(fd, buffer, sizeof(buffer));
    if (got <= 0) break;
    out.insert(out.end(), buffer, buffer + got);
  }
  return out;
}

}  // namespace doppel::bus::testing
