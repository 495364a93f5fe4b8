#include "gamecontroller/packet.h"

#include <algorithm>

namespace doppel::gamecontroller {

namespace {

// Writes fields in order, little-endian; the caller's array has exactly the packed size.
class Writer {
 public:
  explicit Writer(std::uint8_t* out) : out_(out) {}
  void u8(std::uint8_t value) { out_[at_++] = value; }
  void u16(std::uint16_t value) {
    u8(static_cast<std::uint8_t>(value & 0xff));
    u8(static_cast<std::uint8_t>(value >> 8));
  }
  template <std::size_t N, typename T>
  void bytes(const std::array<T, N>& values) {
    for (T value : values) {
      u8(static_cast<std::uint8_t>(value));
    }
  }
 private:
  std::uint8_t* out_;
  std::size_t at_ = 0;
};

class Reader {
 public:
  explicit Reader(std::span<const std::uint8_t> in) : in_(in) {}
  std::uint8_t u8() { return in_[at_++]; }
  std::uint16_t u16() {
    const std::uint8_t low = u8();
    return static_cast<std::uint16_t>(low | (u8() << 8));
  }
  template <std::size_t N>
  void bytes(std::array<std::uint8_t, N>& values) {
    for (std::uint8_t& value : values) {
      value = u8();
    }
  }

 private:
  std::span<const std::uint8_t> in_;
  std::size_t at_ = 0;
};

void write_robot(Writer& w, const RobotInfo& robot) {
  w.u8(robot.penalty);
  w.u8(robot.secs_till_unpenalised);
  w.u8(robot.number_of_warnings);
  w.u8(robot.yellow_card_count);
  w.u8(robot.red_card_count);
  w.u8(robot.goalkeeper);
}

void read_robot(Reader& r, RobotInfo& robot) {
  robot.penalty = r.u8();
  robot.secs_till_unpenalised = r.u8();
  robot.number_of_warnings = r.u8();
  robot.yellow_card_count = r.u8();
  robot.red_card_count = r.u8();
  robot.goalkeeper = r.u8();
}

bool has_header(std::span<const std::uint8_t> bytes, const std::array<char, 4>& header) {
  return std::equal(header.begin(), header.end(), bytes.begin(),
                    [](char h, std::uint8_t b) { return static_cast<std::uint8_t>(h) == b; });
}

}  // namespace

std::string_view to_string(DecodeStatus status) {
  switch (status) {
    case DecodeStatus::kOk: return "ok";
    case DecodeStatus::kWrongSize: return "wrong size";
    case DecodeStatus::kWrongHeader: return "wrong header";
    case DecodeStatus::kWrongVersion: return "wrong version";
    case DecodeStatus::kBadValue: return "value out of range";
  }
  return "?";
}

std::string_view to_string(State state) {
  switch (state) {
    case State::kInitial: return "INITIAL";
    case State::kReady: return "READY";
    case State::kSet: return "SET";
    case State::kPlaying: return "PLAYING";
    case State::kFinished: return "FINISHED";
  }
  return "?";
}

void encode(const GameControlData& data, DataBytes& out) {
  Writer w(out.data());
  w.bytes(kHeader);
  w.u16(kStructVersion);
  w.u8(data.packet_number);
  w.u8(data.players_per_team);
  w.u8(data.game_type);
  w.u8(static_cast<std::uint8_t>(data.state));
  w.u8(data.first_half);
  w.u8(data.kick_off_team);
  w.u8(static_cast<std::uint8_t>(data.secondary_state));
  w.bytes(data.secondary_state_info);
  w.u8(data.drop_in_team);
  w.u16(data.drop_in_time);
  w.u16(data.secs_remaining);
  w.u16(data.secondary_time);
  for (const TeamInfo& team : data.teams) {
    w.u8(team.team_number);
    w.u8(team.team_colour);
    w.u8(team.score);
    w.u8(team.penalty_shot);
    w.u16(team.single_shots);
    w.u8(team.coach_sequence);
    w.bytes(team.coach_message);
    write_robot(w, team.coach);
    for (const RobotInfo& robot : team.players) {
      write_robot(w, robot);
    }
  }
}

DecodeStatus decode(std::span<const std::uint8_t> bytes, GameControlData& out) {
  if (bytes.size() != kDataSize) {
    return DecodeStatus::kWrongSize;
  }
  if (!has_header(bytes, kHeader)) {
    return DecodeStatus::kWrongHeader;
  }
  Reader r(bytes.subspan(4));
  if (r.u16() != kStructVersion) {
    return DecodeStatus::kWrongVersion;
  }
  GameControlData data;
  data.packet_number = r.u8();
  data.players_per_team = r.u8();
  data.game_type = r.u8();
  const std::uint8_t state = r.u8();
  data.first_half = r.u8();
  data.kick_off_team = r.u8();
  const std::uint8_t secondary = r.u8();
  if (state > static_cast<std::uint8_t>(State::kFinished) ||
      secondary > static_cast<std::uint8_t>(SecondaryState::kThrowIn)) {
    return DecodeStatus::kBadValue;
  }
  data.state = static_cast<State>(state);
  data.secondary_state = static_cast<SecondaryState>(secondary);
  r.bytes(data.secondary_state_info);
  data.drop_in_team = r.u8();
  data.drop_in_time = r.u16();
  data.secs_remaining = r.u16();
  data.secondary_time = r.u16();
  for (TeamInfo& team : data.teams) {
    team.team_number = r.u8();
    team.team_colour = r.u8();
    team.score = r.u8();
    team.penalty_shot = r.u8();
    team.single_shots = r.u16();
    team.coach_sequence = r.u8();
    r.bytes(team.coach_message);
    read_robot(r, team.coach);
    for (RobotInfo& robot : team.players) {
      read_robot(r, robot);
    }
  }
  out = data;
  return DecodeStatus::kOk;
}

void encode(const ReturnData& data, ReturnBytes& out) {
  Writer w(out.data());
  w.bytes(kReturnHeader);
  w.u8(kReturnStructVersion);
  w.u8(data.team);
  w.u8(data.player);
  w.u8(data.message);
}

DecodeStatus decode(std::span<const std::uint8_t> bytes, ReturnData& out) {
  if (bytes.size() != kReturnSize) {
    return DecodeStatus::kWrongSize;
  }
  if (!has_header(bytes, kReturnHeader)) {
    return DecodeStatus::kWrongHeader;
  }
  if (bytes[4] != kReturnStructVersion) {
    return DecodeStatus::kWrongVersion;
  }
  out = ReturnData{bytes[5], bytes[6], bytes[7]};
  return DecodeStatus::kOk;
}

}  // namespace doppel::gamecontroller
