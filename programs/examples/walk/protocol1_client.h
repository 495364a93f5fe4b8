#pragma once
// A small Dynamixel Protocol 1.0 client over a serial port, as a team's robot code has one: READ,
// WRITE and SYNC WRITE (the ROBOTIS e-Manual's Protocol 1.0 page). It knows nothing of Doppel.

#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace walk {

class Protocol1Client {
 public:
  // Opens `path` raw 8N1 at `baud_bps` (a standard rate: 57600, 115200, 1000000, ...).
  // Throws std::runtime_error naming the path on failure.
  Protocol1Client(const std::string& path, uint32_t baud_bps);
  ~Protocol1Client();
  Protocol1Client(const Protocol1Client&) = delete;
  Protocol1Client& operator=(const Protocol1Client&) = delete;

  // READ `out.size()` bytes from `address` of servo `id`; false on timeout, bad checksum or a
  // status with an error bit (the error byte is kept in last_error()).
  bool read(uint8_t id, uint8_t address, std::span<uint8_t> out, int timeout_ms = 100);
  // WRITE and wait for the status; false as read().
  bool write(uint8_t id, uint8_t address, std::span<const uint8_t> data, int timeout_ms = 100);
  // SYNC WRITE (broadcast, no status): `data` holds ids.size() blocks of `length` bytes each.
  void sync_write(uint8_t address, uint8_t length, std::span<const uint8_t> ids, std::span<const uint8_t> data);

  uint8_t last_error() const { return last_error_; }

 private:
  void send(const std::vector<uint8_t>& packet);
  // Reads one status packet from `id` with `param_count` parameters into `out`.
  bool receive_status(uint8_t id, std::span<uint8_t> out, int timeout_ms);

  int fd_ = -1;
  uint8_t last_error_ = 0;
  std::vector<uint8_t> tx_;  // reused packet buffer
  std::vector<uint8_t> rx_;
};

}  // namespace walk
