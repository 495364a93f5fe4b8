#pragma once
// The team-communication facet: the hub inside doppel (docs/teamcomm.md) and its registered robots.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "contract/error.h"

namespace doppel::contract {

// The team-communication hub inside doppel (docs/teamcomm.md) and its registered robots.
struct TeamcommRobot {
  int team = 0;      // 0..255
  int player = 0;    // 0..255
  uint16_t port = 0; // where its software receives (and sends from)
};
struct TeamcommLink {
  TeamcommRobot from, to;
  uint64_t relayed = 0, dropped = 0, delayed = 0, queue_full = 0, send_errors = 0;
};
struct TeamcommStatus {
  std::string listen;         // ADDRESS:PORT the hub receives on
  std::string robot_address;  // where the robots' software runs
  double loss = 0.0, delay_ms = 0.0, jitter_ms = 0.0;
  uint64_t received = 0, unknown_sender = 0, oversized = 0;
  std::vector<TeamcommRobot> robots;
  std::vector<TeamcommLink> links;
};

class Teamcomm {
 public:
  virtual ~Teamcomm() = default;
  // None while no hub runs (doppel --teamcomm starts one).
  virtual std::optional<TeamcommStatus> teamcomm() = 0;
  virtual Outcome teamcomm_add(const TeamcommRobot& robot) = 0;
  virtual Outcome teamcomm_remove(int team, int player) = 0;
};

}  // namespace doppel::contract
