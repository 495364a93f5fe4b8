#include "teamcomm/hub.h"

#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace doppel::teamcomm {
namespace {

using namespace std::chrono_literals;

// A robot's software as the hub sees it: one UDP socket on loopback (an ephemeral port) that it
// receives on and sends its team messages from.
class Client {
 public:
  Client() {
    fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    EXPECT_EQ(::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
    socklen_t size = sizeof addr;
    ::getsockname(fd_, reinterpret_cast<sockaddr*>(&addr), &size);
    port_ = ntohs(addr.sin_port);
    int buffer = 4 << 20;
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &buffer, sizeof buffer);
  }
  ~Client() { ::close(fd_); }
  std::uint16_t port() const { return port_; }
  void send(std::uint16_t to_port, const std::string& bytes) const {
    sockaddr_in to{};
    to.sin_family = AF_INET;
    to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    to.sin_port = htons(to_port);
    ASSERT_EQ(::sendto(fd_, bytes.data(), bytes.size(), 0, reinterpret_cast<sockaddr*>(&to), sizeof to),
              static_cast<ssize_t>(bytes.size()));
  }
  // The next datagram within the timeout, or nothing.
  std::optional<std::string> receive(std::chrono::milliseconds timeout) const {
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, static_cast<int>(timeout.count())) <= 0) return std::nullopt;
    std::string bytes(65536, '\0');
    const ssize_t n = ::recv(fd_, bytes.data(), bytes.size(), 0);
    if (n < 0) return std::nullopt;
    bytes.resize(static_cast<std::size_t>(n));
    return bytes;
  }

 private:
  int fd_ = -1;
  std::uint16_t port_ = 0;
};

// The hub on its own thread for the length of a test.
class RunningHub {
 public:
  explicit RunningHub(const HubConfig& config) : hub_(config), thread_([this] { hub_.run(stop_); }) {}
  ~RunningHub() {
    stop_ = true;
    thread_.join();
  }
  Hub& hub() { return hub_; }
  // Waits (up to 5 s) until the hub's counters satisfy `done`: until then a datagram may still wait
  // in its socket, however long the silence the test listened to. The counters it ends with.
  template <typename Done>
  HubCounters counters_when(Done done) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
    HubCounters counters = hub_.counters();
    while (!done(counters) && std::chrono::steady_clock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
      counters = hub_.counters();
    }
    return counters;
  }

 private:
  Hub hub_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

LinkCounters link(const HubCounters& counters, int from_player, int to_player) {
  for (const LinkCounters& c : counters.links) {
    if (c.from_player == from_player && c.to_player == to_player) return c;
  }
  throw std::runtime_error("no such link");
}

TEST(Hub, RelaysToTeammatesButNotBackToTheSenderNorToTheOtherTeam) {
  Client a, b, c, rival;
  HubConfig config;
  config.robots = {{1, 1, a.port()}, {1, 2, b.port()}, {1, 3, c.port()}, {2, 1, rival.port()}};
  RunningHub sut(config);

  a.send(sut.hub().port(), "hello from 1:1");
  EXPECT_EQ(b.receive(1000ms), "hello from 1:1");
  EXPECT_EQ(c.receive(1000ms), "hello from 1:1");
  b.send(sut.hub().port(), "and from 1:2");
  EXPECT_EQ(a.receive(1000ms), "and from 1:2");
  EXPECT_EQ(c.receive(1000ms), "and from 1:2");
  rival.send(sut.hub().port(), "rival team");  // alone in its team: nobody to relay to
  EXPECT_EQ(a.receive(200ms), std::nullopt);
  EXPECT_EQ(b.receive(0ms), std::nullopt);
  EXPECT_EQ(c.receive(0ms), std::nullopt);
  EXPECT_EQ(rival.receive(0ms), std::nullopt);

  const HubCounters counters = sut.counters_when([](const HubCounters& now) { return now.received == 3; });
  EXPECT_EQ(counters.received, 3u);
  EXPECT_EQ(counters.links.size(), 6u);  // 3 robots of team 1: 3 * 2 ordered pairs; team 2: none
  EXPECT_EQ(link(counters, 1, 2).relayed, 1u);
  EXPECT_EQ(link(counters, 2, 3).relayed, 1u);
  EXPECT_EQ(link(counters, 3, 1).relayed, 0u);
}

TEST(Hub, DropsTheConfiguredShareWithinFourSigma) {
  constexpr int kN = 10000;
  constexpr double kP = 0.2;
  Client a, b;
  HubConfig config;
  config.robots = {{1, 1, a.port()}, {1, 2, b.port()}};
  config.link.loss_probability = kP;
  config.seed = 2026;
  RunningHub sut(config);

  int received = 0;
  for (int i = 0; i < kN; ++i) {
    a.send(sut.hub().port(), "m" + std::to_string(i));
    // Let the hub keep up, so no datagram is lost in a socket buffer instead of the model.
    if (i % 64 == 63) {
      while (sut.hub().counters().received < static_cast<std::uint64_t>(i + 1)) std::this_thread::sleep_for(100us);
    }
    while (b.receive(0ms)) ++received;
  }
  while (sut.hub().counters().received < kN) std::this_thread::sleep_for(1ms);
  while (b.receive(200ms)) ++received;

  const LinkCounters ab = link(sut.hub().counters(), 1, 2);
  const double sigma = std::sqrt(kN * kP * (1 - kP));  // binomial standard deviation: 40 messages
  EXPECT_NEAR(static_cast<double>(ab.dropped), kN * kP, 4 * sigma);
  EXPECT_EQ(ab.dropped + ab.relayed, static_cast<std::uint64_t>(kN));
  EXPECT_EQ(received, static_cast<int>(ab.relayed));  // what the model let through arrived
  EXPECT_NEAR(static_cast<double>(kN - received), kN * kP, 4 * sigma);
}

TEST(Hub, DelayAddsAtLeastTheConfiguredDelay) {
  Client a, b;
  HubConfig config;
  config.robots = {{3, 1, a.port()}, {3, 2, b.port()}};
  config.link.delay_ns = 80'000'000;
  config.link.jitter_ns = 20'000'000;
  RunningHub sut(config);

  for (int i = 0; i < 5; ++i) {
    const auto sent = std::chrono::steady_clock::now();
    a.send(sut.hub().port(), "late");
    ASSERT_EQ(b.receive(2000ms), "late");
    const auto took = std::chrono::steady_clock::now() - sent;
    EXPECT_GE(took, 80ms);
  }
  EXPECT_EQ(link(sut.hub().counters(), 1, 2).delayed, 5u);
}

TEST(Hub, SurvivesOversizedEmptyAndStrangersDatagrams) {
  Client a, b, stranger;
  HubConfig config;
  config.robots = {{1, 1, a.port()}, {1, 2, b.port()}};
  config.max_payload_bytes = 1024;
  RunningHub sut(config);

  a.send(sut.hub().port(), std::string(1025, 'x'));
  a.send(sut.hub().port(), std::string(65507, '\xff'));  // the largest IPv4 UDP payload
  stranger.send(sut.hub().port(), "not registered");
  a.send(sut.hub().port(), std::string());  // an empty datagram is a datagram: relayed
  a.send(sut.hub().port(), std::string("\0\x01\x02garbage\xfe", 11));

  EXPECT_EQ(b.receive(1000ms), std::string());
  EXPECT_EQ(b.receive(1000ms), std::string("\0\x01\x02garbage\xfe", 11));
  EXPECT_EQ(b.receive(100ms), std::nullopt);
  EXPECT_EQ(stranger.receive(0ms), std::nullopt);
  const HubCounters counters = sut.hub().counters();
  EXPECT_EQ(counters.received, 5u);
  EXPECT_EQ(counters.oversized, 2u);
  EXPECT_EQ(counters.unknown_sender, 1u);
  EXPECT_EQ(link(counters, 1, 2).relayed, 2u);
}

TEST(Hub, RejectsABadRegistrationWithItsReason) {
  HubConfig config;
  config.robots = {{1, 1, 40001}, {1, 1, 40002}};
  try {
    Hub sut(config);
    FAIL() << "a robot registered twice was accepted";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("1:1 is registered twice"), std::string::npos) << error.what();
  }
  config.robots = {{1, 1, 40001}, {1, 2, 40001}};
  EXPECT_THROW(Hub{config}, std::invalid_argument);
  config.robots = {{1, 1, 40001}};
  config.listen_address = "localhost:1";
  EXPECT_THROW(Hub{config}, std::invalid_argument);
}

TEST(Hub, RegistersAndRemovesRobotsWhileRunning) {
  Client a, b, c;
  HubConfig config;
  config.robots = {{7, 1, a.port()}};
  RunningHub running(config);
  Hub& hub = running.hub();
  // Alone on its team, a's message goes nowhere.
  a.send(hub.port(), "alone");
  EXPECT_EQ(running.counters_when([](const HubCounters& now) { return now.received == 1; }).received, 1u) << "read before b is there";
  EXPECT_FALSE(b.receive(200ms).has_value());
  // Registered from another thread while the hub relays: b and c hear a, and a hears them.
  std::thread([&] { hub.add_robot({7, 2, b.port()}); }).join();
  hub.add_robot({7, 3, c.port()});
  ASSERT_EQ(hub.robots().size(), 3u);
  a.send(hub.port(), "from a");
  EXPECT_EQ(b.receive(2s), std::optional<std::string>("from a"));
  EXPECT_EQ(c.receive(2s), std::optional<std::string>("from a"));
  b.send(hub.port(), "from b");
  EXPECT_EQ(a.receive(2s), std::optional<std::string>("from b"));
  EXPECT_EQ(c.receive(2s), std::optional<std::string>("from b"));
  EXPECT_EQ(link(hub.counters(), 1, 2).relayed, 1u);
  // A second registration of 7:2, or of b's port, is refused with the reason and changes nothing.
  try {
    hub.add_robot({7, 2, 40999});
    FAIL() << "7:2 was registered twice";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("7:2 is registered twice"), std::string::npos) << error.what();
  }
  EXPECT_THROW(hub.add_robot({8, 1, b.port()}), std::invalid_argument);
  EXPECT_THROW(hub.add_robot({8, 1, 0}), std::invalid_argument);
  EXPECT_EQ(hub.robots().size(), 3u);
  // Removed, c hears nothing more, its links are gone, and it becomes an unknown sender.
  EXPECT_TRUE(hub.remove_robot(7, 3));
  EXPECT_FALSE(hub.remove_robot(7, 3));
  a.send(hub.port(), "after");
  EXPECT_EQ(b.receive(2s), std::optional<std::string>("after"));
  EXPECT_FALSE(c.receive(200ms).has_value());
  const HubCounters counters = hub.counters();
  EXPECT_EQ(counters.links.size(), 2u);  // a -> b and b -> a
  const std::uint64_t unknown = counters.unknown_sender;
  c.send(hub.port(), "stranger now");
  EXPECT_FALSE(a.receive(200ms).has_value());
  EXPECT_EQ(running.counters_when([&](const HubCounters& now) { return now.unknown_sender == unknown + 1; }).unknown_sender, unknown + 1);
}

TEST(ParseRobot, ReadsTeamPlayerPortAndNamesTheWrongPart) {
  const Robot robot = parse_robot("12:3:40123");
  EXPECT_EQ(robot.team, 12);
  EXPECT_EQ(robot.player, 3);
  EXPECT_EQ(robot.port, 40123);
  for (const char* bad : {"12:3", "12:3:4:5", "x:3:40123", "12:3:70000", "12:3:0", "12::40123", "-1:3:4000"}) {
    EXPECT_THROW(parse_robot(bad), std::invalid_argument) << bad;
  }
  try {
    parse_robot("12:3:70000");
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("port 70000"), std::string::npos) << error.what();
  }
}

}  // namespace
}  // namespace doppel::teamcomm
