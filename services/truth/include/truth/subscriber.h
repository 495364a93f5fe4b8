#pragma once
// The receiving side of the truth transport (transport.h), for doppel-truth, tests and control
// software in C++: a robot's topic over iceoryx, or every datagram arriving on a UDP port.

#include <cstdint>
#include <memory>
#include <optional>
#include <string>

namespace doppel::truth {

// Subscribes to ("DoppelTruth", "robot<robot>", topic). Requires this process registered with
// RouDi (camera::connect_client, or a roudi::Host). Queues up to `queue` messages.
class IceoryxSubscriber {
 public:
  IceoryxSubscriber(std::size_t robot, const std::string& topic, uint64_t queue = 256);
  ~IceoryxSubscriber();
  IceoryxSubscriber(const IceoryxSubscriber&) = delete;
  IceoryxSubscriber& operator=(const IceoryxSubscriber&) = delete;
  // The next message's bytes, waiting up to `timeout_s`; nullopt when none came.
  std::optional<std::string> take(double timeout_s);

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

struct Datagram {
  uint32_t robot = 0;
  std::string topic;
  std::string payload;  // the serialised message
};

// Binds `address`:`port` (port 0: any free port). Throws std::runtime_error naming the address.
class UdpReceiver {
 public:
  explicit UdpReceiver(uint16_t port, const std::string& address = "127.0.0.1");
  ~UdpReceiver();
  UdpReceiver(const UdpReceiver&) = delete;
  UdpReceiver& operator=(const UdpReceiver&) = delete;
  uint16_t port() const noexcept { return port_; }
  // The next datagram that parses as a proto::truth::Packet (others are counted and skipped),
  // waiting up to `timeout_s`.
  std::optional<Datagram> receive(double timeout_s);
  uint64_t malformed() const noexcept { return malformed_; }

 private:
  int socket_ = -1;
  uint16_t port_ = 0;
  uint64_t malformed_ = 0;
};

}  // namespace doppel::truth
