#include "analyzer/instruction.h"

#include <gtest/gtest.h>

#include "transaction_builder.h"

namespace doppel::analyzer {
namespace {

using testing::Bytes;
using testing::p1_instruction;
using testing::p2_instruction;

TEST(InstructionTest, KindNames) {
  EXPECT_EQ(kind_name(2, 0x82), "P2 SYNC READ");
  EXPECT_EQ(kind_name(1, 0x92), "P1 BULK READ");
  EXPECT_EQ(kind_name(1, 0x02), "P1 READ");
  EXPECT_EQ(kind_name(1, 0x84), "P1 SYNC READ (USB2AX)");
  EXPECT_EQ(kind_name(2, 0x77), "P2 0x77");
}

// Golden bytes from the e-Manual's Protocol 1.0 READ example: FF FF 01 04 02 2B 01 CC.
TEST(InstructionTest, DecodesManualBytes) {
  const Bytes read{0xFF, 0xFF, 0x01, 0x04, 0x02, 0x2B, 0x01, 0xCC};
  const Instruction in = decode_instruction(1, read);
  ASSERT_TRUE(in.framed);
  EXPECT_EQ(in.id, 1);
  EXPECT_EQ(in.code, 0x02);
  EXPECT_EQ(in.params, (Bytes{0x2B, 0x01}));
  EXPECT_FALSE(decode_instruction(1, Bytes(read.begin(), read.end() - 1)).framed);
  Bytes two = read;
  two.insert(two.end(), read.begin(), read.end());
  EXPECT_FALSE(decode_instruction(1, two).framed);
  EXPECT_FALSE(decode_instruction(2, read).framed);
}

TEST(InstructionTest, AddressedDevicesOfMultiDeviceInstructions) {
  const Instruction sync_read = decode_instruction(2, p2_instruction(0xFE, 0x82, {132, 0, 4, 0, 1, 2, 3}));
  const auto devices = addressed_devices(sync_read);
  ASSERT_EQ(devices.size(), 3u);
  EXPECT_EQ(devices[2].id, 3);
  EXPECT_EQ(devices[2].read_bytes, 4);
  // P1 BULK READ: 00, then LEN ID ADDR per device.
  const Instruction bulk = decode_instruction(1, p1_instruction(0xFE, 0x92, {0x00, 2, 1, 36, 6, 200, 30}));
  const auto bulk_devices = addressed_devices(bulk);
  ASSERT_EQ(bulk_devices.size(), 2u);
  EXPECT_EQ(bulk_devices[1].id, 200);
  EXPECT_EQ(bulk_devices[1].read_bytes, 6);
  // A SYNC WRITE whose data does not fill whole device blocks does not parse.
  EXPECT_TRUE(addressed_devices(decode_instruction(2, p2_instruction(0xFE, 0x83, {116, 0, 4, 0, 1, 0, 0}))).empty());
}

TEST(InstructionTest, SignatureLeavesWrittenDataOut) {
  const auto a = decode_instruction(2, p2_instruction(0xFE, 0x83, {116, 0, 4, 0, 1, 0, 8, 0, 0, 2, 0, 8, 0, 0}));
  const auto b = decode_instruction(2, p2_instruction(0xFE, 0x83, {116, 0, 4, 0, 1, 9, 9, 0, 0, 2, 7, 7, 0, 0}));
  const auto c = decode_instruction(2, p2_instruction(0xFE, 0x83, {116, 0, 4, 0, 1, 0, 8, 0, 0, 3, 0, 8, 0, 0}));
  EXPECT_EQ(signature(a), signature(b));
  EXPECT_NE(signature(a), signature(c));
  const auto w1 = decode_instruction(1, p1_instruction(1, 0x03, {30, 0, 2}));
  const auto w2 = decode_instruction(1, p1_instruction(1, 0x03, {30, 5, 5}));
  const auto w3 = decode_instruction(1, p1_instruction(1, 0x03, {32, 0, 2}));
  EXPECT_EQ(signature(w1), signature(w2));
  EXPECT_NE(signature(w1), signature(w3));
  const auto r1 = decode_instruction(1, p1_instruction(1, 0x02, {36, 2}));
  const auto r2 = decode_instruction(1, p1_instruction(1, 0x02, {38, 2}));
  EXPECT_NE(signature(r1), signature(r2));
}

// Reference §2.4: LEN = INST + params + CRC and a packet is LEN + 7 bytes. SYNC WRITE of 4 B to
// 2 of 20 servos: params 4 + 2 * 5 = 14, LEN 17, 24 bytes.
TEST(InstructionTest, SubsetIsReencodedWithTheProtocolLayout) {
  Bytes params{116, 0, 4, 0};
  for (uint8_t id = 1; id <= 20; ++id) params.insert(params.end(), {id, 0, 8, 0, 0});
  const Instruction in = decode_instruction(2, p2_instruction(0xFE, 0x83, params));
  const Bytes sub = encode_subset(in, [](uint8_t id) { return id == 4 || id == 17; });
  EXPECT_EQ(sub.size(), 24u);
  const Instruction back = decode_instruction(2, sub);
  ASSERT_TRUE(back.framed);
  EXPECT_EQ(back.params, (Bytes{116, 0, 4, 0, 4, 0, 8, 0, 0, 17, 0, 8, 0, 0}));
  EXPECT_TRUE(encode_subset(in, [](uint8_t) { return false; }).empty());
  // P1 SYNC WRITE FF FF FE LEN 83 ADDR L (ID data)... CK, 2 of 3 servos with 2 B each:
  // LEN = INST + 2 + 2 * 3 + CK = 10, 14 bytes.
  const Instruction p1 = decode_instruction(1, p1_instruction(0xFE, 0x83, {30, 2, 1, 0, 2, 2, 0, 2, 3, 0, 2}));
  EXPECT_EQ(encode_subset(p1, [](uint8_t id) { return id != 2; }).size(), 14u);
}

}  // namespace
}  // namespace doppel::analyzer
