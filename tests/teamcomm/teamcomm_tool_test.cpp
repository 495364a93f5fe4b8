// doppel-teamcomm as a team uses it: the hub is its own process, and two robots' software are two
// more processes (forked), each sending its team messages to the hub and counting what arrives.
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

extern char** environ;

namespace {

int bound_loopback_socket(std::uint16_t* port) {
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  EXPECT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  socklen_t size = sizeof addr;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &size);
  *port = ntohs(addr.sin_port);
  return fd;
}

// Everything a process's output said until it closed its end (or the deadline passed).
std::string read_until(int fd, const std::string& marker, std::chrono::milliseconds timeout) {
  std::string text;
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  char chunk[4096];
  while (std::chrono::steady_clock::now() < deadline && (marker.empty() || text.find(marker) == std::string::npos)) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 50) <= 0) continue;
    const ssize_t n = ::read(fd, chunk, sizeof chunk);
    if (n <= 0) break;
    text.append(chunk, static_cast<std::size_t>(n));
  }
  return text;
}

// The robot process: sends kMessages tagged with its name to the hub, and reads until all of its
// teammate's came (30 s against a hang), counting messages from its teammate and its own (which
// must never come back). Reports "<from teammate> <own>" through the pipe. Only system calls and
// a stack buffer: it was forked.
constexpr int kMessages = 50;
[[noreturn]] void robot_process(int fd, std::uint16_t hub_port, char self, char mate, int report) {
  sockaddr_in hub{};
  hub.sin_family = AF_INET;
  hub.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  hub.sin_port = htons(hub_port);
  int from_mate = 0, own = 0, sent = 0;
  char buffer[256];
  timespec start{};
  clock_gettime(CLOCK_MONOTONIC, &start);
  for (;;) {
    timespec now{};
    clock_gettime(CLOCK_MONOTONIC, &now);
    const long elapsed_ms = (now.tv_sec - start.tv_sec) * 1000 + (now.tv_nsec - start.tv_nsec) / 1000000;
    // Done when all of the mate's messages came; 30 s only against a hang (a loaded machine may
    // take seconds for what takes milliseconds on an idle one: no timing is asserted).
    if (elapsed_ms > 30'000 || (sent == kMessages && from_mate == kMessages)) break;
    if (sent < kMessages) {
      char message[32];
      const int n = std::snprintf(message, sizeof message, "%c%d", self, sent++);
      ::sendto(fd, message, static_cast<std::size_t>(n), 0, reinterpret_cast<sockaddr*>(&hub), sizeof hub);
    }
    pollfd p{fd, POLLIN, 0};
    while (::poll(&p, 1, 5) > 0) {
      const ssize_t n = ::recv(fd, buffer, sizeof buffer, 0);
      if (n > 0 && buffer[0] == mate) ++from_mate;
      if (n > 0 && buffer[0] == self) ++own;
    }
  }
  const int n = std::snprintf(buffer, sizeof buffer, "%d %d", from_mate, own);
  (void)!::write(report, buffer, static_cast<std::size_t>(n));
  ::_exit(0);
}

TEST(DoppelTeamcomm, TwoRobotProcessesReceiveEachOthersMessagesAndNotTheirOwn) {
  std::uint16_t port_a = 0, port_b = 0;
  const int a = bound_loopback_socket(&port_a);
  const int b = bound_loopback_socket(&port_b);

  int out[2];
  ASSERT_EQ(::pipe2(out, O_CLOEXEC), 0);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, out[1], STDOUT_FILENO);
  const std::string robot_a = "5:1:" + std::to_string(port_a), robot_b = "5:2:" + std::to_string(port_b);
  std::vector<std::string> args = {DOPPEL_TEAMCOMM_TOOL, "--listen", "127.0.0.1:0", "--robot", robot_a,
                                   "--robot", robot_b, "--seed", "7"};
  std::vector<char*> argv;
  for (std::string& arg : args) argv.push_back(arg.data());
  argv.push_back(nullptr);
  pid_t hub = 0;
  ASSERT_EQ(posix_spawn(&hub, argv[0], &actions, nullptr, argv.data(), environ), 0);
  posix_spawn_file_actions_destroy(&actions);
  ::close(out[1]);

  const std::string banner = read_until(out[0], "robots\n", std::chrono::milliseconds(5000));
  unsigned hub_port = 0;
  ASSERT_EQ(std::sscanf(banner.c_str(), "doppel-teamcomm: listening on 127.0.0.1:%u", &hub_port), 1) << banner;

  int report_a[2], report_b[2];
  ASSERT_EQ(::pipe(report_a), 0);
  ASSERT_EQ(::pipe(report_b), 0);
  const pid_t child_a = ::fork();
  if (child_a == 0) robot_process(a, static_cast<std::uint16_t>(hub_port), 'A', 'B', report_a[1]);
  const pid_t child_b = ::fork();
  if (child_b == 0) robot_process(b, static_cast<std::uint16_t>(hub_port), 'B', 'A', report_b[1]);
  ::close(report_a[1]);
  ::close(report_b[1]);

  const std::string said_a = read_until(report_a[0], "", std::chrono::milliseconds(60'000));
  const std::string said_b = read_until(report_b[0], "", std::chrono::milliseconds(60'000));
  int status = 0;
  ::waitpid(child_a, &status, 0);
  ::waitpid(child_b, &status, 0);
  EXPECT_EQ(said_a, std::to_string(kMessages) + " 0");  // all of B's, none of its own
  EXPECT_EQ(said_b, std::to_string(kMessages) + " 0");

  ::kill(hub, SIGINT);
  const std::string counters = read_until(out[0], "", std::chrono::milliseconds(5000));
  ASSERT_EQ(::waitpid(hub, &status, 0), hub);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status;
  EXPECT_NE(counters.find("received 100, unknown sender 0, oversized 0"), std::string::npos) << counters;
  EXPECT_NE(counters.find("5:1 -> 5:2  50  0  0  0  0"), std::string::npos) << counters;
  EXPECT_NE(counters.find("5:2 -> 5:1  50  0  0  0  0"), std::string::npos) << counters;
  for (int fd : {a, b, out[0], report_a[0], report_b[0]}) ::close(fd);
}

TEST(DoppelTeamcomm, ABadRobotArgumentIsAnErrorNamingIt) {
  const std::string command = std::string(DOPPEL_TEAMCOMM_TOOL) + " --robot 1:2:notaport 2>&1";
  FILE* pipe = ::popen(command.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  char line[512] = {};
  std::string text;
  while (std::fgets(line, sizeof line, pipe) != nullptr) text += line;
  const int status = ::pclose(pipe);
  EXPECT_EQ(WEXITSTATUS(status), 2);
  EXPECT_NE(text.find("port 'notaport' is not a decimal number"), std::string::npos) << text;
}

}  // namespace
