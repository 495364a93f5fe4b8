#pragma once
// A small IPv4 UDP socket (POSIX) for the GameController: bind, send to an address, receive with a
// timeout. Errors come back as messages naming the address and the system's reason.

#include <chrono>
#include <cstdint>
#include <optional>
#include <span>
#include <string>

namespace doppel::gamecontroller {

struct Endpoint {
  std::uint32_t address = 0;  // host byte order
  std::uint16_t port = 0;
};

// "a.b.c.d" to an address, or nullopt (no name lookup: the user types the address).
std::optional<std::uint32_t> parse_ipv4(const std::string& text);
std::string to_string(const Endpoint& endpoint);

class UdpSocket {
 public:
  // Binds to address:port (port 0: the system picks one, see local_port()). With `broadcast` the
  // socket may send to a broadcast address; only set when the user named such an address.
  // With `reuse_address` (SO_REUSEADDR, never SO_REUSEPORT) it may share the port with other
  // sockets that set it too. Returns nullopt and fills `error` when the socket cannot be opened or bound.
  static std::optional<UdpSocket> open(std::uint32_t address, std::uint16_t port, bool broadcast, std::string& error,
                                       bool reuse_address = false);

  UdpSocket(UdpSocket&& other) noexcept;
  UdpSocket& operator=(UdpSocket&& other) noexcept;
  UdpSocket(const UdpSocket&) = delete;
  UdpSocket& operator=(const UdpSocket&) = delete;
  ~UdpSocket();

  std::uint16_t local_port() const;
  // False when the system refused the datagram (the message is in `error`).
  bool send_to(const Endpoint& to, std::span<const std::uint8_t> bytes, std::string& error);
  // Waits up to `timeout` for one datagram; returns its full length (which may exceed
  // buffer.size(): the datagram was truncated) or nullopt on timeout or error.
  std::optional<std::size_t> receive(std::span<std::uint8_t> buffer, std::chrono::milliseconds timeout,
                                     Endpoint* from = nullptr);

 private:
  explicit UdpSocket(int fd) : fd_(fd) {}
  int fd_ = -1;
};

}  // namespace doppel::gamecontroller
