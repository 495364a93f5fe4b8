#pragma once
// The start-up of a driver that changes the rate by closing and reopening the port (DynamixelSDK's
// PortHandlerLinux::setBaudRate: closePort() then setupPort()), repeated to catch the reopen race;
// and busy processes to load the CPUs while it runs. Shared by tests/gateway and bench/reopen_race.

#include <sys/types.h>

#include <cstdint>
#include <string>
#include <vector>

namespace doppel::testing {

struct StartupOutcome {
  int answered = 0;            // PINGs that got their exact status
  uint32_t line_bps_after = 0; // the rate the client's own termios showed after its PINGs (0: unreadable)
  std::string first_failure;   // the first PING that failed and how ("" when all were answered)
};

// Opens `port` at `first_bps` the way setupPort does (O_RDWR|O_NOCTTY|O_NONBLOCK; a zeroed termios
// with Bxxxx|CS8|CLOCAL|CREAD, IGNPAR, VMIN = VTIME = 0; tcflush(TCIFLUSH); tcsetattr(TCSANOW)),
// closes it, opens it again at `second_bps` the same way and at once sends `pings` Protocol 1.0
// PINGs to `id`, each waiting up to `timeout_ms` for its 6-byte status. Both rates must be
// standard Bxxxx rates. Throws std::runtime_error when the port cannot be opened.
StartupOutcome reopen_startup(const std::string& port, uint32_t first_bps, uint32_t second_bps, uint8_t id,
                              int pings, int timeout_ms);

// Starts `processes` shells that spin forever (`sh -c 'while :; do :; done'`), kills them on
// destruction.
class BusyLoad {
 public:
  explicit BusyLoad(int processes);
  ~BusyLoad();
  BusyLoad(const BusyLoad&) = delete;
  BusyLoad& operator=(const BusyLoad&) = delete;

 private:
  std::vector<pid_t> children_;
};

}  // namespace doppel::testing
