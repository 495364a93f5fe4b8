#pragma once
// The truth transport: serialised messages of any topic of any robot, published over iceoryx on
// ("DoppelTruth", "robot<N>", topic) (payload = the message) and over UDP to ADDRESS:BASE+N (a
// proto::truth::Packet naming robot and topic around the message). Generic over (robot, topic,
// bytes), so that every kind of ground truth (the world model, sensor levels) shares it. Robots come
// and go while it runs (add_robot / remove_robot). iceoryx types stay out of this header.
//
// Threads: one thread (the publisher thread) calls everything after construction. Not on the
// simulation thread: it allocates (a topic's publisher on its first message, the UDP packet).

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>
#include <string_view>
#include <utility>

namespace doppel::truth {

inline constexpr const char kServiceId[] = "DoppelTruth";
inline constexpr uint16_t kDefaultUdpBasePort = 7600;  // robot N: 7600 + N

// ("DoppelTruth", "robot<N>", topic) as "iceoryx:DoppelTruth/robot<N>/<topic>" (contract::Link's location).
std::string iceoryx_location(std::size_t robot, std::string_view topic);

struct TransportOptions {
  bool iceoryx = true;       // needs this process registered with RouDi (a roudi::Host or connect_client)
  bool udp = true;
  uint16_t udp_base_port = kDefaultUdpBasePort;   // robot N sends to base + N
  std::string udp_address = "127.0.0.1";           // IPv4 address; another than loopback only when the user names it
};

// Where robot `robot`'s messages of `topic` can be received, as contract::Link locations: its
// iceoryx service (when `options.iceoryx`) and "udp:ADDRESS:PORT" (when `options.udp`; every topic
// of a robot shares its port, each datagram a truth.Packet naming the topic).
std::vector<std::string> topic_locations(const TransportOptions& options, std::size_t robot, std::string_view topic);

struct TransportStats {
  uint64_t iceoryx_sent = 0;
  uint64_t iceoryx_dropped = 0;  // no chunk free, or the message larger than the pools' chunks
  uint64_t udp_sent = 0;
  uint64_t udp_failed = 0;       // sendto failed (no route, buffer full)
};

class Transport {
 public:
  // Opens the UDP socket. Throws std::invalid_argument for an address that is not IPv4 or a base
  // port whose robot ports would pass 65535, std::runtime_error when the socket cannot be made.
  explicit Transport(TransportOptions options);
  ~Transport();
  Transport(const Transport&) = delete;
  Transport& operator=(const Transport&) = delete;

  // Robot `robot` may publish from now on / no longer (its iceoryx services are withdrawn).
  void add_robot(std::size_t robot);
  void remove_robot(std::size_t robot);
  bool has_robot(std::size_t robot) const;

  // Publishes `bytes` as robot `robot`'s message on `topic`. A robot that was not added sends
  // nothing. Never blocks on receivers.
  void send(std::size_t robot, const std::string& topic, std::string_view bytes);

  const TransportOptions& options() const noexcept { return options_; }
  uint16_t udp_port(std::size_t robot) const noexcept { return static_cast<uint16_t>(options_.udp_base_port + robot); }
  TransportStats stats() const noexcept { return stats_; }

  struct Publisher;

 private:
  TransportOptions options_;
  int socket_ = -1;
  uint32_t address_ = 0;  // network order
  std::map<std::size_t, std::map<std::string, std::unique_ptr<Publisher>>> robots_;
  TransportStats stats_;
};

}  // namespace doppel::truth
