#pragma once
// The team-communication hub: on a real field the robots of a team broadcast their team messages
// (UDP) to each other; on one machine several control-software instances cannot all bind the
// same broadcast port, so each sends to the hub instead and the hub relays every datagram to the
// other registered robots of the sender's team (never back to the sender, never to another team),
// through a LinkModel per (sender, receiver) link. The payload is opaque bytes.
//
// A sender is recognised by its source address and port: a robot sends from the socket it
// receives on (its registered port). Datagrams from anyone else, and datagrams longer than
// max_payload_bytes, are counted and dropped. Not a real-time thread: delayed messages are kept
// in a bounded queue whose entries own their bytes (allocated when queued).
//
// Robots can be registered and removed while the hub runs (add_robot(), remove_robot(): any
// thread; one mutex guards the registry between them and the relaying thread).
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "teamcomm/link_model.h"

namespace doppel::teamcomm {

struct Robot {
  int team = 0;            // team number
  int player = 0;          // player number within the team
  std::uint16_t port = 0;  // UDP port the robot's software receives on (and sends from), on address
};

struct HubConfig {
  std::string listen_address = "127.0.0.1";   // IPv4 address the hub binds; loopback unless the user names another
  std::uint16_t listen_port = 0;              // 0: the kernel picks one (see Hub::port())
  std::string robot_address = "127.0.0.1";    // where the robots' software runs
  std::vector<Robot> robots;                  // registered robots; (team, player) and port unique
  LinkModelConfig link;                       // the same model on every link, each with its own generator
  std::uint64_t seed = 1;                     // seeds every link's generator (with the link's index)
  std::size_t max_payload_bytes = 65507;      // longer datagrams are dropped (IPv4 UDP maximum by default)
  std::size_t max_pending = 4096;             // delayed messages held at once; more are dropped and counted
};

struct LinkCounters {
  int from_team = 0, from_player = 0;  // the sender
  int to_team = 0, to_player = 0;      // the receiver
  std::uint64_t relayed = 0;           // handed to the receiver's socket
  std::uint64_t dropped = 0;           // lost by the link model
  std::uint64_t delayed = 0;           // relayed with a delay > 0
  std::uint64_t queue_full = 0;        // dropped because max_pending messages were waiting
  std::uint64_t send_errors = 0;       // sendto() failed (e.g. nobody listens: ECONNREFUSED)
};

struct HubCounters {
  std::uint64_t received = 0;        // datagrams read from the hub's socket
  std::uint64_t unknown_sender = 0;  // from an address:port no robot is registered with
  std::uint64_t oversized = 0;       // longer than max_payload_bytes
  std::vector<LinkCounters> links;   // one per ordered pair of robots of the same team
};

class Hub {
 public:
  // Binds the socket. Throws std::invalid_argument / std::runtime_error with a precise message
  // (bad address, duplicate robot, bad link model, port in use).
  explicit Hub(const HubConfig& config);
  ~Hub();
  Hub(const Hub&) = delete;
  Hub& operator=(const Hub&) = delete;

  std::uint16_t port() const noexcept { return port_; }  // the bound port (useful with listen_port 0)

  // Relays until stop is true (checked at least every 20 ms). Never throws for bad traffic.
  void run(const std::atomic<bool>& stop);

  // A copy of the counters; safe from another thread while run() is going.
  HubCounters counters() const;

  // Registers a robot while the hub runs (any thread). Throws std::invalid_argument naming the
  // problem (no port, the team:player or the port already registered); nothing changes then.
  // Its links to and from its registered teammates start with fresh counters.
  void add_robot(const Robot& robot);
  // Removes robot team:player and its links (messages still delayed towards it are dropped).
  // False when no such robot is registered.
  bool remove_robot(int team, int player);
  // The robots registered now, in registration order.
  std::vector<Robot> robots() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::uint16_t port_ = 0;
};

// Parses "TEAM:PLAYER:PORT" (all decimal, team and player >= 0, port 1..65535); throws
// std::invalid_argument naming the part that is wrong.
Robot parse_robot(const std::string& text);

}  // namespace doppel::teamcomm
