#pragma once
// The RoboCup GameController's UDP packets as the Humanoid League used them from 2017 to 2024:
// RoboCupGameControlData ("RGme", struct version 12, port 3838) and RoboCupGameControlReturnData
// ("RGrt", version 2, port 3939). Doppel's own encoder and decoder, written from the published
// header include/RoboCupGameControlData.h of github.com/RoboCup-Humanoid-TC/GameController at
// commit c7200dcf763c758951ae7516d577b117e16f9156 (2021-05-29) and from the Java classes that put
// the bytes on the wire there (src/data/communication/GameControlData.java, TeamInfo.java,
// src/data/PlayerInfo.java, GameControlReturnData.java): every field little-endian, packed, no
// padding. The same layout is HlRoboCupGameControlData in that repository's 2025 header
// (game_controller_msgs/headers/new_RoboCupGameControlData.h, HL_GAMECONTROLLER_STRUCT_VERSION 12).
// Encoding and decoding do not allocate; a bad packet is a DecodeStatus, never an exception.

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

namespace doppel::gamecontroller {

inline constexpr std::uint16_t kDataPort = 3838;    // GAMECONTROLLER_DATA_PORT
inline constexpr std::uint16_t kReturnPort = 3939;  // GAMECONTROLLER_RETURN_PORT
inline constexpr std::uint16_t kStructVersion = 12;        // GAMECONTROLLER_STRUCT_VERSION (uint16 on the wire)
inline constexpr std::uint8_t kReturnStructVersion = 2;    // GAMECONTROLLER_RETURN_STRUCT_VERSION
inline constexpr std::array<char, 4> kHeader{'R', 'G', 'm', 'e'};
inline constexpr std::array<char, 4> kReturnHeader{'R', 'G', 'r', 't'};
inline constexpr std::size_t kMaxPlayers = 11;          // MAX_NUM_PLAYERS (the Humanoid header)
inline constexpr std::size_t kCoachMessageSize = 253;   // SPL_COACH_MESSAGE_SIZE (SPLCoachMessage.h)

// Packed sizes, as the Java classes' SIZE constants add them up.
inline constexpr std::size_t kRobotInfoSize = 6;
inline constexpr std::size_t kTeamInfoSize = 1 + 1 + 1 + 1 + 2 + 1 + kCoachMessageSize + (kMaxPlayers + 1) * kRobotInfoSize;
inline constexpr std::size_t kDataSize = 4 + 2 + 1 + 1 + 1 + 1 + 1 + 1 + 1 + 4 + 1 + 2 + 2 + 2 + 2 * kTeamInfoSize;
inline constexpr std::size_t kReturnSize = 4 + 1 + 1 + 1 + 1;
static_assert(kTeamInfoSize == 332 && kDataSize == 688 && kReturnSize == 8);

enum class State : std::uint8_t { kInitial = 0, kReady = 1, kSet = 2, kPlaying = 3, kFinished = 4 };

// STATE2_*: the Humanoid protocol's "secondary state" is what later versions call game phase and
// set play (penalty shoot-out, overtime, timeout, free kicks, corner and goal kicks, throw-in).
enum class SecondaryState : std::uint8_t {
  kNormal = 0,
  kPenaltyShoot = 1,
  kOvertime = 2,
  kTimeout = 3,
  kDirectFreekick = 4,
  kIndirectFreekick = 5,
  kPenaltyKick = 6,
  kCornerKick = 7,
  kGoalKick = 8,
  kThrowIn = 9,
};

inline constexpr std::uint8_t kTeamCyan = 0;     // TEAM_CYAN
inline constexpr std::uint8_t kTeamMagenta = 1;  // TEAM_MAGENTA
inline constexpr std::uint8_t kDropBall = 255;   // DROPBALL: kickOffTeam when nobody kicks off
inline constexpr std::uint8_t kGameRoundRobin = 0;  // GAME_ROUNDROBIN

// Penalty codes of the Humanoid League (HL_*) and the common ones.
inline constexpr std::uint8_t kPenaltyNone = 0;
inline constexpr std::uint8_t kPenaltySubstitute = 14;
inline constexpr std::uint8_t kPenaltyBallManipulation = 30;
inline constexpr std::uint8_t kPenaltyPhysicalContact = 31;
inline constexpr std::uint8_t kPenaltyIllegalAttack = 32;
inline constexpr std::uint8_t kPenaltyIllegalDefense = 33;
inline constexpr std::uint8_t kPenaltyPickupOrIncapable = 34;
inline constexpr std::uint8_t kPenaltyService = 35;

// GAMECONTROLLER_RETURN_MSG_*.
inline constexpr std::uint8_t kReturnManPenalise = 0;
inline constexpr std::uint8_t kReturnManUnpenalise = 1;
inline constexpr std::uint8_t kReturnAlive = 2;

struct RobotInfo {
  std::uint8_t penalty = kPenaltyNone;
  std::uint8_t secs_till_unpenalised = 0;
  std::uint8_t number_of_warnings = 0;
  std::uint8_t yellow_card_count = 0;
  std::uint8_t red_card_count = 0;
  std::uint8_t goalkeeper = 0;  // a C++ bool in the header, one byte 0/1 on the wire
  bool operator==(const RobotInfo&) const = default;
};

struct TeamInfo {
  std::uint8_t team_number = 0;
  std::uint8_t team_colour = kTeamCyan;
  std::uint8_t score = 0;
  std::uint8_t penalty_shot = 0;
  std::uint16_t single_shots = 0;  // bit i: shot i scored
  std::uint8_t coach_sequence = 0;
  std::array<std::uint8_t, kCoachMessageSize> coach_message{};
  RobotInfo coach;
  std::array<RobotInfo, kMaxPlayers> players{};  // players[0] is player number 1
  bool operator==(const TeamInfo&) const = default;
};

struct GameControlData {
  std::uint8_t packet_number = 0;
  std::uint8_t players_per_team = 4;
  std::uint8_t game_type = kGameRoundRobin;
  State state = State::kInitial;
  std::uint8_t first_half = 1;
  std::uint8_t kick_off_team = kDropBall;  // a team number, or kDropBall
  SecondaryState secondary_state = SecondaryState::kNormal;
  std::array<std::uint8_t, 4> secondary_state_info{};
  std::uint8_t drop_in_team = 0;
  std::uint16_t drop_in_time = 0xffff;  // -1 before the first drop-in
  std::uint16_t secs_remaining = 600;
  std::uint16_t secondary_time = 0;
  std::array<TeamInfo, 2> teams{};
  bool operator==(const GameControlData&) const = default;
};

struct ReturnData {
  std::uint8_t team = 0;
  std::uint8_t player = 0;  // starts at 1
  std::uint8_t message = kReturnAlive;
  bool operator==(const ReturnData&) const = default;
};

enum class DecodeStatus { kOk, kWrongSize, kWrongHeader, kWrongVersion, kBadValue };
std::string_view to_string(DecodeStatus status);
std::string_view to_string(State state);

using DataBytes = std::array<std::uint8_t, kDataSize>;
using ReturnBytes = std::array<std::uint8_t, kReturnSize>;

void encode(const GameControlData& data, DataBytes& out);
// A packet of any other size than kDataSize is kWrongSize; a state or secondary state outside the
// header's constants is kBadValue. `out` is only written on kOk.
DecodeStatus decode(std::span<const std::uint8_t> bytes, GameControlData& out);

void encode(const ReturnData& data, ReturnBytes& out);
DecodeStatus decode(std::span<const std::uint8_t> bytes, ReturnData& out);

}  // namespace doppel::gamecontroller
