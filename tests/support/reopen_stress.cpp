#include "reopen_stress.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <termios.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <stdexcept>

namespace doppel::testing {
namespace {

speed_t speed_constant(uint32_t bps) {
  switch (bps) {
    case 9600: return B9600;
    case 57600: return B57600;
    case 115200: return B115200;
    case 1000000: return B1000000;
    default: throw std::runtime_error("reopen_startup: " + std::to_string(bps) + " is not a rate of this test");
  }
}

uint32_t speed_bps(speed_t speed) {
  switch (speed) {
    case B9600: return 9600;
    case B57600: return 57600;
    case B115200: return 115200;
    case B1000000: return 1000000;
    default: return 0;
  }
}

// PortHandlerLinux::setupPort, written from termios(3).
int setup_port(const std::string& port, uint32_t bps) {
  const int fd = ::open(port.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK);
  if (fd < 0) throw std::runtime_error("open " + port + ": " + std::strerror(errno));
  termios tio;
  std::memset(&tio, 0, sizeof(tio));
  tio.c_cflag = speed_constant(bps) | CS8 | CLOCAL | CREAD;
  tio.c_iflag = IGNPAR;
  tio.c_cc[VTIME] = 0;
  tio.c_cc[VMIN] = 0;
  ::tcflush(fd, TCIFLUSH);
  ::tcsetattr(fd, TCSANOW, &tio);
  return fd;
}

bool ping(int fd, uint8_t id, int timeout_ms, std::string& failure) {
  // PING: FF FF ID 02 01 CK, status FF FF ID 02 00 CK, CK = ~(ID + LEN + INST/ERR) (reference §1.1).
  const std::array<uint8_t, 6> request{0xFF, 0xFF, id, 0x02, 0x01, static_cast<uint8_t>(~(id + 0x02 + 0x01))};
  const std::array<uint8_t, 6> expected{0xFF, 0xFF, id, 0x02, 0x00, static_cast<uint8_t>(~(id + 0x02))};
  ::tcflush(fd, TCIFLUSH);
  if (::write(fd, request.data(), request.size()) != static_cast<ssize_t>(request.size())) return false;
  std::array<uint8_t, 6> reply{};
  std::size_t got = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  while (got < reply.size()) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) {
      failure = "timeout after " + std::to_string(got) + " bytes";
      return false;
    }
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, static_cast<int>(left.count()) + 1) <= 0) continue;
    const ssize_t n = ::read(fd, reply.data() + got, reply.size() - got);
    if (n > 0) got += static_cast<std::size_t>(n);
  }
  if (reply != expected) {
    failure = "wrong bytes:";
    for (uint8_t b : reply) failure += " " + std::to_string(b);
  }
  return reply == expected;
}

}  // namespace

StartupOutcome reopen_startup(const std::string& port, uint32_t first_bps, uint32_t second_bps, uint8_t id,
                              int pings, int timeout_ms) {
  ::close(setup_port(port, first_bps));
  const int fd = setup_port(port, second_bps);
  StartupOutcome outcome;
  for (int i = 0; i < pings; ++i) {
    std::string failure;
    if (ping(fd, id, timeout_ms, failure)) {
      ++outcome.answered;
    } else if (outcome.first_failure.empty()) {
      outcome.first_failure = "PING " + std::to_string(i + 1) + ": " + failure;
    }
  }
  termios now{};
  if (::tcgetattr(fd, &now) == 0) outcome.line_bps_after = speed_bps(::cfgetospeed(&now));
  ::close(fd);
  return outcome;
}

BusyLoad::BusyLoad(int processes) {
  for (int i = 0; i < processes; ++i) {
    const pid_t pid = ::fork();
    if (pid == 0) {
      ::execl("/bin/sh", "sh", "-c", "while :; do :; done", static_cast<char*>(nullptr));
      ::_exit(127);
    }
    if (pid > 0) children_.push_back(pid);
  }
}

BusyLoad::~BusyLoad() {
  for (pid_t pid : children_) ::kill(pid, SIGKILL);
  for (pid_t pid : children_) ::waitpid(pid, nullptr, 0);
}

}  // namespace doppel::testing
