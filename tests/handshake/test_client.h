#pragma once
// A handshake client for tests, written from libs/proto/handshake.proto's framing rule (4-byte
// little-endian length, then the message), not from the server's encoder; and raw bytes for the
// tests that send what no client should.

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

#include "proto/handshake.pb.h"

namespace doppel::handshake::testing {

namespace wire = doppel::proto::handshake;

class TestClient {
 public:
  static TestClient unix_socket(const std::string& path) {
    TestClient c(socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0));
    sockaddr_un address{};
    address.sun_family = AF_UNIX;
    std::strncpy(address.sun_path, path.c_str(), sizeof address.sun_path - 1);
    if (connect(c.fd_, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) {
      throw std::runtime_error("connect " + path + ": " + std::strerror(errno));
    }
    return c;
  }
  static TestClient tcp(uint16_t port) {
    TestClient c(socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0));
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(port);
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (connect(c.fd_, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) {
      throw std::runtime_error("connect 127.0.0.1:" + std::to_string(port) + ": " + std::strerror(errno));
    }
    return c;
  }

  TestClient(TestClient&& other) noexcept : fd_(other.fd_) { other.fd_ = -1; }
  TestClient& operator=(TestClient&&) = delete;
  ~TestClient() { close(); }
  void close() {
    if (fd_ >= 0) {
      ::close(fd_);
      fd_ = -1;
    }
  }

  void send_raw(std::string_view bytes) {
    std::size_t sent = 0;
    while (sent < bytes.size()) {
      const ssize_t n = ::send(fd_, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
      if (n <= 0) {
        throw std::runtime_error(std::string("send: ") + std::strerror(errno));
      }
      sent += static_cast<std::size_t>(n);
    }
  }
  static std::string frame(std::string_view payload) {
    const auto n = static_cast<uint32_t>(payload.size());
    std::string out = {static_cast<char>(n & 0xFF), static_cast<char>((n >> 8) & 0xFF),
                       static_cast<char>((n >> 16) & 0xFF), static_cast<char>((n >> 24) & 0xFF)};
    return out + std::string(payload);
  }
  void send(const wire::ClientMessage& message) { send_raw(frame(message.SerializeAsString())); }

  // The next reply, or nullopt when the server closed the connection or nothing came in time.
  std::optional<wire::ServerMessage> receive(std::chrono::milliseconds timeout = std::chrono::seconds(20)) {
    std::string header;
    if (!read_exactly(4, header, timeout)) {
      return std::nullopt;
    }
    const uint32_t n = static_cast<uint8_t>(header[0]) | static_cast<uint8_t>(header[1]) << 8 |
                       static_cast<uint8_t>(header[2]) << 16 | static_cast<uint32_t>(static_cast<uint8_t>(header[3])) << 24;
    std::string payload;
    if (n > (1u << 24) || !read_exactly(n, payload, timeout)) {
      return std::nullopt;
    }
    wire::ServerMessage message;
    if (!message.ParseFromString(payload)) {
      return std::nullopt;
    }
    return message;
  }

  wire::ServerMessage call(const wire::ClientMessage& request) {
    send(request);
    std::optional<wire::ServerMessage> reply = receive();
    if (!reply) {
      throw std::runtime_error("no reply to " + request.ShortDebugString());
    }
    return *reply;
  }

  // Sends `bytes` repeatedly without reading any reply until the socket accepts no more (the
  // server stopped reading because its replies are not read) or `limit` bytes went; returns the bytes sent.
  std::size_t flood(std::string_view bytes, std::size_t limit) {
    std::size_t total = 0;
    while (total < limit) {
      const ssize_t n = ::send(fd_, bytes.data(), bytes.size(), MSG_DONTWAIT | MSG_NOSIGNAL);
      if (n <= 0) {
        break;
      }
      total += static_cast<std::size_t>(n);
    }
    return total;
  }
  // True once a write fails because the server closed the connection, within `timeout`; never reads.
  bool write_refused(std::chrono::milliseconds timeout = std::chrono::seconds(20)) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
      const char byte = 0;
      if (::send(fd_, &byte, 1, MSG_DONTWAIT | MSG_NOSIGNAL) < 0 && (errno == EPIPE || errno == ECONNRESET)) {
        return true;
      }
      ::usleep(20000);
    }
    return false;
  }

  // True when the server closes the connection (end of stream) within `timeout`; replies before
  // that are skipped.
  bool closed_by_server(std::chrono::milliseconds timeout = std::chrono::seconds(20)) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    char buffer[4096];
    while (true) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
      pollfd p{fd_, POLLIN, 0};
      if (left.count() <= 0 || poll(&p, 1, static_cast<int>(left.count())) <= 0) {
        return false;
      }
      const ssize_t n = ::recv(fd_, buffer, sizeof buffer, 0);
      if (n == 0 || (n < 0 && errno == ECONNRESET)) {
        return true;
      }
      if (n < 0) {
        return false;
      }
    }
  }

 private:
  explicit TestClient(int fd) : fd_(fd) {
    if (fd_ < 0) {
      throw std::runtime_error(std::string("socket: ") + std::strerror(errno));
    }
  }

  bool read_exactly(std::size_t n, std::string& out, std::chrono::milliseconds timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    out.clear();
    char buffer[4096];
    while (out.size() < n) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
      pollfd p{fd_, POLLIN, 0};
      if (left.count() <= 0 || poll(&p, 1, static_cast<int>(left.count())) <= 0) {
        return false;
      }
      const ssize_t got = ::recv(fd_, buffer, std::min(sizeof buffer, n - out.size()), 0);
      if (got <= 0) {
        return false;
      }
      out.append(buffer, static_cast<std::size_t>(got));
    }
    return true;
  }

  int fd_ = -1;
};

}  // namespace doppel::handshake::testing
