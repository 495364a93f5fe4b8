// Golden bytes from the header, not from the encoder: the expected packet is assembled here field by
// field in the order and with the sizes of RoboCupGameControlData in include/RoboCupGameControlData.h
// of github.com/RoboCup-Humanoid-TC/GameController at c7200dcf763c758951ae7516d577b117e16f9156
// (GAMECONTROLLER_STRUCT_VERSION 12), little-endian and packed as that repository's Java
// GameControlData.toByteArray() writes it.

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "gamecontroller/packet.h"

namespace gc = doppel::gamecontroller;

namespace {

gc::GameControlData sample() {
  gc::GameControlData data;
  data.packet_number = 0x2a;
  data.players_per_team = 4;
  data.game_type = 1;  // GAME_PLAYOFF
  data.state = gc::State::kPlaying;
  data.first_half = 0;
  data.kick_off_team = 7;
  data.secondary_state = gc::SecondaryState::kCornerKick;
  data.secondary_state_info = {7, 1, 0, 0};
  data.drop_in_team = 1;
  data.drop_in_time = 0x1234;
  data.secs_remaining = 0x0258;  // 600 s
  data.secondary_time = 0x00a1;
  for (std::size_t t = 0; t < 2; ++t) {
    gc::TeamInfo& team = data.teams[t];
    team.team_number = static_cast<std::uint8_t>(7 + t);
    team.team_colour = static_cast<std::uint8_t>(t);
    team.score = static_cast<std::uint8_t>(3 - t);
    team.penalty_shot = static_cast<std::uint8_t>(2 + t);
    team.single_shots = static_cast<std::uint16_t>(0xbeef + t);
    team.coach_sequence = static_cast<std::uint8_t>(0x55 + t);
    for (std::size_t i = 0; i < team.coach_message.size(); ++i) {
      team.coach_message[i] = static_cast<std::uint8_t>(i + t);
    }
    team.coach = {15, 1, 2, 3, 4, 0};
    for (std::size_t p = 0; p < gc::kMaxPlayers; ++p) {
      team.players[p] = {static_cast<std::uint8_t>(30 + p % 6), static_cast<std::uint8_t>(10 * p),
                         static_cast<std::uint8_t>(p % 2), static_cast<std::uint8_t>(p % 3),
                         static_cast<std::uint8_t>(p == 5), static_cast<std::uint8_t>(p == 0)};
    }
  }
  return data;
}

void put16(std::vector<std::uint8_t>& out, std::uint16_t value) {
  out.push_back(static_cast<std::uint8_t>(value & 0xff));
  out.push_back(static_cast<std::uint8_t>(value >> 8));
}

// The sample's packet, one push per header field; the comment gives each field's byte offset.
std::vector<std::uint8_t> expected_bytes() {
  std::vector<std::uint8_t> b;
  b.insert(b.end(), {'R', 'G', 'm', 'e'});  // 0: char header[4]
  put16(b, 12);                             // 4: uint16_t version
  b.push_back(0x2a);                        // 6: uint8_t packetNumber
  b.push_back(4);                           // 7: uint8_t playersPerTeam
  b.push_back(1);                           // 8: uint8_t gameType
  b.push_back(3);                           // 9: uint8_t state (STATE_PLAYING)
  b.push_back(0);                           // 10: uint8_t firstHalf
  b.push_back(7);                           // 11: uint8_t kickOffTeam
  b.push_back(7);                           // 12: uint8_t secondaryState (STATE2_CORNER_KICK)
  b.insert(b.end(), {7, 1, 0, 0});          // 13: char secondaryStateInfo[4]
  b.push_back(1);                           // 17: uint8_t dropInTeam
  put16(b, 0x1234);                         // 18: uint16_t dropInTime
  put16(b, 0x0258);                         // 20: uint16_t secsRemaining
  put16(b, 0x00a1);                         // 22: uint16_t secondaryTime
  for (std::size_t t = 0; t < 2; ++t) {     // 24 + 332 * t: TeamInfo teams[2]
    b.push_back(static_cast<std::uint8_t>(7 + t));     // +0: uint8_t teamNumber
    b.push_back(static_cast<std::uint8_t>(t));         // +1: uint8_t teamColour
    b.push_back(static_cast<std::uint8_t>(3 - t));     // +2: uint8_t score
    b.push_back(static_cast<std::uint8_t>(2 + t));     // +3: uint8_t penaltyShot
    put16(b, static_cast<std::uint16_t>(0xbeef + t));  // +4: uint16_t singleShots
    b.push_back(static_cast<std::uint8_t>(0x55 + t));  // +6: uint8_t coachSequence
    for (std::size_t i = 0; i < 253; ++i) {            // +7: uint8_t coachMessage[SPL_COACH_MESSAGE_SIZE = 253]
      b.push_back(static_cast<std::uint8_t>(i + t));
    }
    b.insert(b.end(), {15, 1, 2, 3, 4, 0});  // +260: RobotInfo coach (6 bytes, see below)
    for (std::size_t p = 0; p < 11; ++p) {   // +266 + 6 * p: RobotInfo players[MAX_NUM_PLAYERS = 11]
      b.push_back(static_cast<std::uint8_t>(30 + p % 6));  // +0: uint8_t penalty
      b.push_back(static_cast<std::uint8_t>(10 * p));      // +1: uint8_t secsTillUnpenalised
      b.push_back(static_cast<std::uint8_t>(p % 2));       // +2: uint8_t numberOfWarnings
      b.push_back(static_cast<std::uint8_t>(p % 3));       // +3: uint8_t yellowCardCount
      b.push_back(p == 5 ? 1 : 0);                         // +4: uint8_t redCardCount
      b.push_back(p == 0 ? 1 : 0);                         // +5: bool goalKeeper
    }
  }                                                        // 24 + 2 * 332 = 688 bytes
  return b;
}

}  // namespace

TEST(GameControlDataPacket, EncodesTheHeadersLayoutByteForByte) {
  const std::vector<std::uint8_t> expected = expected_bytes();
  ASSERT_EQ(expected.size(), 688u);
  gc::DataBytes bytes{};
  gc::encode(sample(), bytes);
  for (std::size_t i = 0; i < expected.size(); ++i) {
    ASSERT_EQ(bytes[i], expected[i]) << "byte " << i;
  }
}

TEST(GameControlDataPacket, DecodesTheHandBuiltBytes) {
  const std::vector<std::uint8_t> expected = expected_bytes();
  gc::GameControlData decoded;
  ASSERT_EQ(gc::decode(expected, decoded), gc::DecodeStatus::kOk);
  EXPECT_EQ(decoded, sample());
}

TEST(GameControlDataPacket, RefusesWrongSizeHeaderVersionAndValues) {
  std::vector<std::uint8_t> bytes = expected_bytes();
  gc::GameControlData decoded;
  const gc::GameControlData untouched = decoded;
  EXPECT_EQ(gc::decode(std::span(bytes).first(687), decoded), gc::DecodeStatus::kWrongSize);
  bytes.push_back(0);
  EXPECT_EQ(gc::decode(bytes, decoded), gc::DecodeStatus::kWrongSize);
  bytes.pop_back();
  bytes[3] = 'x';
  EXPECT_EQ(gc::decode(bytes, decoded), gc::DecodeStatus::kWrongHeader);
  bytes[3] = 'e';
  bytes[4] = 11;  // version 11
  EXPECT_EQ(gc::decode(bytes, decoded), gc::DecodeStatus::kWrongVersion);
  bytes[4] = 12;
  bytes[9] = 5;  // no STATE_ 5
  EXPECT_EQ(gc::decode(bytes, decoded), gc::DecodeStatus::kBadValue);
  bytes[9] = 3;
  bytes[12] = 10;  // no STATE2_ 10
  EXPECT_EQ(gc::decode(bytes, decoded), gc::DecodeStatus::kBadValue);
  EXPECT_EQ(decoded, untouched);
  EXPECT_EQ(gc::decode(std::span<const std::uint8_t>(), decoded), gc::DecodeStatus::kWrongSize);
}

// RoboCupGameControlReturnData: char header[4] "RGrt", uint8_t version (2), uint8_t team,
// uint8_t player, uint8_t message (GAMECONTROLLER_RETURN_MSG_ALIVE = 2).
TEST(GameControlReturnPacket, DecodesAHandBuiltPacket) {
  const std::vector<std::uint8_t> bytes{'R', 'G', 'r', 't', 2, 9, 3, 2};
  gc::ReturnData decoded;
  ASSERT_EQ(gc::decode(bytes, decoded), gc::DecodeStatus::kOk);
  EXPECT_EQ(decoded.team, 9);
  EXPECT_EQ(decoded.player, 3);
  EXPECT_EQ(decoded.message, gc::kReturnAlive);

  gc::ReturnBytes encoded{};
  gc::encode(gc::ReturnData{9, 3, 2}, encoded);
  EXPECT_EQ(std::vector<std::uint8_t>(encoded.begin(), encoded.end()), bytes);
}

TEST(GameControlReturnPacket, RefusesForeignPackets) {
  gc::ReturnData decoded;
  const std::vector<std::uint8_t> short_packet{'R', 'G', 'r', 't', 2, 9, 3};
  const std::vector<std::uint8_t> game_header{'R', 'G', 'm', 'e', 2, 9, 3, 2};
  const std::vector<std::uint8_t> old_version{'R', 'G', 'r', 't', 1, 9, 3, 2};
  // The SPL's return packet (version 4) is longer: header, version, playerNum, teamNum, fallen, floats.
  std::vector<std::uint8_t> spl(32, 0);
  spl[0] = 'R';
  spl[1] = 'G';
  spl[2] = 'r';
  spl[3] = 't';
  spl[4] = 4;
  EXPECT_EQ(gc::decode(short_packet, decoded), gc::DecodeStatus::kWrongSize);
  EXPECT_EQ(gc::decode(game_header, decoded), gc::DecodeStatus::kWrongHeader);
  EXPECT_EQ(gc::decode(old_version, decoded), gc::DecodeStatus::kWrongVersion);
  EXPECT_EQ(gc::decode(spl, decoded), gc::DecodeStatus::kWrongSize);
}
