#include "dynamixel/bus_devices.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <vector>

namespace doppel::dynamixel {
namespace {

using Bytes = std::vector<uint8_t>;

// A device that answers with fixed bytes and fixed timing, to test ordering and collisions.
class ScriptedDevice : public Device {
 public:
  ScriptedDevice(uint8_t id, uint32_t baud_bps, Bytes reply, ReplyTiming timing = ReplyTiming::kAfterInstruction,
                 uint16_t chain_position = 0)
      : id_(id), baud_bps_(baud_bps), reply_(std::move(reply)), timing_(timing), chain_position_(chain_position) {}

  Protocol protocol() const noexcept override { return Protocol::kV1; }
  uint8_t id() const noexcept override { return id_; }
  uint32_t baud_bps() const noexcept override { return baud_bps_; }
  uint32_t return_delay_us() const noexcept override { return 2u * id_; }
  std::string_view model_name() const noexcept override { return "SCRIPTED"; }
  uint16_t model_number() const noexcept override { return 0; }

  void handle(const InstructionPacket&, Response& response) noexcept override {
    ++seen;
    if (reply_.empty()) {
      return;
    }
    response.transmits = true;
    response.timing = timing_;
    response.chain_position = chain_position_;
    response.status.size = static_cast<uint16_t>(reply_.size());
    std::copy(reply_.begin(), reply_.end(), response.status.bytes.begin());
    if (change_id_to) {
      id_ = change_id_to;
    }
  }

  int seen = 0;
  uint8_t change_id_to = 0;

 private:
  uint8_t id_;
  uint32_t baud_bps_;
  Bytes reply_;
  ReplyTiming timing_;
  uint16_t chain_position_;
};

Bytes bytes_of(const OutgoingStatus& s) { return Bytes(s.packet->bytes.begin(), s.packet->bytes.begin() + s.packet->size); }

InstructionPacket any_packet() {
  InstructionPacket p;
  p.id = kBroadcastId;
  p.instruction = instruction::kPing;
  return p;
}

TEST(BaudRatesMatch, ToleratesThreePercent) {
  EXPECT_TRUE(baud_rates_match(57143, 57600));    // register 34, reference §3.2
  EXPECT_TRUE(baud_rates_match(117647, 115200));  // register 16, -2.1 %
  EXPECT_TRUE(baud_rates_match(1000000, 1000000));
  EXPECT_FALSE(baud_rates_match(1000000, 57600));
  EXPECT_FALSE(baud_rates_match(1000000, 960000));
  EXPECT_FALSE(baud_rates_match(0, 57600));
}

TEST(BusDevices, SingleReplyGoesOutAfterTheInstruction) {
  ScriptedDevice a(1, 1000000, {0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC});
  BusDevices sut;
  sut.add(a);

  const auto out = sut.dispatch(any_packet(), 1000000);

  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(bytes_of(out[0]), (Bytes{0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC}));
  EXPECT_EQ(out[0].device_id, 1);
  EXPECT_EQ(out[0].return_delay_us, 2u);
  EXPECT_FALSE(out[0].after_previous);
  EXPECT_FALSE(out[0].collision);
  EXPECT_EQ(sut.counters().instructions, 1u);
}

TEST(BusDevices, DevicesAtAnotherBaudRateDoNotSeeThePacket) {
  ScriptedDevice fast(1, 1000000, {0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC});
  ScriptedDevice slow(2, 57143, {0xFF, 0xFF, 0x02, 0x02, 0x00, 0xFB});
  BusDevices sut;
  sut.add(fast);
  sut.add(slow);

  const auto out = sut.dispatch(any_packet(), 57600);

  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].device_id, 2);
  EXPECT_EQ(fast.seen, 0);
  EXPECT_EQ(sut.counters().baud_mismatches, 0u);
  EXPECT_TRUE(sut.dispatch(any_packet(), 9600).empty());
  EXPECT_EQ(sut.counters().baud_mismatches, 1u);
}

TEST(BusDevices, SimultaneousRepliesCollideAsWiredAnd) {
  ScriptedDevice a(1, 1000000, {0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC});
  ScriptedDevice b(2, 1000000, {0xFF, 0xFF, 0x02, 0x02, 0x00, 0xFB});
  BusDevices sut;
  sut.add(a);
  sut.add(b);

  const auto out = sut.dispatch(any_packet(), 1000000);

  ASSERT_EQ(out.size(), 1u);
  EXPECT_TRUE(out[0].collision);
  EXPECT_EQ(bytes_of(out[0]), (Bytes{0xFF, 0xFF, 0x00, 0x02, 0x00, 0xF8}));
  EXPECT_EQ(out[0].return_delay_us, 2u);
  EXPECT_EQ(sut.counters().collisions, 1u);
}

TEST(BusDevices, CollisionWithLongerReplyKeepsItsTail) {
  ScriptedDevice a(1, 1000000, {0xF0, 0x0F});
  ScriptedDevice b(2, 1000000, {0x3C, 0xFF, 0x55});
  BusDevices sut;
  sut.add(a);
  sut.add(b);

  const auto out = sut.dispatch(any_packet(), 1000000);

  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(bytes_of(out[0]), (Bytes{0x30, 0x0F, 0x55}));
}

TEST(BusDevices, ChainedRepliesGoOutInChainOrder) {
  ScriptedDevice third(3, 1000000, {0x03}, ReplyTiming::kAfterPrevious, 2);
  ScriptedDevice first(1, 1000000, {0x01}, ReplyTiming::kAfterInstruction, 0);
  ScriptedDevice second(2, 1000000, {0x02}, ReplyTiming::kAfterPrevious, 1);
  BusDevices sut;
  sut.add(third);
  sut.add(first);
  sut.add(second);

  const auto out = sut.dispatch(any_packet(), 1000000);

  ASSERT_EQ(out.size(), 3u);
  EXPECT_EQ(out[0].device_id, 1);
  EXPECT_FALSE(out[0].after_previous);
  EXPECT_EQ(out[1].device_id, 2);
  EXPECT_TRUE(out[1].after_previous);
  EXPECT_EQ(out[2].device_id, 3);
  EXPECT_TRUE(out[2].after_previous);
  EXPECT_EQ(sut.counters().broken_chains, 0u);
}

TEST(BusDevices, SilentPredecessorBreaksTheRestOfTheChain) {
  ScriptedDevice first(1, 1000000, {0x01}, ReplyTiming::kAfterInstruction, 0);
  ScriptedDevice third(3, 1000000, {0x03}, ReplyTiming::kAfterPrevious, 2);
  ScriptedDevice fourth(4, 1000000, {0x04}, ReplyTiming::kAfterPrevious, 3);
  BusDevices sut;
  sut.add(first);
  sut.add(third);
  sut.add(fourth);

  const auto out = sut.dispatch(any_packet(), 1000000);

  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].device_id, 1);
  EXPECT_EQ(sut.counters().broken_chains, 2u);
}

TEST(BusDevices, MissingFirstDeviceSilencesTheWholeChain) {
  ScriptedDevice second(2, 1000000, {0x02}, ReplyTiming::kAfterPrevious, 1);
  BusDevices sut;
  sut.add(second);

  EXPECT_TRUE(sut.dispatch(any_packet(), 1000000).empty());
  EXPECT_EQ(sut.counters().broken_chains, 1u);
}

TEST(BusDevices, SenderIdIsTakenBeforeTheDeviceChangesIt) {
  ScriptedDevice a(1, 1000000, {0x01});
  a.change_id_to = 7;
  BusDevices sut;
  sut.add(a);

  const auto out = sut.dispatch(any_packet(), 1000000);

  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].device_id, 1);
  EXPECT_EQ(a.id(), 7);
}

TEST(BusDevices, SilentDevicesProduceNothing) {
  ScriptedDevice a(1, 1000000, {});
  BusDevices sut;
  sut.add(a);

  EXPECT_TRUE(sut.dispatch(any_packet(), 1000000).empty());
  EXPECT_EQ(a.seen, 1);
}

TEST(BusDevices, UnpoweredDeviceNeitherSeesNorAnswersUntilPoweredAgain) {
  ScriptedDevice controller(200, 1000000, {0xFF, 0xFF, 0xC8, 0x02, 0x00, 0x35});
  ScriptedDevice servo(1, 1000000, {0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC});
  BusDevices sut;
  sut.add(controller);
  sut.add(servo);
  EXPECT_TRUE(sut.powered(1));

  sut.set_powered(1, false);
  const auto off = sut.dispatch(any_packet(), 1000000);

  ASSERT_EQ(off.size(), 1u);
  EXPECT_EQ(off[0].device_id, 200);
  EXPECT_EQ(servo.seen, 0);
  EXPECT_FALSE(sut.powered(1));
  EXPECT_EQ(sut.counters().baud_mismatches, 0u);

  sut.set_powered(1, true);
  const auto on = sut.dispatch(any_packet(), 1000000);
  ASSERT_EQ(on.size(), 1u);
  EXPECT_TRUE(on[0].collision);  // both answer the broadcast PING again
  EXPECT_EQ(servo.seen, 1);
}

TEST(BusDevices, AddThrowsWhenFull) {
  std::vector<ScriptedDevice> devices;
  devices.reserve(BusDevices::kMaxDevices + 1);
  BusDevices sut;
  for (std::size_t i = 0; i < BusDevices::kMaxDevices; ++i) {
    devices.emplace_back(static_cast<uint8_t>(i), 1000000, Bytes{});
    sut.add(devices.back());
  }
  devices.emplace_back(99, 1000000, Bytes{});

  EXPECT_THROW(sut.add(devices.back()), std::length_error);
  EXPECT_EQ(sut.devices().size(), BusDevices::kMaxDevices);
}

}  // namespace
}  // namespace doppel::dynamixel
