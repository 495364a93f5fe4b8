#pragma once
// The game facet: the GameController inside doppel (docs/gamecontroller.md), its game as the
// packets carry it and the commands that change it.

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "contract/error.h"

namespace doppel::contract {

// The GameController inside doppel (docs/gamecontroller.md): its game as the packets carry it,
// whether it sends, and what the robots answered. Teams are index 0 (A, cyan) and 1 (B, magenta).
struct GamePenalty {
  uint32_t player = 0;           // 1..11
  uint32_t penalty = 0;          // the protocol's penalty code (34 = HL pick-up or incapable)
  std::string reason;            // its name (pickup_or_incapable, ...)
  uint32_t seconds_left = 0;     // secsTillUnpenalised
};
struct GameTeam {
  uint32_t number = 0;
  uint32_t score = 0;
  std::vector<GamePenalty> penalties;  // the penalised players only
};
struct GameReturn {
  uint32_t team = 0, player = 0;  // as the robot said (team number, player 1..11)
  std::string message;            // alive, manual_penalise, manual_unpenalise
  uint64_t count = 0;             // return packets from it so far
  double age_s = 0.0;             // since the last one
};
struct GameStatus {
  bool on = false;               // doppel's own GameController runs (its sockets are open)
  bool sending = false;          // and sends (off: `game off`, or stepped aside)
  std::string stepped_aside;     // why it stopped by itself ("" = it did not)
  std::string destination;       // ADDRESS:PORT its packets go to
  std::string return_address;    // ADDRESS:PORT it receives return packets on
  std::string watch;             // ADDRESS:PORT it watches for another GameController; "" = none
  std::string watch_error;       // why there is no watch although one was asked for
  std::string state;             // initial, ready, set, playing, finished
  bool first_half = true;
  uint32_t kick_off_team = 0;    // a team number, or 255 (drop ball)
  std::string secondary_state;   // normal, timeout, direct_free_kick, ... (the protocol's STATE2_*)
  uint32_t secondary_team = 0;   // secondaryStateInfo[0]
  uint32_t secondary_mode = 0;   // secondaryStateInfo[1]
  uint32_t secs_remaining = 0;
  uint32_t packet_number = 0;
  uint64_t sent = 0;
  std::array<GameTeam, 2> teams{};
  std::vector<GameReturn> returns;
  uint64_t bad_returns = 0;      // wrong size, header, version or an unknown robot
  // Another GameController the watch saw (its last packet): where from, how many, its game.
  bool foreign = false;
  std::string foreign_from;
  uint64_t foreign_packets = 0;
  std::string foreign_state;
  std::array<uint32_t, 2> foreign_teams{}, foreign_scores{};
  double foreign_age_s = 0.0;
};

// One checked command to the GameController (the HTTP layer checks names and ranges).
struct GameCommand {
  std::string command;     // on, off, state, goal, score, kickoff, penalize, unpenalize, set_play, timeout, normal
  std::string state;       // state: initial (a new game), ready, set, playing, finished
  int team = -1;           // 0 (A) or 1 (B); kickoff: -1 = drop ball
  uint32_t player = 0;     // penalize, unpenalize: 1..11
  uint32_t seconds = 30;   // penalize: 0..255
  uint32_t penalty = 34;   // penalize: the protocol's code (checked against kGamePenalties)
  uint32_t score = 0;      // score: 0..255
  std::string set_play;    // direct_free_kick, indirect_free_kick, penalty_kick, corner_kick, goal_kick, throw_in
  uint32_t mode = 0;       // set_play: secondaryStateInfo[1], 0..255
};

// The penalty names the API takes and shows, with the Humanoid League's codes (packet.h).
struct GamePenaltyName {
  const char* name;
  uint32_t code;
};
inline constexpr std::array<GamePenaltyName, 7> kGamePenalties{{{"substitute", 14},
                                                                {"ball_manipulation", 30},
                                                                {"physical_contact", 31},
                                                                {"illegal_attack", 32},
                                                                {"illegal_defense", 33},
                                                                {"pickup_or_incapable", 34},
                                                                {"service", 35}}};

class Game {
 public:
  virtual ~Game() = default;
  virtual GameStatus game() = 0;
  // Applies a checked command; kConflict with the game's reason when the game refuses it.
  virtual Outcome game_command(const GameCommand& command) = 0;
};

}  // namespace doppel::contract
