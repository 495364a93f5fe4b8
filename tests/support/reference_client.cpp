#include "reference_client.h"

#include <fcntl.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <stdexcept>

#include "bother_line.h"

namespace doppel::testing {
namespace {

void set_raw_speed(int fd, uint32_t baud_bps) {
  if (const char* failed = set_bother_line(fd, baud_bps)) {
    throw std::runtime_error(std::string(failed) + ": " + std::strerror(errno));
  }
}

}  // namespace

Bytes p1_instruction(uint8_t id, uint8_t instruction, const Bytes& params) {
  Bytes packet;
  packet.reserve(params.size() + 6);
  for (uint8_t byte : {uint8_t{0xFF}, uint8_t{0xFF}, id, static_cast<uint8_t>(params.size() + 2), instruction}) {
    packet.push_back(byte);
  }
  for (uint8_t byte : params) {
    packet.push_back(byte);
  }
  unsigned sum = 0;
  for (std::size_t i = 2; i < packet.size(); ++i) {
    sum += packet[i];
  }
  packet.push_back(static_cast<uint8_t>(~sum & 0xFF));
  return packet;
}

std::optional<std::vector<P1Status>> parse_p1_statuses(const Bytes& bytes) {
  std::vector<P1Status> statuses;
  std::size_t i = 0;
  while (i < bytes.size()) {
    if (bytes.size() - i < 6 || bytes[i] != 0xFF || bytes[i + 1] != 0xFF) {
      return std::nullopt;
    }
    uint8_t length = bytes[i + 3];
    if (length < 2 || i + 4 + length > bytes.size()) {
      return std::nullopt;
    }
    unsigned sum = 0;
    for (std::size_t k = i + 2; k < i + 3 + length; ++k) {
      sum += bytes[k];
    }
    if (static_cast<uint8_t>(~sum & 0xFF) != bytes[i + 3 + length]) {
      return std::nullopt;
    }
    P1Status status;
    status.id = bytes[i + 2];
    status.error = bytes[i + 4];
    status.params.assign(bytes.begin() + static_cast<long>(i) + 5, bytes.begin() + static_cast<long>(i) + 3 + length);
    statuses.push_back(std::move(status));
    i += 4 + length;
  }
  return statuses;
}

SerialClient::SerialClient(const std::string& path, uint32_t baud_bps) {
  fd_ = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK);
  if (fd_ < 0) {
    throw std::runtime_error("open " + path + ": " + std::strerror(errno));
  }
  set_raw_speed(fd_, baud_bps);
}

SerialClient::~SerialClient() {
  if (fd_ >= 0) {
    ::close(fd_);
  }
}

void SerialClient::send(const Bytes& bytes) {
  ioctl(fd_, TCFLSH, TCIFLUSH);
  std::size_t done = 0;
  while (done < bytes.size()) {
    ssize_t n = ::write(fd_, bytes.data() + done, bytes.size() - done);
    if (n > 0) {
      done += static_cast<std::size_t>(n);
    } else if (n < 0 && errno != EAGAIN && errno != EINTR) {
      throw std::runtime_error(std::string("write: ") + std::strerror(errno));
    } else {
      pollfd p{fd_, POLLOUT, 0};
      ::poll(&p, 1, 10);
    }
  }
}

Bytes SerialClient::receive(std::size_t count, int timeout_ms) {
  Bytes out;
  auto read_available = [&] {
    uint8_t buffer[512];
    ssize_t n = ::read(fd_, buffer, std::min(sizeof(buffer), count - out.size()));
    if (n > 0) {
      out.insert(out.end(), buffer, buffer + n);
    }
  };
  auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  while (out.size() < count) {
    auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) {
      // One last look: on a loaded machine this process may have slept past its deadline while
      // the bytes were already there; that is the client's delay, not the bus'.
      read_available();
      break;
    }
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, static_cast<int>(left.count())) > 0) {
      read_available();
    }
  }
  return out;
}

Bytes SerialClient::drain(int timeout_ms) { return receive(1 << 16, timeout_ms); }

Bytes SerialClient::transact(const Bytes& request, std::size_t expected, int timeout_ms) {
  send(request);
  return receive(expected, timeout_ms);
}

}  // namespace doppel::testing
