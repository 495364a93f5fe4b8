// The seed corpora of the protocol fuzzers (fuzz/corpus/, written by fuzz/make_corpus.py from the
// reference) hold valid packets of every instruction: each file frames with a good checksum.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <string>
#include <vector>

#include "dynamixel/packet_framer.h"
#include "dynamixel/protocol1.h"

namespace doppel::dynamixel {
namespace {

constexpr std::size_t kWireStart = 2;  // fuzz/fuzz_support.h: line-rate and feedback bytes first

std::vector<std::vector<uint8_t>> corpus(const std::string& fuzzer) {
  std::vector<std::vector<uint8_t>> files;
  for (const auto& entry : std::filesystem::directory_iterator(std::string(DOPPEL_FUZZ_CORPUS_DIR) + "/" + fuzzer)) {
    std::ifstream in(entry.path(), std::ios::binary);
    files.emplace_back(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  return files;
}

TEST(FuzzCorpus, Protocol1SeedsAreValidPacketsOfEveryInstruction) {
  std::set<uint8_t> instructions;
  for (const std::vector<uint8_t>& file : corpus("protocol1_parser_fuzz")) {
    ASSERT_GT(file.size(), kWireStart);
    Protocol1Parser parser;
    int packets = 0;
    for (std::size_t i = kWireStart; i < file.size(); ++i) {
      if (parser.push(file[i]) != Protocol1Parser::Result::kPacket) continue;
      ++packets;
      EXPECT_TRUE(parser.packet().checksum_ok);
      instructions.insert(parser.packet().instruction);
    }
    EXPECT_GE(packets, 1);
    EXPECT_TRUE(parser.idle()) << "no trailing bytes";
  }
  // Reference §1.2: PING, READ, WRITE, REG_WRITE, ACTION, RESET, SYNC WRITE, BULK READ.
  EXPECT_EQ(instructions, (std::set<uint8_t>{0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x83, 0x92}));
}

TEST(FuzzCorpus, Protocol2SeedsAreValidPacketsOfEveryInstruction) {
  std::set<uint8_t> instructions;
  for (const std::vector<uint8_t>& file : corpus("protocol2_parser_fuzz")) {
    ASSERT_GT(file.size(), kWireStart);
    PacketFramer framer;
    int packets = 0;
    for (std::size_t i = kWireStart; i < file.size(); ++i) {
      if (framer.push(file[i]) != PacketFramer::Result::kPacket) continue;
      ++packets;
      EXPECT_TRUE(framer.packet().checksum_ok);
      if (framer.packet().protocol == Protocol::kV2) instructions.insert(framer.packet().instruction);
    }
    EXPECT_GE(packets, 1);
    EXPECT_TRUE(framer.idle()) << "no trailing bytes";
  }
  // Reference §2.4, every instruction a host sends.
  EXPECT_EQ(instructions, (std::set<uint8_t>{0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x08, 0x10, 0x20, 0x82, 0x83, 0x8A,
                                             0x92, 0x93, 0x9A}));
}

}  // namespace
}  // namespace doppel::dynamixel
