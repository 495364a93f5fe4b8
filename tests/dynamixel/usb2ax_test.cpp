// The USB2AX firmware model against the published firmware (Xevel/usb2ax, firmware/lufa_usb2ax):
// golden bytes follow the Protocol 1.0 framing of reference §1.1 and the firmware's own status
// construction (AX.c axStatusPacket, sync_read), computed by hand in the comments.
#include <gtest/gtest.h>

#include "dynamixel/usb2ax.h"
#include "test_support.h"

namespace doppel::dynamixel {
namespace {

using testing::Bytes;

InstructionPacket framed(const Bytes& bytes) {
  auto parsed = testing::parse_all<Protocol1Parser>(bytes);
  EXPECT_EQ(parsed.packets.size(), 1u);
  return parsed.packets.empty() ? InstructionPacket{} : parsed.packets.front();
}

Bytes bytes_of(const StatusPacket& status) { return Bytes(status.bytes.begin(), status.bytes.begin() + status.size); }

TEST(Usb2axFirmware, AnswersPingOfItsOwnId253) {
  Usb2axFirmware sut;
  // PING 253: CK = ~(FD + 02 + 01) = ~0x00 = FF; status CK = ~(FD + 02 + 00) = ~FF = 00.
  EXPECT_EQ(sut.handle(framed({0xFF, 0xFF, 0xFD, 0x02, 0x01, 0xFF})), Usb2axFirmware::Action::kAnswer);
  EXPECT_EQ(bytes_of(sut.status()), (Bytes{0xFF, 0xFF, 0xFD, 0x02, 0x00, 0x00}));
}

TEST(Usb2axFirmware, ReadsItsControlTable) {
  Usb2axFirmware sut;
  // READ 253 addresses 0..3: model 0x4201 (L 01, H 42), firmware 5, ID FD (AX.c regs[]).
  // CK = ~(FD + 04 + 02 + 00 + 04) = ~0x07 = F8; status CK = ~(FD+06+00+01+42+05+FD) = ~0x48 = B7.
  EXPECT_EQ(sut.handle(framed({0xFF, 0xFF, 0xFD, 0x04, 0x02, 0x00, 0x04, 0xF8})), Usb2axFirmware::Action::kAnswer);
  EXPECT_EQ(bytes_of(sut.status()), (Bytes{0xFF, 0xFF, 0xFD, 0x06, 0x00, 0x01, 0x42, 0x05, 0xFD, 0xB7}));
  // Past its 18 registers: range error (0x08), CK = ~(FD + 02 + 08) = ~0x07 = F8.
  EXPECT_EQ(sut.handle(framed({0xFF, 0xFF, 0xFD, 0x04, 0x02, 0x10, 0x04, 0xE8})), Usb2axFirmware::Action::kAnswer);
  EXPECT_EQ(bytes_of(sut.status()), (Bytes{0xFF, 0xFF, 0xFD, 0x02, 0x08, 0xF8}));
}

TEST(Usb2axFirmware, WritesOnlyItsTimeoutsAndOnlyAboveTheirMinimum) {
  Usb2axFirmware sut;
  // WRITE 253 address 4 (USART_TIMEOUT) = 100: CK = ~(FD + 04 + 03 + 04 + 64) = ~0x6C = 93.
  EXPECT_EQ(sut.handle(framed({0xFF, 0xFF, 0xFD, 0x04, 0x03, 0x04, 0x64, 0x93})), Usb2axFirmware::Action::kAnswer);
  EXPECT_EQ(bytes_of(sut.status()), (Bytes{0xFF, 0xFF, 0xFD, 0x02, 0x00, 0x00}));
  EXPECT_EQ(sut.registers()[4], 100);
  EXPECT_EQ(sut.usart_timeout_ns(), 101 * 20'000);
  // USART_TIMEOUT = 7 is below USART_TIMEOUT_MIN 8: range error, register kept.
  EXPECT_EQ(sut.handle(framed({0xFF, 0xFF, 0xFD, 0x04, 0x03, 0x04, 0x07, 0xF0})), Usb2axFirmware::Action::kAnswer);
  EXPECT_EQ(bytes_of(sut.status()), (Bytes{0xFF, 0xFF, 0xFD, 0x02, 0x08, 0xF8}));
  EXPECT_EQ(sut.registers()[4], 100);
  // The ID (address 3) is below START_RW_ADDR: range error. CK = ~(FD+04+03+03+01) = ~0x08 = F7.
  EXPECT_EQ(sut.handle(framed({0xFF, 0xFF, 0xFD, 0x04, 0x03, 0x03, 0x01, 0xF7})), Usb2axFirmware::Action::kAnswer);
  EXPECT_EQ(sut.status().bytes[4], 0x08);
  EXPECT_EQ(sut.registers()[3], 0xFD);
}

TEST(Usb2axFirmware, SyncReadOfTwoAx12PresentPositionsReturnsOneStatusWithBothValues) {
  Usb2axFirmware sut;
  // SYNC READ (0x84) broadcast, Present Position (36 = 0x24), 2 bytes, servos 1 and 2:
  // CK = ~(FE + 06 + 84 + 24 + 02 + 01 + 02) = ~0xB1 = 4E.
  ASSERT_EQ(sut.handle(framed({0xFF, 0xFF, 0xFE, 0x06, 0x84, 0x24, 0x02, 0x01, 0x02, 0x4E})),
            Usb2axFirmware::Action::kSyncRead);
  ASSERT_EQ(sut.servo_count(), 2u);
  // The READs it sends (axGetRegister): FF FF 01 04 02 24 02 CK.
  const InstructionPacket& first = sut.servo_read(0);
  EXPECT_EQ(first.id, 1);
  EXPECT_EQ(first.instruction, 0x02);
  EXPECT_EQ(first.param_count, 2);
  EXPECT_EQ(first.params[0], 0x24);
  EXPECT_EQ(first.params[1], 0x02);
  EXPECT_EQ(sut.servo_read(1).id, 2);
  EXPECT_EQ(sut.expected_answer_bytes(), 8u);
  // AX-12 answers, positions 0x0200 and 0x0300: CK = ~(01+04+00+00+02) = F8, ~(02+04+00+00+03) = F6.
  const Bytes one{0xFF, 0xFF, 0x01, 0x04, 0x00, 0x00, 0x02, 0xF8};
  const Bytes two{0xFF, 0xFF, 0x02, 0x04, 0x00, 0x00, 0x03, 0xF6};
  sut.add_servo_answer(one.data(), one.size());
  sut.add_servo_answer(two.data(), two.size());
  // FF FF FD (2 + 2 * 2) 00 00 02 00 03 CK, CK = ~(FD + 06 + 00 + 00 + 02 + 00 + 03) = ~0x08 = F7.
  EXPECT_EQ(bytes_of(sut.finish_sync_read()), (Bytes{0xFF, 0xFF, 0xFD, 0x06, 0x00, 0x00, 0x02, 0x00, 0x03, 0xF7}));
}

TEST(Usb2axFirmware, SyncReadFillsASilentOrCorruptServoWithFF) {
  Usb2axFirmware sut;
  ASSERT_EQ(sut.handle(framed({0xFF, 0xFF, 0xFE, 0x06, 0x84, 0x24, 0x02, 0x01, 0x02, 0x4E})),
            Usb2axFirmware::Action::kSyncRead);
  const Bytes corrupt{0xFF, 0xFF, 0x01, 0x04, 0x00, 0x00, 0x02, 0xF9};  // checksum off by one
  sut.add_servo_answer(corrupt.data(), corrupt.size());
  sut.add_servo_answer(nullptr, 0);
  // CK = ~(FD + 06 + 00 + FF * 4) = ~(0x103 + 0x3FC) = ~0xFF = 00.
  EXPECT_EQ(bytes_of(sut.finish_sync_read()), (Bytes{0xFF, 0xFF, 0xFD, 0x06, 0x00, 0xFF, 0xFF, 0xFF, 0xFF, 0x00}));
}

TEST(Usb2axFirmware, SyncReadTooLongForItsBuffersIsARangeError) {
  Usb2axFirmware sut;
  // 120 bytes from each of 2 servos = 240 > 229 (AX_MAX_RETURN_PACKET_SIZE - 6).
  // CK = ~(FE + 06 + 84 + 00 + 78 + 01 + 02) = ~0x203 = FC.
  EXPECT_EQ(sut.handle(framed({0xFF, 0xFF, 0xFE, 0x06, 0x84, 0x00, 0x78, 0x01, 0x02, 0xFC})),
            Usb2axFirmware::Action::kAnswer);
  EXPECT_EQ(bytes_of(sut.status()), (Bytes{0xFF, 0xFF, 0xFD, 0x02, 0x08, 0xF8}));
}

TEST(Usb2axFirmware, PassesEverythingElseToTheServos) {
  Usb2axFirmware sut;
  // PING 1 (reference §1.7), a broadcast WRITE, a packet for 253 with a bad checksum.
  EXPECT_EQ(sut.handle(framed({0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB})), Usb2axFirmware::Action::kPassThrough);
  EXPECT_EQ(sut.handle(framed({0xFF, 0xFF, 0xFE, 0x04, 0x03, 0x19, 0x01, 0xE0})), Usb2axFirmware::Action::kPassThrough);
  EXPECT_EQ(sut.handle(framed({0xFF, 0xFF, 0xFD, 0x02, 0x01, 0x00})), Usb2axFirmware::Action::kPassThrough);
}

}  // namespace
}  // namespace doppel::dynamixel
