#include "teamcomm/hub.h"

#include <algorithm>
#include <arpa/inet.h>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <netinet/in.h>
#include <poll.h>
#include <queue>
#include <stdexcept>
#include <sys/socket.h>
#include <unistd.h>
#include <unordered_map>

namespace doppel::teamcomm {
namespace {

using Clock = std::chrono::steady_clock;

sockaddr_in ipv4(const std::string& address, std::uint16_t port, const char* what) {
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(port);
  if (inet_pton(AF_INET, address.c_str(), &addr.sin_addr) != 1) {
    throw std::invalid_argument(std::string(what) + ": '" + address + "' is not an IPv4 address");
  }
  return addr;
}

int parse_int(const std::string& text, const char* part, const std::string& whole, long min, long max) {
  if (text.empty() || text.find_first_not_of("0123456789") != std::string::npos || text.size() > 9) {
    throw std::invalid_argument("robot '" + whole + "': " + part + " '" + text + "' is not a decimal number");
  }
  const long value = std::stol(text);
  if (value < min || value > max) {
    throw std::invalid_argument("robot '" + whole + "': " + part + " " + text + " is outside " +
                                std::to_string(min) + ".." + std::to_string(max));
  }
  return static_cast<int>(value);
}

}  // namespace

Robot parse_robot(const std::string& text) {
  const auto first = text.find(':');
  const auto second = first == std::string::npos ? first : text.find(':', first + 1);
  if (second == std::string::npos || text.find(':', second + 1) != std::string::npos) {
    throw std::invalid_argument("robot '" + text + "': expected TEAM:PLAYER:PORT");
  }
  Robot robot;
  robot.team = parse_int(text.substr(0, first), "team", text, 0, 255);
  robot.player = parse_int(text.substr(first + 1, second - first - 1), "player", text, 0, 255);
  robot.port = static_cast<std::uint16_t>(parse_int(text.substr(second + 1), "port", text, 1, 65535));
  return robot;
}

struct Hub::Impl {
  struct Link {
    std::size_t to = 0;  // receiver's robot index
    LinkModel model;
    std::atomic<std::uint64_t> relayed{0}, dropped{0}, delayed{0}, queue_full{0}, send_errors{0};
    Link(std::size_t receiver, const LinkModelConfig& config, std::uint64_t seed)
        : to(receiver), model(config, seed) {}
  };
  struct Pending {
    Clock::time_point due;
    std::uint64_t sequence;  // keeps equal due times in arrival order
    std::size_t link;
    std::vector<std::uint8_t> bytes;
    bool operator>(const Pending& other) const {
      return due != other.due ? due > other.due : sequence > other.sequence;
    }
  };

  HubConfig config;
  int fd = -1;
  std::vector<sockaddr_in> robot_addresses;
  std::unordered_map<std::uint16_t, std::size_t> robot_by_port;
  std::vector<std::unique_ptr<Link>> links;
  std::vector<std::vector<std::size_t>> links_from;  // per robot: its outgoing link indices
  std::priority_queue<Pending, std::vector<Pending>, std::greater<>> pending;
  std::uint64_t sequence = 0;
  std::vector<std::uint8_t> buffer = std::vector<std::uint8_t>(65536);
  std::atomic<std::uint64_t> received{0}, unknown_sender{0}, oversized{0};

  void send(std::size_t link_index, const std::uint8_t* data, std::size_t size) {
    Link& link = *links[link_index];
    const sockaddr_in& to = robot_addresses[link.to];
    const ssize_t n = ::sendto(fd, data, size, MSG_DONTWAIT, reinterpret_cast<const sockaddr*>(&to), sizeof to);
    if (n < 0) {
      link.send_errors.fetch_add(1, std::memory_order_relaxed);
    } else {
      link.relayed.fetch_add(1, std::memory_order_relaxed);
    }
  }

  void relay(std::size_t sender, std::size_t size, Clock::time_point now) {
    for (const std::size_t index : links_from[sender]) {
      Link& link = *links[index];
      const LinkDecision decision = link.model.next();
      if (decision.drop) {
        link.dropped.fetch_add(1, std::memory_order_relaxed);
      } else if (decision.delay_ns == 0) {
        send(index, buffer.data(), size);
      } else if (pending.size() >= config.max_pending) {
        link.queue_full.fetch_add(1, std::memory_order_relaxed);
      } else {
        link.delayed.fetch_add(1, std::memory_order_relaxed);
        pending.push(Pending{now + std::chrono::nanoseconds(decision.delay_ns), sequence++, index,
                             std::vector<std::uint8_t>(buffer.begin(), buffer.begin() + static_cast<std::ptrdiff_t>(size))});
      }
    }
  }

  void read_all() {
    for (;;) {
      sockaddr_in from{};
      socklen_t from_size = sizeof from;
      const ssize_t n = ::recvfrom(fd, buffer.data(), buffer.size(), MSG_DONTWAIT | MSG_TRUNC,
                                   reinterpret_cast<sockaddr*>(&from), &from_size);
      if (n < 0) {
        if (errno == EINTR || errno == ECONNREFUSED) continue;
        return;  // EAGAIN: nothing more; anything else: try again after the next poll
      }
      received.fetch_add(1, std::memory_order_relaxed);
      if (static_cast<std::size_t>(n) > config.max_payload_bytes || static_cast<std::size_t>(n) > buffer.size()) {
        oversized.fetch_add(1, std::memory_order_relaxed);
        continue;
      }
      const auto sender = robot_by_port.find(ntohs(from.sin_port));
      if (sender == robot_by_port.end() ||
          from.sin_addr.s_addr != robot_addresses[sender->second].sin_addr.s_addr) {
        unknown_sender.fetch_add(1, std::memory_order_relaxed);
        continue;
      }
      relay(sender->second, static_cast<std::size_t>(n), Clock::now());
    }
  }

  void flush_due(Clock::time_point now) {
    while (!pending.empty() && pending.top().due <= now) {
      const Pending& top = pending.top();
      send(top.link, top.bytes.data(), top.bytes.size());
      pending.pop();
    }
  }
};

Hub::Hub(const HubConfig& config) : impl_(std::make_unique<Impl>()) {
  Impl& impl = *impl_;
  impl.config = config;
  validate(config.link);
  if (config.max_payload_bytes == 0) throw std::invalid_argument("hub: the largest payload must be at least 1 byte");
  for (std::size_t i = 0; i < config.robots.size(); ++i) {
    const Robot& robot = config.robots[i];
    if (robot.port == 0) throw std::invalid_argument("hub: robot " + std::to_string(robot.team) + ":" +
                                                     std::to_string(robot.player) + " has no port");
    for (std::size_t j = 0; j < i; ++j) {
      if (config.robots[j].team == robot.team && config.robots[j].player == robot.player) {
        throw std::invalid_argument("hub: robot " + std::to_string(robot.team) + ":" + std::to_string(robot.player) +
                                    " is registered twice");
      }
    }
    if (!impl.robot_by_port.emplace(robot.port, i).second) {
      throw std::invalid_argument("hub: port " + std::to_string(robot.port) + " is registered for two robots");
    }
    impl.robot_addresses.push_back(ipv4(config.robot_address, robot.port, "robot address"));
  }
  impl.links_from.resize(config.robots.size());
  for (std::size_t from = 0; from < config.robots.size(); ++from) {
    for (std::size_t to = 0; to < config.robots.size(); ++to) {
      if (from == to || config.robots[from].team != config.robots[to].team) continue;
      // Each link its own stream, derived from the seed and the pair, so one link's draws do not
      // depend on how traffic on the others interleaves.
      std::seed_seq seq{static_cast<std::uint32_t>(config.seed), static_cast<std::uint32_t>(config.seed >> 32),
                        static_cast<std::uint32_t>(from), static_cast<std::uint32_t>(to)};
      std::uint32_t words[2];
      seq.generate(words, words + 2);
      const std::uint64_t link_seed = (static_cast<std::uint64_t>(words[0]) << 32) | words[1];
      impl.links_from[from].push_back(impl.links.size());
      impl.links.push_back(std::make_unique<Impl::Link>(to, config.link, link_seed));
    }
  }

  sockaddr_in listen = ipv4(config.listen_address, config.listen_port, "listen address");
  impl.fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (impl.fd < 0) throw std::runtime_error(std::string("hub: socket(): ") + std::strerror(errno));
  if (::bind(impl.fd, reinterpret_cast<const sockaddr*>(&listen), sizeof listen) != 0) {
    const int error = errno;
    ::close(impl.fd);
    throw std::runtime_error("hub: cannot bind " + config.listen_address + ":" + std::to_string(config.listen_port) +
                             ": " + std::strerror(error));
  }
  socklen_t size = sizeof listen;
  ::getsockname(impl.fd, reinterpret_cast<sockaddr*>(&listen), &size);
  port_ = ntohs(listen.sin_port);
}

Hub::~Hub() {
  if (impl_ && impl_->fd >= 0) ::close(impl_->fd);
}

void Hub::run(const std::atomic<bool>& stop) {
  Impl& impl = *impl_;
  while (!stop.load(std::memory_order_relaxed)) {
    Clock::time_point now = Clock::now();
    impl.flush_due(now);
    int timeout_ms = 20;
    if (!impl.pending.empty()) {
      const auto wait = std::chrono::ceil<std::chrono::milliseconds>(impl.pending.top().due - now).count();
      timeout_ms = static_cast<int>(std::clamp<std::int64_t>(wait, 0, 20));
    }
    pollfd p{impl.fd, POLLIN, 0};
    if (::poll(&p, 1, timeout_ms) > 0 && (p.revents & POLLIN) != 0) impl.read_all();
  }
}

HubCounters Hub::counters() const {
  const Impl& impl = *impl_;
  HubCounters out;
  out.received = impl.received.load(std::memory_order_relaxed);
  out.unknown_sender = impl.unknown_sender.load(std::memory_order_relaxed);
  out.oversized = impl.oversized.load(std::memory_order_relaxed);
  for (std::size_t from = 0; from < impl.links_from.size(); ++from) {
    for (const std::size_t index : impl.links_from[from]) {
      const Impl::Link& link = *impl.links[index];
      LinkCounters c;
      c.from_team = impl.config.robots[from].team;
      c.from_player = impl.config.robots[from].player;
      c.to_team = impl.config.robots[link.to].team;
      c.to_player = impl.config.robots[link.to].player;
      c.relayed = link.relayed.load(std::memory_order_relaxed);
      c.dropped = link.dropped.load(std::memory_order_relaxed);
      c.delayed = link.delayed.load(std::memory_order_relaxed);
      c.queue_full = link.queue_full.load(std::memory_order_relaxed);
      c.send_errors = link.send_errors.load(std::memory_order_relaxed);
      out.links.push_back(c);
    }
  }
  return out;
}

}  // namespace doppel::teamcomm
