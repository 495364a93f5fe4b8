// The length-prefixed framing: 4 bytes little-endian, then the message; bounded, in any slicing.
#include "handshake/framing.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace doppel::handshake {
namespace {

std::vector<uint8_t> bytes(std::initializer_list<int> list) {
  std::vector<uint8_t> out;
  for (int b : list) {
    out.push_back(static_cast<uint8_t>(b));
  }
  return out;
}

TEST(Framing, EncodeWritesTheLengthLittleEndianFirst) {
  const std::string frame = encode_frame(std::string(258, 'x'));
  ASSERT_EQ(frame.size(), 262u);
  EXPECT_EQ(static_cast<uint8_t>(frame[0]), 0x02);
  EXPECT_EQ(static_cast<uint8_t>(frame[1]), 0x01);
  EXPECT_EQ(static_cast<uint8_t>(frame[2]), 0x00);
  EXPECT_EQ(static_cast<uint8_t>(frame[3]), 0x00);
  EXPECT_EQ(frame.substr(4), std::string(258, 'x'));
  EXPECT_EQ(encode_frame(""), std::string(4, '\0'));
}

TEST(Framing, DecodesAFrameFedOneByteAtATime) {
  const std::vector<uint8_t> wire = bytes({3, 0, 0, 0, 'a', 'b', 'c'});
  FrameDecoder decoder(16);
  for (std::size_t i = 0; i < wire.size(); ++i) {
    EXPECT_EQ(decoder.state(), FrameDecoder::State::kNeedMore);
    EXPECT_EQ(decoder.mid_frame(), i > 0);
    EXPECT_EQ(decoder.feed(&wire[i], 1), 1u);
  }
  ASSERT_EQ(decoder.state(), FrameDecoder::State::kFrame);
  EXPECT_EQ(decoder.frame(), "abc");
  decoder.next();
  EXPECT_EQ(decoder.state(), FrameDecoder::State::kNeedMore);
  EXPECT_FALSE(decoder.mid_frame());
}

TEST(Framing, StopsAfterEachFrameSoTheCallerFeedsTheRest) {
  const std::vector<uint8_t> wire = bytes({1, 0, 0, 0, 'x', 0, 0, 0, 0, 2, 0, 0, 0, 'y', 'z', 9});
  FrameDecoder decoder(16);
  std::vector<std::string> frames;
  std::size_t offset = 0;
  while (offset < wire.size()) {
    offset += decoder.feed(wire.data() + offset, wire.size() - offset);
    if (decoder.state() == FrameDecoder::State::kFrame) {
      frames.emplace_back(decoder.frame());
      decoder.next();
    }
  }
  EXPECT_EQ(frames, (std::vector<std::string>{"x", "", "yz"}));
  EXPECT_TRUE(decoder.mid_frame());  // the last byte starts a length
  EXPECT_EQ(decoder.feed(wire.data(), 0), 0u);
}

TEST(Framing, RefusesALengthAboveTheMaximumWithoutBufferingIt) {
  FrameDecoder decoder(1000);
  const std::vector<uint8_t> wire = bytes({0xE9, 0x03, 0, 0, 'a'});  // 1001
  EXPECT_EQ(decoder.feed(wire.data(), wire.size()), 4u);
  EXPECT_EQ(decoder.state(), FrameDecoder::State::kTooLarge);
  EXPECT_EQ(decoder.announced_length(), 1001u);
  EXPECT_EQ(decoder.feed(wire.data() + 4, 1), 0u);  // and takes nothing more
  FrameDecoder exact(1000);
  const std::vector<uint8_t> at_limit = bytes({0xE8, 0x03, 0, 0});
  exact.feed(at_limit.data(), at_limit.size());
  EXPECT_EQ(exact.state(), FrameDecoder::State::kNeedMore);
  const std::vector<uint8_t> huge = bytes({0xFF, 0xFF, 0xFF, 0xFF});
  FrameDecoder big(kDefaultMaxFrameBytes);
  big.feed(huge.data(), huge.size());
  EXPECT_EQ(big.state(), FrameDecoder::State::kTooLarge);
  EXPECT_EQ(big.announced_length(), 0xFFFFFFFFu);
}

}  // namespace
}  // namespace doppel::handshake
