#include "truth/subscriber.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <stdexcept>
#include <thread>
#include <vector>

#include "iceoryx_posh/mepoo/chunk_header.hpp"
#include "iceoryx_posh/popo/untyped_subscriber.hpp"
#include "proto/truth.pb.h"
#include "truth/transport.h"

namespace doppel::truth {
namespace {

iox::capro::IdString_t id(const std::string& text) { return iox::capro::IdString_t(iox::cxx::TruncateToCapacity, text); }

}  // namespace

struct IceoryxSubscriber::Impl {
  Impl(std::size_t robot, const std::string& topic, uint64_t queue)
      : port(iox::capro::ServiceDescription(id(kServiceId), id("robot" + std::to_string(robot)), id(topic)), options(queue)) {}
  static iox::popo::SubscriberOptions options(uint64_t queue) {
    iox::popo::SubscriberOptions o;
    o.queueCapacity = queue;
    o.historyRequest = 1;
    o.queueFullPolicy = iox::popo::QueueFullPolicy::DISCARD_OLDEST_DATA;
    return o;
  }
  iox::popo::UntypedSubscriber port;
};

IceoryxSubscriber::IceoryxSubscriber(std::size_t robot, const std::string& topic, uint64_t queue)
    : impl_(std::make_unique<Impl>(robot, topic, queue)) {}

IceoryxSubscriber::~IceoryxSubscriber() = default;

std::optional<std::string> IceoryxSubscriber::take(double timeout_s) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (true) {
    std::optional<std::string> out;
    impl_->port.take().and_then([&](const void* payload) {
      const auto* header = iox::mepoo::ChunkHeader::fromUserPayload(payload);
      out.emplace(static_cast<const char*>(payload), header->userPayloadSize());
      impl_->port.release(payload);
    });
    if (out || std::chrono::steady_clock::now() >= deadline) return out;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

UdpReceiver::UdpReceiver(uint16_t port, const std::string& address) {
  in_addr addr{};
  if (::inet_pton(AF_INET, address.c_str(), &addr) != 1) {
    throw std::runtime_error("'" + address + "' is not an IPv4 address");
  }
  socket_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (socket_ < 0) throw std::runtime_error(std::string("UDP socket: ") + std::strerror(errno));
  const int size = 4 << 20;  // room for bursts while the reader is descheduled
  ::setsockopt(socket_, SOL_SOCKET, SO_RCVBUF, &size, sizeof size);
  sockaddr_in at{};
  at.sin_family = AF_INET;
  at.sin_addr = addr;
  at.sin_port = htons(port);
  if (::bind(socket_, reinterpret_cast<const sockaddr*>(&at), sizeof at) != 0) {
    const std::string why = std::strerror(errno);
    ::close(socket_);
    throw std::runtime_error("cannot listen on UDP " + address + ":" + std::to_string(port) + ": " + why);
  }
  socklen_t length = sizeof at;
  ::getsockname(socket_, reinterpret_cast<sockaddr*>(&at), &length);
  port_ = ntohs(at.sin_port);
}

UdpReceiver::~UdpReceiver() {
  if (socket_ >= 0) ::close(socket_);
}

std::optional<Datagram> UdpReceiver::receive(double timeout_s) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  std::vector<char> buffer(65536);
  while (true) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    pollfd fd{socket_, POLLIN, 0};
    if (::poll(&fd, 1, static_cast<int>(std::max<int64_t>(0, left.count()))) <= 0) {
      if (std::chrono::steady_clock::now() >= deadline) return std::nullopt;
      continue;
    }
    const ssize_t n = ::recv(socket_, buffer.data(), buffer.size(), 0);
    if (n < 0) continue;
    proto::truth::Packet packet;
    if (!packet.ParseFromArray(buffer.data(), static_cast<int>(n)) || packet.topic().empty()) {
      ++malformed_;
      continue;
    }
    return Datagram{packet.robot(), packet.topic(), packet.payload()};
  }
}

}  // namespace doppel::truth
