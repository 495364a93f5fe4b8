#pragma once
// A serial-port client written from shared/reference/dynamixel.md, not from Doppel's codec, so that
// a misreading shared by encoder and decoder cannot pass unnoticed. It opens the port the way the
// ROBOTIS SDK does (O_RDWR|O_NOCTTY|O_NONBLOCK, raw 8N1, VMIN = VTIME = 0) and speaks Protocol 1.0.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace doppel::testing {

using Bytes = std::vector<uint8_t>;

// FF FF ID LEN INST params CKSUM with CKSUM = ~(ID + LEN + INST + params) & 0xFF (reference §1.1).
Bytes p1_instruction(uint8_t id, uint8_t instruction, const Bytes& params = {});

// A status packet as parsed by the client (reference §1.1, §1.8 rules).
struct P1Status {
  uint8_t id = 0;
  uint8_t error = 0;
  Bytes params;
};

// Parses every complete status packet in `bytes`; returns nullopt if any packet is malformed
// (bad header, checksum, or trailing partial bytes).
std::optional<std::vector<P1Status>> parse_p1_statuses(const Bytes& bytes);

class SerialClient {
 public:
  // Opens `path` and sets `baud_bps` with cfsetspeed when it is a standard Bxxxx rate, otherwise
  // with TCSETS2/BOTHER. Throws std::runtime_error on failure.
  SerialClient(const std::string& path, uint32_t baud_bps);
  ~SerialClient();
  SerialClient(const SerialClient&) = delete;
  SerialClient& operator=(const SerialClient&) = delete;

  // tcflush(TCIFLUSH) then write all bytes, as the SDK does before each transmission.
  void send(const Bytes& bytes);
  // Reads until `count` bytes arrived or `timeout_ms` passed; returns what arrived.
  Bytes receive(std::size_t count, int timeout_ms);
  // Reads whatever arrives within `timeout_ms` (for "expect silence" checks).
  Bytes drain(int timeout_ms);
  // send() then receive(expected, timeout_ms). The default only guards against a hang (it returns
  // as soon as `expected` bytes came): a loaded machine may stall doppel's bus thread for a while,
  // and tests do not assert wall-clock timing. A check for silence names its own short timeout.
  Bytes transact(const Bytes& request, std::size_t expected, int timeout_ms = 5000);

  int fd() const { return fd_; }

 private:
  int fd_ = -1;
};

}  // namespace doppel::testing
