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
#include <memory>
#include <mutex>

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
    Robot from, to;
    sockaddr_in to_address{};
    LinkModel model;
    bool removed = false;  // its receiver or sender left; delayed messages on it are dropped
    std::atomic<std::uint64_t> relayed{0}, dropped{0}, delayed{0}, queue_full{0}, send_errors{0};
    Link(const Robot& sender, const Robot& receiver, const sockaddr_in& address, const LinkModelConfig& config,
         std::uint64_t seed)
        : from(sender), to(receiver), to_address(address), model(config, seed) {}
  };
  struct Entry {
    Robot robot;
    sockaddr_in address{};
    std::vector<std::shared_ptr<Link>> out;  // to each registered teammate
  };
  struct Pending {
    Clock::time_point due;
    std::uint64_t sequence;  // keeps equal due times in arrival order
    std::shared_ptr<Link> link;
    std::vector<std::uint8_t> bytes;
    bool operator>(const Pending& other) const {
      return due != other.due ? due > other.due : sequence > other.sequence;
    }
  };

  HubConfig config;
  int fd = -1;
  mutable std::mutex mutex;     // the registry (entries, their links) and the pending queue
  std::vector<Entry> entries;   // registration order
  std::priority_queue<Pending, std::vector<Pending>, std::greater<>> pending;
  std::uint64_t sequence = 0;
  std::vector<std::uint8_t> buffer = std::vector<std::uint8_t>(65536);
  std::atomic<std::uint64_t> received{0}, unknown_sender{0}, oversized{0};

  // Each link its own stream, derived from the seed and the pair (team and player of both ends),
  // so one link's draws depend neither on the traffic of the others nor on registration order.
  std::uint64_t link_seed(const Robot& from, const Robot& to) const {
    std::seed_seq seq{static_cast<std::uint32_t>(config.seed), static_cast<std::uint32_t>(config.seed >> 32),
                      static_cast<std::uint32_t>(from.team), static_cast<std::uint32_t>(from.player),
                      static_cast<std::uint32_t>(to.team), static_cast<std::uint32_t>(to.player)};
    std::uint32_t words[2];
    seq.generate(words, words + 2);
    return (static_cast<std::uint64_t>(words[0]) << 32) | words[1];
  }

  // Checks `robot` against the registry; throws naming the problem. Caller holds the mutex.
  void check_new(const Robot& robot) const {
    const std::string name = std::to_string(robot.team) + ":" + std::to_string(robot.player);
    if (robot.port == 0) throw std::invalid_argument("hub: robot " + name + " has no port");
    if (robot.team < 0 || robot.team > 255 || robot.player < 0 || robot.player > 255) {
      throw std::invalid_argument("hub: robot " + name + ": team and player must be within 0..255");
    }
    for (const Entry& entry : entries) {
      if (entry.robot.team == robot.team && entry.robot.player == robot.player) {
        throw std::invalid_argument("hub: robot " + name + " is registered twice");
      }
      if (entry.robot.port == robot.port) {
        throw std::invalid_argument("hub: port " + std::to_string(robot.port) + " is registered for two robots");
      }
    }
  }

  // Caller holds the mutex and has checked the robot.
  void add(const Robot& robot) {
    Entry added{robot, ipv4(config.robot_address, robot.port, "robot address"), {}};
    for (Entry& entry : entries) {
      if (entry.robot.team != robot.team) continue;
      entry.out.push_back(std::make_shared<Link>(entry.robot, robot, added.address, config.link, link_seed(entry.robot, robot)));
      added.out.push_back(std::make_shared<Link>(robot, entry.robot, entry.address, config.link, link_seed(robot, entry.robot)));
    }
    entries.push_back(std::move(added));
  }

  void send(Link& link, const std::uint8_t* data, std::size_t size) {
    const ssize_t n = ::sendto(fd, data, size, MSG_DONTWAIT, reinterpret_cast<const sockaddr*>(&link.to_address),
                               sizeof link.to_address);
    if (n < 0) {
      link.send_errors.fetch_add(1, std::memory_order_relaxed);
    } else {
      link.relayed.fetch_add(1, std::memory_order_relaxed);
    }
  }

  void relay(Entry& sender, std::size_t size, Clock::time_point now) {
    for (const std::shared_ptr<Link>& shared : sender.out) {
      Link& link = *shared;
      const LinkDecision decision = link.model.next();
      if (decision.drop) {
        link.dropped.fetch_add(1, std::memory_order_relaxed);
      } else if (decision.delay_ns == 0) {
        send(link, buffer.data(), size);
      } else if (pending.size() >= config.max_pending) {
        link.queue_full.fetch_add(1, std::memory_order_relaxed);
      } else {
        link.delayed.fetch_add(1, std::memory_order_relaxed);
        pending.push(Pending{now + std::chrono::nanoseconds(decision.delay_ns), sequence++, shared,
                             std::vector<std::uint8_t>(buffer.begin(), buffer.begin() + static_cast<std::ptrdiff_t>(size))});
      }
    }
  }

  // Caller holds the mutex.
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
      const std::uint16_t port = ntohs(from.sin_port);
      const auto sender = std::find_if(entries.begin(), entries.end(), [&](const Entry& entry) {
        return entry.robot.port == port && entry.address.sin_addr.s_addr == from.sin_addr.s_addr;
      });
      if (sender == entries.end()) {
        unknown_sender.fetch_add(1, std::memory_order_relaxed);
        continue;
      }
      relay(*sender, static_cast<std::size_t>(n), Clock::now());
    }
  }

  // Caller holds the mutex.
  void flush_due(Clock::time_point now) {
    while (!pending.empty() && pending.top().due <= now) {
      const Pending& top = pending.top();
      if (!top.link->removed) send(*top.link, top.bytes.data(), top.bytes.size());
      pending.pop();
    }
  }
};

Hub::Hub(const HubConfig& config) : impl_(std::make_unique<Impl>()) {
  Impl& impl = *impl_;
  impl.config = config;
  impl.config.robots.clear();  // the registry is impl.entries
  validate(config.link);
  if (config.max_payload_bytes == 0) throw std::invalid_argument("hub: the largest payload must be at least 1 byte");
  ipv4(config.robot_address, 1, "robot address");
  for (const Robot& robot : config.robots) {
    impl.check_new(robot);
    impl.add(robot);
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
    int timeout_ms = 20;
    {
      std::lock_guard lock(impl.mutex);
      const Clock::time_point now = Clock::now();
      impl.flush_due(now);
      if (!impl.pending.empty()) {
        const auto wait = std::chrono::ceil<std::chrono::milliseconds>(impl.pending.top().due - now).count();
        timeout_ms = static_cast<int>(std::clamp<std::int64_t>(wait, 0, 20));
      }
    }
    pollfd p{impl.fd, POLLIN, 0};
    if (::poll(&p, 1, timeout_ms) > 0 && (p.revents & POLLIN) != 0) {
      std::lock_guard lock(impl.mutex);
      impl.read_all();
    }
  }
}

HubCounters Hub::counters() const {
  const Impl& impl = *impl_;
  HubCounters out;
  out.received = impl.received.load(std::memory_order_relaxed);
  out.unknown_sender = impl.unknown_sender.load(std::memory_order_relaxed);
  out.oversized = impl.oversized.load(std::memory_order_relaxed);
  std::lock_guard lock(impl.mutex);
  for (const Impl::Entry& entry : impl.entries) {
    for (const std::shared_ptr<Impl::Link>& shared : entry.out) {
      const Impl::Link& link = *shared;
      LinkCounters c;
      c.from_team = link.from.team;
      c.from_player = link.from.player;
      c.to_team = link.to.team;
      c.to_player = link.to.player;
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

void Hub::add_robot(const Robot& robot) {
  Impl& impl = *impl_;
  std::lock_guard lock(impl.mutex);
  impl.check_new(robot);
  impl.add(robot);
}

bool Hub::remove_robot(int team, int player) {
  Impl& impl = *impl_;
  std::lock_guard lock(impl.mutex);
  const auto found = std::find_if(impl.entries.begin(), impl.entries.end(), [&](const Impl::Entry& entry) {
    return entry.robot.team == team && entry.robot.player == player;
  });
  if (found == impl.entries.end()) return false;
  for (const std::shared_ptr<Impl::Link>& link : found->out) link->removed = true;
  impl.entries.erase(found);
  for (Impl::Entry& entry : impl.entries) {
    std::erase_if(entry.out, [&](const std::shared_ptr<Impl::Link>& link) {
      if (link->to.team != team || link->to.player != player) return false;
      link->removed = true;
      return true;
    });
  }
  return true;
}

std::vector<Robot> Hub::robots() const {
  const Impl& impl = *impl_;
  std::lock_guard lock(impl.mutex);
  std::vector<Robot> out;
  for (const Impl::Entry& entry : impl.entries) out.push_back(entry.robot);
  return out;
}

}  // namespace doppel::teamcomm
