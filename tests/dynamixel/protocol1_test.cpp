#include "dynamixel/protocol1.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "test_support.h"

namespace doppel::dynamixel {
namespace {

using testing::Bytes;
using testing::params_of;
using testing::Parsed;

// Every packet the parser framed from `bytes`, fed in chunks of `chunk` bytes.
Parsed parse(const Bytes& bytes, std::size_t chunk = 1) { return testing::parse_all<Protocol1Parser>(bytes, chunk); }

TEST(Protocol1Checksum, ReferenceWorkedExample) {
  // Reference §1.1: FF FF 01 05 03 0C 64 AA -> checksum 0xDC.
  const uint8_t body[] = {0x01, 0x05, 0x03, 0x0C, 0x64, 0xAA};
  EXPECT_EQ(protocol1_checksum(body, sizeof body), 0xDC);
}

TEST(Protocol1Checksum, PingAndStatusOfReference) {
  const uint8_t ping[] = {0x01, 0x02, 0x01};
  const uint8_t status[] = {0x01, 0x02, 0x00};
  const uint8_t error_status[] = {0x01, 0x02, 0x24};
  EXPECT_EQ(protocol1_checksum(ping, 3), 0xFB);
  EXPECT_EQ(protocol1_checksum(status, 3), 0xFC);
  EXPECT_EQ(protocol1_checksum(error_status, 3), 0xD8);
}

TEST(Protocol1Parser, FramesReadInstructionOfReference) {
  const auto got = parse({0xFF, 0xFF, 0x01, 0x04, 0x02, 0x2B, 0x01, 0xCC});

  ASSERT_EQ(got.packets.size(), 1u);
  const auto& p = got.packets[0];
  EXPECT_EQ(p.protocol, Protocol::kV1);
  EXPECT_EQ(p.id, 1);
  EXPECT_EQ(p.instruction, instruction::kRead);
  EXPECT_TRUE(p.checksum_ok);
  EXPECT_EQ(params_of(p), (Bytes{0x2B, 0x01}));
  EXPECT_EQ(got.counters.packets, 1u);
  EXPECT_EQ(got.counters.dropped_bytes, 0u);
}

TEST(Protocol1Parser, FramesPingWithoutParams) {
  const auto got = parse({0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB});

  ASSERT_EQ(got.packets.size(), 1u);
  EXPECT_EQ(got.packets[0].instruction, instruction::kPing);
  EXPECT_EQ(got.packets[0].param_count, 0);
  EXPECT_TRUE(got.packets[0].checksum_ok);
}

TEST(Protocol1Parser, FramesSyncWriteOfReference) {
  const Bytes sync = {0xFF, 0xFF, 0xFE, 0x0E, 0x83, 0x1E, 0x04, 0x00, 0x10, 0x00,
                      0x50, 0x01, 0x01, 0x20, 0x02, 0x60, 0x03, 0x67};
  const auto got = parse(sync);

  ASSERT_EQ(got.packets.size(), 1u);
  EXPECT_EQ(got.packets[0].id, kBroadcastId);
  EXPECT_EQ(got.packets[0].instruction, instruction::kSyncWrite);
  EXPECT_TRUE(got.packets[0].checksum_ok);
  EXPECT_EQ(got.packets[0].param_count, 12);
}

TEST(Protocol1Parser, AnyChunkingGivesTheSameResult) {
  // Garbage, a READ, a stray FF, a BULK READ, a bad-checksum WRITE, a REG_WRITE.
  const Bytes stream = {0x00, 0x12, 0xFF, 0x33, 0xFF, 0xFF, 0x01, 0x04, 0x02, 0x2B, 0x01, 0xCC,
                        0xFF, 0xFF, 0xFF, 0xFE, 0x09, 0x92, 0x00, 0x02, 0x01, 0x1E, 0x02, 0x02, 0x24, 0x1D,
                        0xFF, 0xFF, 0x01, 0x05, 0x03, 0x1E, 0x00, 0x02, 0xD7,
                        0xFF, 0xFF, 0x01, 0x05, 0x04, 0x1E, 0xF4, 0x01, 0xE2};
  const auto reference = parse(stream, 1);
  ASSERT_EQ(reference.packets.size(), 4u);
  EXPECT_EQ(reference.packets[1].instruction, instruction::kBulkRead);
  EXPECT_TRUE(reference.packets[1].checksum_ok);
  EXPECT_FALSE(reference.packets[2].checksum_ok);
  EXPECT_TRUE(reference.packets[3].checksum_ok);

  for (std::size_t chunk = 2; chunk <= stream.size(); ++chunk) {
    const auto got = parse(stream, chunk);
    ASSERT_EQ(got.packets.size(), reference.packets.size()) << "chunk " << chunk;
    for (std::size_t i = 0; i < got.packets.size(); ++i) {
      EXPECT_EQ(got.packets[i].id, reference.packets[i].id);
      EXPECT_EQ(got.packets[i].instruction, reference.packets[i].instruction);
      EXPECT_EQ(got.packets[i].checksum_ok, reference.packets[i].checksum_ok);
      EXPECT_EQ(params_of(got.packets[i]), params_of(reference.packets[i]));
    }
    EXPECT_EQ(got.counters.dropped_bytes, reference.counters.dropped_bytes);
  }
}

TEST(Protocol1Parser, SkipsGarbageAndCountsDroppedBytes) {
  const auto got = parse({0x00, 0x12, 0xFF, 0x33, 0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB});

  ASSERT_EQ(got.packets.size(), 1u);
  EXPECT_EQ(got.packets[0].id, 1);
  EXPECT_EQ(got.counters.dropped_bytes, 4u);  // 00 12 and the lone FF 33
}

TEST(Protocol1Parser, ThirdFfKeepsTheHeader) {
  const auto got = parse({0xFF, 0xFF, 0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB});

  ASSERT_EQ(got.packets.size(), 1u);
  EXPECT_EQ(got.packets[0].id, 1);
  EXPECT_TRUE(got.packets[0].checksum_ok);
  EXPECT_EQ(got.counters.dropped_bytes, 2u);
}

TEST(Protocol1Parser, BadChecksumIsFramedByLenAndFlagged) {
  // WRITE Goal Position 512 with checksum D7 instead of D6, then a good PING.
  const auto got = parse({0xFF, 0xFF, 0x01, 0x05, 0x03, 0x1E, 0x00, 0x02, 0xD7,
                          0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB});

  ASSERT_EQ(got.packets.size(), 2u);
  EXPECT_FALSE(got.packets[0].checksum_ok);
  EXPECT_EQ(got.packets[0].instruction, instruction::kWrite);
  EXPECT_EQ(params_of(got.packets[0]), (Bytes{0x1E, 0x00, 0x02}));
  EXPECT_TRUE(got.packets[1].checksum_ok);
  EXPECT_EQ(got.counters.bad_checksums, 1u);
  EXPECT_EQ(got.counters.packets, 2u);
}

TEST(Protocol1Parser, ImpossibleLengthResyncs) {
  for (uint8_t len : {uint8_t{0}, uint8_t{1}}) {
    const auto got = parse({0xFF, 0xFF, 0x01, len, 0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB});

    ASSERT_EQ(got.packets.size(), 1u) << int(len);
    EXPECT_EQ(got.packets[0].instruction, instruction::kPing);
    EXPECT_TRUE(got.packets[0].checksum_ok);
    EXPECT_EQ(got.counters.bad_lengths, 1u);
  }
}

TEST(Protocol1Parser, MaximumLengthPacket) {
  Bytes bytes = {0xFF, 0xFF, 0x05, 0xFF, 0x03};
  auto sum = static_cast<uint8_t>(0x05 + 0xFF + 0x03);
  for (int i = 0; i < 253; ++i) {
    bytes.push_back(static_cast<uint8_t>(i));
    sum = static_cast<uint8_t>(sum + i);
  }
  bytes.push_back(static_cast<uint8_t>(~sum));

  const auto got = parse(bytes);

  ASSERT_EQ(got.packets.size(), 1u);
  EXPECT_EQ(got.packets[0].param_count, 253);
  EXPECT_TRUE(got.packets[0].checksum_ok);
}

TEST(Protocol1Parser, ResetDropsPartialPacketAndCountsTimeout) {
  Protocol1Parser sut;
  for (uint8_t b : {0xFF, 0xFF, 0x01, 0x04, 0x02}) {
    EXPECT_EQ(sut.push(b), Protocol1Parser::Result::kIncomplete);
  }
  EXPECT_FALSE(sut.idle());

  sut.reset();

  EXPECT_TRUE(sut.idle());
  EXPECT_EQ(sut.counters().timeouts, 1u);
  Protocol1Parser::Result last = Protocol1Parser::Result::kIncomplete;
  for (uint8_t b : {0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB}) {
    last = sut.push(b);
  }
  EXPECT_EQ(last, Protocol1Parser::Result::kPacket);
  EXPECT_EQ(sut.packet().instruction, instruction::kPing);
}

TEST(Protocol1Parser, IdleWhenNothingBuffered) {
  Protocol1Parser sut;
  EXPECT_TRUE(sut.idle());
  sut.reset();
  EXPECT_EQ(sut.counters().timeouts, 0u);
}

TEST(EncodeProtocol1Status, MatchesReferenceReplies) {
  StatusPacket sut;
  const uint8_t temperature[] = {0x20};
  ASSERT_TRUE(encode_protocol1_status(1, 0x00, temperature, 1, sut));
  EXPECT_EQ(Bytes(sut.bytes.begin(), sut.bytes.begin() + sut.size),
            (Bytes{0xFF, 0xFF, 0x01, 0x03, 0x00, 0x20, 0xDB}));

  ASSERT_TRUE(encode_protocol1_status(1, 0x24, nullptr, 0, sut));
  EXPECT_EQ(Bytes(sut.bytes.begin(), sut.bytes.begin() + sut.size), (Bytes{0xFF, 0xFF, 0x01, 0x02, 0x24, 0xD8}));
}

TEST(EncodeProtocol1Status, RejectsTooManyParams) {
  StatusPacket sut;
  std::vector<uint8_t> params(254);
  EXPECT_FALSE(encode_protocol1_status(1, 0, params.data(), params.size(), sut));
  EXPECT_EQ(sut.size, 0);
}

TEST(EncodeProtocol1Instruction, MatchesReferencePackets) {
  uint8_t out[32];
  const uint8_t goal[] = {0x1E, 0x00, 0x02};
  ASSERT_EQ(encode_protocol1_instruction(1, instruction::kWrite, goal, 3, out, sizeof out), 9u);
  EXPECT_EQ(Bytes(out, out + 9), (Bytes{0xFF, 0xFF, 0x01, 0x05, 0x03, 0x1E, 0x00, 0x02, 0xD6}));

  ASSERT_EQ(encode_protocol1_instruction(kBroadcastId, instruction::kAction, nullptr, 0, out, sizeof out), 6u);
  EXPECT_EQ(Bytes(out, out + 6), (Bytes{0xFF, 0xFF, 0xFE, 0x02, 0x05, 0xFA}));

  EXPECT_EQ(encode_protocol1_instruction(1, instruction::kWrite, goal, 3, out, 8), 0u);
}

}  // namespace
}  // namespace doppel::dynamixel
