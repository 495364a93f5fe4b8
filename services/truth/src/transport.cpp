#include "truth/transport.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstring>
#include <stdexcept>

#include "iceoryx_posh/popo/untyped_publisher.hpp"
#include "proto/truth.pb.h"

namespace doppel::truth {
namespace {

iox::capro::IdString_t id(const std::string& text) { return iox::capro::IdString_t(iox::cxx::TruncateToCapacity, text); }

}  // namespace

std::string iceoryx_location(std::size_t robot, std::string_view topic) {
  return std::string("iceoryx:") + kServiceId + "/robot" + std::to_string(robot) + "/" + std::string(topic);
}

std::vector<std::string> topic_locations(const TransportOptions& options, std::size_t robot, std::string_view topic) {
  std::vector<std::string> locations;
  if (options.iceoryx) locations.push_back(iceoryx_location(robot, topic));
  if (options.udp) {
    locations.push_back("udp:" + options.udp_address + ":" + std::to_string(options.udp_base_port + robot));
  }
  return locations;
}

struct Transport::Publisher {
  explicit Publisher(std::size_t robot, const std::string& topic)
      : port(iox::capro::ServiceDescription(id(kServiceId), id("robot" + std::to_string(robot)), id(topic)), options()) {}
  static iox::popo::PublisherOptions options() {
    iox::popo::PublisherOptions o;
    o.historyCapacity = 1;  // a late subscriber gets the newest message at once
    o.subscriberTooSlowPolicy = iox::popo::ConsumerTooSlowPolicy::DISCARD_OLDEST_DATA;
    return o;
  }
  iox::popo::UntypedPublisher port;
};

Transport::Transport(TransportOptions options) : options_(std::move(options)) {
  if (!options_.udp) return;
  in_addr address{};
  if (::inet_pton(AF_INET, options_.udp_address.c_str(), &address) != 1) {
    throw std::invalid_argument("truth UDP address '" + options_.udp_address + "' is not an IPv4 address");
  }
  if (options_.udp_base_port == 0 || options_.udp_base_port > 65535 - 64) {
    throw std::invalid_argument("truth UDP base port must be within 1..65471 (robot N sends to base + N), got " +
                                std::to_string(options_.udp_base_port));
  }
  address_ = address.s_addr;
  socket_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  if (socket_ < 0) throw std::runtime_error(std::string("truth UDP socket: ") + std::strerror(errno));
}

Transport::~Transport() {
  robots_.clear();
  if (socket_ >= 0) ::close(socket_);
}

void Transport::add_robot(std::size_t robot) { robots_.try_emplace(robot); }

void Transport::remove_robot(std::size_t robot) { robots_.erase(robot); }

bool Transport::has_robot(std::size_t robot) const { return robots_.count(robot) > 0; }

void Transport::send(std::size_t robot, const std::string& topic, std::string_view bytes) {
  const auto it = robots_.find(robot);
  if (it == robots_.end()) return;
  if (options_.iceoryx) {
    std::unique_ptr<Publisher>& publisher = it->second[topic];
    if (publisher == nullptr) publisher = std::make_unique<Publisher>(robot, topic);
    auto loaned = publisher->port.loan(static_cast<uint32_t>(bytes.size() == 0 ? 1 : bytes.size()));
    if (loaned.has_error()) {
      ++stats_.iceoryx_dropped;
    } else {
      void* chunk = loaned.value();
      std::memcpy(chunk, bytes.data(), bytes.size());
      publisher->port.publish(chunk);
      ++stats_.iceoryx_sent;
    }
  }
  if (socket_ >= 0) {
    proto::truth::Packet packet;
    packet.set_robot(static_cast<uint32_t>(robot));
    packet.set_topic(topic);
    packet.set_payload(bytes.data(), bytes.size());
    const std::string datagram = packet.SerializeAsString();
    sockaddr_in to{};
    to.sin_family = AF_INET;
    to.sin_addr.s_addr = address_;
    to.sin_port = htons(udp_port(robot));
    const ssize_t sent = ::sendto(socket_, datagram.data(), datagram.size(), 0, reinterpret_cast<const sockaddr*>(&to), sizeof to);
    ++(sent == static_cast<ssize_t>(datagram.size()) ? stats_.udp_sent : stats_.udp_failed);
  }
}

}  // namespace doppel::truth
