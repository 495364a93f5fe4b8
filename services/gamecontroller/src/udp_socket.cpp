#include "gamecontroller/udp_socket.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <utility>

namespace doppel::gamecontroller {

namespace {
sockaddr_in to_sockaddr(const Endpoint& endpoint) {
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(endpoint.address);
  address.sin_port = htons(endpoint.port);
  return address;
}
}  // namespace

std::optional<std::uint32_t> parse_ipv4(const std::string& text) {
  in_addr address{};
  if (inet_pton(AF_INET, text.c_str(), &address) != 1) {
    return std::nullopt;
  }
  return ntohl(address.s_addr);
}

std::string to_string(const Endpoint& endpoint) {
  return std::to_string(endpoint.address >> 24) + "." + std::to_string((endpoint.address >> 16) & 0xff) + "." +
         std::to_string((endpoint.address >> 8) & 0xff) + "." + std::to_string(endpoint.address & 0xff) + ":" +
         std::to_string(endpoint.port);
}

std::optional<UdpSocket> UdpSocket::open(std::uint32_t address, std::uint16_t port, bool broadcast,
                                         std::string& error, bool reuse_address) {
  const Endpoint endpoint{address, port};
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    error = std::string("cannot open a UDP socket: ") + std::strerror(errno);
    return std::nullopt;
  }
  UdpSocket socket(fd);
  const int on = 1;
  if (broadcast && ::setsockopt(fd, SOL_SOCKET, SO_BROADCAST, &on, sizeof on) != 0) {
    error = std::string("cannot allow broadcast: ") + std::strerror(errno);
    return std::nullopt;
  }
  if (reuse_address && ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &on, sizeof on) != 0) {
    error = std::string("cannot share the address (SO_REUSEADDR): ") + std::strerror(errno);
    return std::nullopt;
  }
  const sockaddr_in bind_address = to_sockaddr(endpoint);
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&bind_address), sizeof bind_address) != 0) {
    error = "cannot bind UDP " + to_string(endpoint) + ": " + std::strerror(errno);
    return std::nullopt;
  }
  return socket;
}

UdpSocket::UdpSocket(UdpSocket&& other) noexcept : fd_(std::exchange(other.fd_, -1)) {}

UdpSocket& UdpSocket::operator=(UdpSocket&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) {
      ::close(fd_);
    }
    fd_ = std::exchange(other.fd_, -1);
  }
  return *this;
}

UdpSocket::~UdpSocket() {
  if (fd_ >= 0) {
    ::close(fd_);
  }
}

std::uint16_t UdpSocket::local_port() const {
  sockaddr_in address{};
  socklen_t length = sizeof address;
  if (::getsockname(fd_, reinterpret_cast<sockaddr*>(&address), &length) != 0) {
    return 0;
  }
  return ntohs(address.sin_port);
}

bool UdpSocket::send_to(const Endpoint& to, std::span<const std::uint8_t> bytes, std::string& error) {
  const sockaddr_in address = to_sockaddr(to);
  const ssize_t sent = ::sendto(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL,
                                reinterpret_cast<const sockaddr*>(&address), sizeof address);
  if (sent != static_cast<ssize_t>(bytes.size())) {
    error = "cannot send to " + to_string(to) + ": " + std::strerror(errno);
    return false;
  }
  return true;
}

std::optional<std::size_t> UdpSocket::receive(std::span<std::uint8_t> buffer, std::chrono::milliseconds timeout,
                                              Endpoint* from) {
  pollfd waiting{fd_, POLLIN, 0};
  if (::poll(&waiting, 1, static_cast<int>(timeout.count())) <= 0) {
    return std::nullopt;
  }
  sockaddr_in address{};
  socklen_t length = sizeof address;
  // MSG_TRUNC: the return value is the datagram's real length, so an oversized one is recognised.
  const ssize_t received = ::recvfrom(fd_, buffer.data(), buffer.size(), MSG_TRUNC | MSG_DONTWAIT,
                                      reinterpret_cast<sockaddr*>(&address), &length);
  if (received < 0) {
    return std::nullopt;
  }
  if (from != nullptr) {
    *from = Endpoint{ntohl(address.sin_addr.s_addr), ntohs(address.sin_port)};
  }
  return static_cast<std::size_t>(received);
}

}  // namespace doppel::gamecontroller
