#include "protocol1_client.h"

#include <fcntl.h>
#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <stdexcept>

namespace walk {

namespace {

speed_t speed_of(uint32_t baud_bps) {
  switch (baud_bps) {
    case 9600: return B9600;
    case 57600: return B57600;
    case 115200: return B115200;
    case 1000000: return B1000000;
    case 2000000: return B2000000;
    case 3000000: return B3000000;
    case 4000000: return B4000000;
    default: throw std::runtime_error("unsupported baud rate " + std::to_string(baud_bps));
  }
}

uint8_t checksum(const std::vector<uint8_t>& packet) {
  unsigned sum = 0;
  for (std::size_t i = 2; i < packet.size(); ++i) sum += packet[i];
  return static_cast<uint8_t>(~sum & 0xFF);
}

}  // namespace

Protocol1Client::Protocol1Client(const std::string& path, uint32_t baud_bps) {
  fd_ = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK);
  if (fd_ < 0) throw std::runtime_error("cannot open " + path + ": " + std::strerror(errno));
  termios tio{};
  if (tcgetattr(fd_, &tio) != 0) {
    ::close(fd_);
    throw std::runtime_error(path + " is not a serial port: " + std::strerror(errno));
  }
  cfmakeraw(&tio);
  tio.c_cflag |= CLOCAL | CREAD;
  tio.c_cc[VMIN] = 0;
  tio.c_cc[VTIME] = 0;
  cfsetspeed(&tio, speed_of(baud_bps));
  if (tcsetattr(fd_, TCSANOW, &tio) != 0) {
    ::close(fd_);
    throw std::runtime_error("cannot configure " + path + ": " + std::strerror(errno));
  }
  tx_.reserve(256);
  rx_.reserve(256);
}

Protocol1Client::~Protocol1Client() {
  if (fd_ >= 0) ::close(fd_);
}

void Protocol1Client::send(const std::vector<uint8_t>& packet) {
  tcflush(fd_, TCIFLUSH);  // drop anything stale before a new transaction, as the ROBOTIS SDK does
  std::size_t done = 0;
  while (done < packet.size()) {
    const ssize_t n = ::write(fd_, packet.data() + done, packet.size() - done);
    if (n > 0) {
      done += static_cast<std::size_t>(n);
    } else if (n < 0 && errno != EAGAIN && errno != EINTR) {
      throw std::runtime_error(std::string("serial write failed: ") + std::strerror(errno));
    } else {
      pollfd p{fd_, POLLOUT, 0};
      ::poll(&p, 1, 10);
    }
  }
}

bool Protocol1Client::receive_status(uint8_t id, std::span<uint8_t> out, int timeout_ms) {
  const std::size_t expected = 6 + out.size();  // FF FF ID LEN ERR params CKSUM
  rx_.clear();
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  while (rx_.size() < expected) {
    uint8_t buffer[256];
    const ssize_t n = ::read(fd_, buffer, sizeof(buffer));
    if (n > 0) {
      rx_.insert(rx_.end(), buffer, buffer + n);
      // Resynchronise on the header: drop bytes before FF FF.
      while (rx_.size() >= 2 && !(rx_[0] == 0xFF && rx_[1] == 0xFF)) rx_.erase(rx_.begin());
      continue;
    }
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) return false;
    pollfd p{fd_, POLLIN, 0};
    ::poll(&p, 1, static_cast<int>(left.count()));
  }
  unsigned sum = 0;
  for (std::size_t i = 2; i + 1 < expected; ++i) sum += rx_[i];
  if (rx_[2] != id || rx_[3] != out.size() + 2 || static_cast<uint8_t>(~sum & 0xFF) != rx_[expected - 1]) return false;
  last_error_ = rx_[4];
  std::memcpy(out.data(), rx_.data() + 5, out.size());
  return last_error_ == 0;
}

bool Protocol1Client::read(uint8_t id, uint8_t address, std::span<uint8_t> out, int timeout_ms) {
  tx_.assign({0xFF, 0xFF, id, 4, 0x02, address, static_cast<uint8_t>(out.size())});
  tx_.push_back(checksum(tx_));
  send(tx_);
  return receive_status(id, out, timeout_ms);
}

bool Protocol1Client::write(uint8_t id, uint8_t address, std::span<const uint8_t> data, int timeout_ms) {
  tx_.assign({0xFF, 0xFF, id, static_cast<uint8_t>(data.size() + 3), 0x03, address});
  tx_.insert(tx_.end(), data.begin(), data.end());
  tx_.push_back(checksum(tx_));
  send(tx_);
  return receive_status(id, {}, timeout_ms);
}

void Protocol1Client::sync_write(uint8_t address, uint8_t length, std::span<const uint8_t> ids,
                                 std::span<const uint8_t> data) {
  if (data.size() != ids.size() * length) throw std::invalid_argument("sync_write: data size does not match ids x length");
  const std::size_t param_count = 2 + ids.size() * (1 + length);
  tx_.assign({0xFF, 0xFF, 0xFE, static_cast<uint8_t>(param_count + 2), 0x83, address, length});
  for (std::size_t i = 0; i < ids.size(); ++i) {
    tx_.push_back(ids[i]);
    tx_.insert(tx_.end(), data.begin() + static_cast<long>(i * length), data.begin() + static_cast<long>((i + 1) * length));
  }
  tx_.push_back(checksum(tx_));
  send(tx_);
}

}  // namespace walk
