// Real device models on one BusDevices: what the wire carries back for whole transactions.
#include <gtest/gtest.h>

#include "dynamixel/bus_devices.h"
#include "dynamixel/fumanoid_boards.h"
#include "dynamixel/protocol1_servo.h"
#include "test_support.h"

namespace doppel::dynamixel {
namespace {

using testing::Bytes;
using testing::make_packet;
using testing::parse_one;

constexpr uint32_t k1Mbps = 1000000;

Bytes bytes_of(const OutgoingStatus& s) { return Bytes(s.packet->bytes.begin(), s.packet->bytes.begin() + s.packet->size); }

class BusIntegration : public ::testing::Test {
 protected:
  Protocol1Servo mx1{model_spec("MX-28"), 1, 1, 0};
  Protocol1Servo mx2{model_spec("MX-64"), 2, 1, 10};
  Protocol1Servo mx3{model_spec("MX-106"), 3, 1, 20};
  BusDevices sut;
};

TEST_F(BusIntegration, BroadcastPingWithSeveralDevicesCollides) {
  sut.add(mx1);
  sut.add(mx2);
  sut.add(mx3);

  const auto out = sut.dispatch(parse_one({0xFF, 0xFF, 0xFE, 0x02, 0x01, 0xFE}), k1Mbps);

  ASSERT_EQ(out.size(), 1u);
  EXPECT_TRUE(out[0].collision);
  // Wired-AND of FF FF 01 02 00 FC, FF FF 02 02 00 FB, FF FF 03 02 00 FA.
  EXPECT_EQ(bytes_of(out[0]), (Bytes{0xFF, 0xFF, 0x00, 0x02, 0x00, 0xF8}));
  EXPECT_EQ(sut.counters().collisions, 1u);
}

TEST_F(BusIntegration, BroadcastPingWithOneDeviceIsClean) {
  sut.add(mx2);

  const auto out = sut.dispatch(parse_one({0xFF, 0xFF, 0xFE, 0x02, 0x01, 0xFE}), k1Mbps);

  ASSERT_EQ(out.size(), 1u);
  EXPECT_FALSE(out[0].collision);
  EXPECT_EQ(bytes_of(out[0]), (Bytes{0xFF, 0xFF, 0x02, 0x02, 0x00, 0xFB}));
}

TEST_F(BusIntegration, BulkReadChainInListOrder) {
  sut.add(mx3);
  sut.add(mx1);
  sut.add(mx2);
  // BULK READ [len 1, ID 2, addr 3], [1, ID 3, 3], [1, ID 1, 3]: 3N+3 = 12 = 0x0C.
  // ~(FE + 0C + 92 + 00 + 01 02 03 + 01 03 03 + 01 01 03) = ~0xAE (low byte) = 0x51
  const Bytes bulk = {0xFF, 0xFF, 0xFE, 0x0C, 0x92, 0x00, 0x01, 0x02, 0x03, 0x01, 0x03, 0x03, 0x01, 0x01, 0x03, 0x51};

  const auto out = sut.dispatch(parse_one(bulk), k1Mbps);

  ASSERT_EQ(out.size(), 3u);
  // Each device answers its ID register: FF FF id 03 00 id ~(2*id + 3).
  EXPECT_EQ(bytes_of(out[0]), (Bytes{0xFF, 0xFF, 0x02, 0x03, 0x00, 0x02, 0xF8}));
  EXPECT_EQ(bytes_of(out[1]), (Bytes{0xFF, 0xFF, 0x03, 0x03, 0x00, 0x03, 0xF6}));
  EXPECT_EQ(bytes_of(out[2]), (Bytes{0xFF, 0xFF, 0x01, 0x03, 0x00, 0x01, 0xFA}));
  EXPECT_FALSE(out[0].after_previous);
  EXPECT_TRUE(out[1].after_previous);
  EXPECT_TRUE(out[2].after_previous);
  EXPECT_EQ(out[0].return_delay_us, 20u);
  EXPECT_EQ(out[1].return_delay_us, 40u);
}

TEST_F(BusIntegration, BulkReadWithMissingDeviceInTheMiddleEndsTheChain) {
  sut.add(mx1);
  sut.add(mx3);
  // [2, ID 1, 36], [2, ID 2, 36], [2, ID 3, 36]; ID 2 is not on the bus.
  const auto packet = make_packet(kBroadcastId, instruction::kBulkRead, {0x00, 2, 1, 36, 2, 2, 36, 2, 3, 36});

  const auto out = sut.dispatch(packet, k1Mbps);

  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].device_id, 1);
  EXPECT_EQ(sut.counters().broken_chains, 1u);
}

TEST_F(BusIntegration, BulkReadWithMissingFirstDeviceGetsNoReply) {
  sut.add(mx2);
  const auto packet = make_packet(kBroadcastId, instruction::kBulkRead, {0x00, 2, 9, 36, 2, 2, 36});

  EXPECT_TRUE(sut.dispatch(packet, k1Mbps).empty());
  EXPECT_EQ(sut.counters().broken_chains, 1u);
}

TEST_F(BusIntegration, AxInABulkReadListBreaksTheChain) {
  Protocol1Servo ax(model_spec("AX-12A"), 4, 1, 0);
  sut.add(mx1);
  sut.add(ax);
  sut.add(mx2);
  const auto packet = make_packet(kBroadcastId, instruction::kBulkRead, {0x00, 1, 1, 3, 1, 4, 3, 1, 2, 3});

  const auto out = sut.dispatch(packet, k1Mbps);

  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].device_id, 1);
}

TEST_F(BusIntegration, BulkReadIncludesSensorBoards) {
  FumanoidImu imu(100, 1, 0);
  FumanoidFootBoard foot(101, 1, 0);
  sut.add(mx1);
  sut.add(imu);
  sut.add(foot);
  const auto packet = make_packet(kBroadcastId, instruction::kBulkRead, {0x00, 2, 1, 36, 18, 100, 26, 10, 101, 26});

  const auto out = sut.dispatch(packet, k1Mbps);

  ASSERT_EQ(out.size(), 3u);
  EXPECT_EQ(out[1].device_id, 100);
  EXPECT_EQ(out[1].packet->size, 6 + 18);
  EXPECT_EQ(out[2].device_id, 101);
  EXPECT_EQ(out[2].packet->size, 6 + 10);
}

TEST_F(BusIntegration, BaudChangeAnswersAtTheOldRate) {
  Protocol1Servo rx(model_spec("RX-28"), 5, 34, 250);  // factory 57 600 bps
  sut.add(rx);

  // WRITE ID 5 Baud Rate := 1 (1 Mbps), sent at 57 600.
  const auto out = sut.dispatch(make_packet(5, instruction::kWrite, {p1::kBaudRate, 1}), 57600);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(bytes_of(out[0]), (Bytes{0xFF, 0xFF, 0x05, 0x02, 0x00, 0xF8}));

  EXPECT_TRUE(sut.dispatch(make_packet(5, instruction::kPing), 57600).empty());
  EXPECT_EQ(sut.counters().baud_mismatches, 1u);
  EXPECT_EQ(sut.dispatch(make_packet(5, instruction::kPing), k1Mbps).size(), 1u);
}

TEST_F(BusIntegration, ReturnDelayChangeAppliesFromTheNextPacket) {
  sut.add(mx2);  // Return Delay Time 10 = 20 us

  const auto out = sut.dispatch(make_packet(2, instruction::kWrite, {p1::kReturnDelayTime, 100}), k1Mbps);

  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].return_delay_us, 20u);
  EXPECT_EQ(sut.dispatch(make_packet(2, instruction::kPing), k1Mbps)[0].return_delay_us, 200u);
}

TEST_F(BusIntegration, BroadcastResetIsSilentAndResetsAll) {
  sut.add(mx2);
  sut.add(mx3);

  EXPECT_TRUE(sut.dispatch(parse_one({0xFF, 0xFF, 0xFE, 0x02, 0x06, 0xF9}), k1Mbps).empty());
  EXPECT_EQ(mx2.id(), 1);
  EXPECT_EQ(mx3.id(), 1);
  EXPECT_EQ(mx2.baud_bps(), 57142u);
}

}  // namespace
}  // namespace doppel::dynamixel
