// Protocol Type (13) of the X series and MX(2.0): 1 switches the servo to Protocol 1.0, 2 back.
// Golden packets: P1 framing and checksum of shared/reference/dynamixel.md §1.1 (PING and its
// status are §1.7's worked packets), P2 framing and CRC of §2.1/§2.2 (the empty OK status is §2.2's);
// the values come from the X table of §3.7. Where the reference is silent (error-bit mapping,
// instruction set of the P1 front end) the expectations are Doppel's documented choices
// (docs/devices.md P6.6).
#include <gtest/gtest.h>

#include <numbers>
#include <vector>

#include "dynamixel/bus_devices.h"
#include "dynamixel/packet_framer.h"
#include "dynamixel/protocol1_servo.h"
#include "dynamixel/protocol2_servo.h"
#include "test_support.h"

namespace doppel::dynamixel {
namespace {

using testing::Bytes;

InstructionPacket parse(const Bytes& wire) { return testing::frame_one<PacketFramer>(wire); }
Bytes transact(Device& sut, const Bytes& wire) { return testing::transact(sut, parse(wire)); }

// §1.7 / §2.2 worked packets.
const Bytes kP1Ping = {0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB};
const Bytes kP1Ok = {0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC};
const Bytes kP2Ping = {0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x03, 0x00, 0x01, 0x19, 0x4E};
const Bytes kP2PingStatus = {0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x07, 0x00, 0x55, 0x00, 0xFC, 0x03, 0x2D, 0x17, 0x43};
const Bytes kP2Ok = {0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x04, 0x00, 0x55, 0x00, 0xA1, 0x0C};
// P2 WRITE ID 1, Protocol Type (13) := 1.
const Bytes kP2SwitchToP1 = {0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x06, 0x00, 0x03, 0x0D, 0x00, 0x01, 0x3F, 0x63};
// P1 WRITE ID 1, Protocol Type (13) := 2.
const Bytes kP1SwitchToP2 = {0xFF, 0xFF, 0x01, 0x04, 0x03, 0x0D, 0x02, 0xE8};
// P1 status ID 1 with only the Range (0x08) / Angle Limit (0x02) / Instruction (0x40) / Checksum (0x10) bit.
const Bytes kP1Range = {0xFF, 0xFF, 0x01, 0x02, 0x08, 0xF4};
const Bytes kP1AngleLimit = {0xFF, 0xFF, 0x01, 0x02, 0x02, 0xFA};
const Bytes kP1Instruction = {0xFF, 0xFF, 0x01, 0x02, 0x40, 0xBC};
const Bytes kP1Checksum = {0xFF, 0xFF, 0x01, 0x02, 0x10, 0xEC};

class XmInProtocol1 : public ::testing::Test {
 protected:
  XmInProtocol1() {
    // The status of the switching WRITE goes out in the old protocol (2.0).
    EXPECT_EQ(transact(sut, kP2SwitchToP1), kP2Ok);
    EXPECT_EQ(sut.protocol(), Protocol::kV1);
  }
  Protocol2Servo sut{p2_model_spec("XM430-W350"), 1, 3, 0};
};

TEST_F(XmInProtocol1, AnswersProtocol1AndIgnoresProtocol2) {
  EXPECT_EQ(transact(sut, kP1Ping), kP1Ok);
  EXPECT_TRUE(transact(sut, kP2Ping).empty());
  EXPECT_EQ(sut.register_value(x430::kProtocolType), 1);
}

TEST(ProtocolType, Protocol2ServoIgnoresProtocol1UntilSwitched) {
  Protocol2Servo sut{p2_model_spec("XM430-W350"), 1, 3, 0};
  EXPECT_EQ(sut.protocol(), Protocol::kV2);
  EXPECT_TRUE(transact(sut, kP1Ping).empty());
  EXPECT_EQ(transact(sut, kP2Ping), kP2PingStatus);
}

TEST_F(XmInProtocol1, WritingTwoOverProtocol1SwitchesBack) {
  EXPECT_EQ(transact(sut, kP1SwitchToP2), kP1Ok);  // answered in Protocol 1.0, the old one
  EXPECT_EQ(sut.protocol(), Protocol::kV2);
  EXPECT_TRUE(transact(sut, kP1Ping).empty());
  EXPECT_EQ(transact(sut, kP2Ping), kP2PingStatus);
}

TEST(ProtocolType, OnlyOneAndTwoAreValues) {
  Protocol2Servo sut{p2_model_spec("XL430-W250"), 1, 3, 0};
  const Bytes write_0 = {0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x06, 0x00, 0x03, 0x0D, 0x00, 0x00, 0x3A, 0xE3};
  const Bytes write_3 = {0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x06, 0x00, 0x03, 0x0D, 0x00, 0x03, 0x30, 0xE3};
  const Bytes data_range = {0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x04, 0x00, 0x55, 0x04, 0xBA, 0x8C};
  EXPECT_EQ(transact(sut, write_0), data_range);
  EXPECT_EQ(transact(sut, write_3), data_range);
  EXPECT_EQ(sut.protocol(), Protocol::kV2);
}

TEST(ProtocolType, EepromLockAppliesToTheSwitch) {
  Protocol2Servo sut{p2_model_spec("XM430-W350"), 1, 3, 0};
  const Bytes torque_on = {0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x06, 0x00, 0x03, 0x40, 0x00, 0x01, 0xDB, 0x66};
  const Bytes access = {0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x04, 0x00, 0x55, 0x07, 0xB0, 0x8C};  // §2.2
  ASSERT_EQ(transact(sut, torque_on), kP2Ok);
  EXPECT_EQ(transact(sut, kP2SwitchToP1), access);
  EXPECT_EQ(sut.protocol(), Protocol::kV2);
}

TEST(ProtocolType, Mx2SwitchesToo) {
  Protocol2Servo sut{p2_model_spec("MX-28(2.0)"), 1, 3, 0};
  EXPECT_EQ(transact(sut, kP2SwitchToP1), kP2Ok);
  EXPECT_EQ(transact(sut, kP1Ping), kP1Ok);
  // READ 0, 2 -> model number 30.
  EXPECT_EQ(transact(sut, {0xFF, 0xFF, 0x01, 0x04, 0x02, 0x00, 0x02, 0xF6}),
            (Bytes{0xFF, 0xFF, 0x01, 0x04, 0x00, 0x1E, 0x00, 0xDC}));
}

TEST_F(XmInProtocol1, ReadsTheXTableWithOneByteAddresses) {
  // READ 0, 2: model number 1020 (0x03FC).
  EXPECT_EQ(transact(sut, {0xFF, 0xFF, 0x01, 0x04, 0x02, 0x00, 0x02, 0xF6}),
            (Bytes{0xFF, 0xFF, 0x01, 0x04, 0x00, 0xFC, 0x03, 0xFB}));
  // READ 132, 4: Present Position 2048 at 0 rad.
  EXPECT_EQ(transact(sut, {0xFF, 0xFF, 0x01, 0x04, 0x02, 0x84, 0x04, 0x70}),
            (Bytes{0xFF, 0xFF, 0x01, 0x06, 0x00, 0x00, 0x08, 0x00, 0x00, 0xF0}));
}

TEST_F(XmInProtocol1, WritesItemsWhole) {
  // WRITE 116 = 512 (4 bytes).
  EXPECT_EQ(transact(sut, {0xFF, 0xFF, 0x01, 0x07, 0x03, 0x74, 0x00, 0x02, 0x00, 0x00, 0x7E}), kP1Ok);
  EXPECT_EQ(sut.register_value(x430::kGoalPosition), 512);
  // Two bytes into the 4-byte Goal Position: refused (P2 Data Length -> P1 Range bit), nothing written.
  EXPECT_EQ(transact(sut, {0xFF, 0xFF, 0x01, 0x05, 0x03, 0x74, 0x00, 0x03, 0x7F}), kP1Range);
  EXPECT_EQ(sut.register_value(x430::kGoalPosition), 512);
}

TEST_F(XmInProtocol1, GoalOutsideThePositionLimitsIsTheAngleLimitBit) {
  // WRITE 116 = 4096 > Max Position Limit 4095 in position mode.
  EXPECT_EQ(transact(sut, {0xFF, 0xFF, 0x01, 0x07, 0x03, 0x74, 0x00, 0x10, 0x00, 0x00, 0x70}), kP1AngleLimit);
}

TEST_F(XmInProtocol1, AddressesAbove255AreOutOfReach) {
  // READ 250, 10 would run to 259: Range bit, no data.
  EXPECT_EQ(transact(sut, {0xFF, 0xFF, 0x01, 0x04, 0x02, 0xFA, 0x0A, 0xF4}), kP1Range);
  // WRITE of 7 bytes at 250 (to 256): Range bit.
  EXPECT_EQ(transact(sut, {0xFF, 0xFF, 0x01, 0x0A, 0x03, 0xFA, 0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07, 0xDB}),
            kP1Range);
  // ... but Indirect Data 1 (224) reaches any item: point Indirect Address 1 (168) at 578 (the low
  // byte of Indirect Address 29, default 634 = 0x027A) and read it through 224.
  EXPECT_EQ(transact(sut, {0xFF, 0xFF, 0x01, 0x05, 0x03, 0xA8, 0x42, 0x02, 0x0A}), kP1Ok);
  EXPECT_EQ(transact(sut, {0xFF, 0xFF, 0x01, 0x04, 0x02, 0xE0, 0x01, 0x17}), (Bytes{0xFF, 0xFF, 0x01, 0x03, 0x00, 0x7A, 0x81}));
}

TEST_F(XmInProtocol1, OnlyTheProtocol1InstructionSet) {
  // REBOOT (0x08) is not a P1 instruction (§1.2): Instruction bit.
  EXPECT_EQ(transact(sut, {0xFF, 0xFF, 0x01, 0x02, 0x08, 0xF4}), kP1Instruction);
  // SYNC READ (0x82) with the P1 framing: Instruction bit.
  EXPECT_EQ(transact(sut, {0xFF, 0xFF, 0x01, 0x04, 0x82, 0x84, 0x04, 0xF0}), kP1Instruction);
  // ACTION with nothing registered.
  EXPECT_EQ(transact(sut, {0xFF, 0xFF, 0x01, 0x02, 0x05, 0xF7}), kP1Instruction);
  // SYNC WRITE to ID 1 instead of the broadcast ID: Instruction bit, LED (65) unchanged.
  EXPECT_EQ(testing::transact(sut, testing::make_packet(1, instruction::kSyncWrite, {0x41, 0x01, 0x01, 0x01})),
            kP1Instruction);
  EXPECT_EQ(sut.register_value(x430::kLed), 0);
}

TEST_F(XmInProtocol1, StatusReturnLevelOfTheXTable) {
  // WRITE Status Return Level (68) := 1: answered under the old level 2.
  EXPECT_EQ(transact(sut, {0xFF, 0xFF, 0x01, 0x04, 0x03, 0x44, 0x01, 0xB2}), kP1Ok);
  // WRITE LED (65) := 1: executed without a status; READ 65, 1 is answered.
  EXPECT_TRUE(transact(sut, {0xFF, 0xFF, 0x01, 0x04, 0x03, 0x41, 0x01, 0xB5}).empty());
  EXPECT_EQ(transact(sut, {0xFF, 0xFF, 0x01, 0x04, 0x02, 0x41, 0x01, 0xB6}),
            (Bytes{0xFF, 0xFF, 0x01, 0x03, 0x00, 0x01, 0xFA}));
  // SYNC READ (0x82) counts as a read for the X firmware: answered, with the Instruction bit.
  EXPECT_EQ(transact(sut, {0xFF, 0xFF, 0x01, 0x04, 0x82, 0x84, 0x04, 0xF0}), kP1Instruction);
  // Level 0: only PING is answered.
  EXPECT_TRUE(transact(sut, {0xFF, 0xFF, 0x01, 0x04, 0x03, 0x44, 0x00, 0xB3}).empty());
  EXPECT_TRUE(transact(sut, {0xFF, 0xFF, 0x01, 0x04, 0x02, 0x41, 0x01, 0xB6}).empty());
  EXPECT_EQ(transact(sut, kP1Ping), kP1Ok);
}

TEST_F(XmInProtocol1, Protocol1PacketsFeedTheBusWatchdog) {
  ServoFeedback f;
  f.voltage_v = 12.0;
  f.sim_time_ns = 1'000'000'000;
  sut.apply(f);
  // WRITE Bus Watchdog (98) := 5 (100 ms), Torque Enable (64) := 1.
  ASSERT_EQ(transact(sut, {0xFF, 0xFF, 0x01, 0x04, 0x03, 0x62, 0x05, 0x90}), kP1Ok);
  ASSERT_EQ(transact(sut, {0xFF, 0xFF, 0x01, 0x04, 0x03, 0x40, 0x01, 0xB6}), kP1Ok);
  f.sim_time_ns += 90'000'000;
  sut.apply(f);
  ASSERT_EQ(transact(sut, kP1Ping), kP1Ok);
  f.sim_time_ns += 90'000'000;  // 180 ms after the WRITEs, 90 ms after the PING
  sut.apply(f);
  EXPECT_FALSE(sut.watchdog_tripped());
  f.sim_time_ns += 20'000'000;
  sut.apply(f);
  EXPECT_TRUE(sut.watchdog_tripped());
}

// DeviceCounters are counted by the Protocol 1.0 front end alike for both kinds of device: a
// broadcast SYNC WRITE counts once where it lists the device, a bad checksum and a refused READ
// count as such.
template <class Servo>
void expect_protocol1_counters(Servo& sut, uint8_t led_address) {
  const DeviceCounters before = sut.counters();
  testing::transact(sut, testing::make_packet(kBroadcastId, instruction::kSyncWrite, {led_address, 1, 2, 1}));
  EXPECT_EQ(sut.counters().handled, before.handled);  // lists only ID 2
  testing::transact(sut, testing::make_packet(kBroadcastId, instruction::kSyncWrite, {led_address, 1, 1, 1}));
  EXPECT_EQ(sut.counters().handled, before.handled + 1);
  EXPECT_EQ(sut.counters().errors, before.errors);
  InstructionPacket bad = testing::make_packet(1, instruction::kPing);
  bad.checksum_ok = false;
  testing::transact(sut, bad);
  EXPECT_EQ(sut.counters().bad_checksums, before.bad_checksums + 1);
  testing::transact(sut, testing::make_packet(1, instruction::kRead, {0, 0}));  // zero bytes: Range bit
  EXPECT_EQ(sut.counters().handled, before.handled + 3);
  EXPECT_EQ(sut.counters().errors, before.errors + 1);
}

TEST(ProtocolType, Protocol1CountersAlikeForBothKindsOfDevice) {
  Protocol1Servo rx64{model_spec("RX-64"), 1, 1, 250};
  expect_protocol1_counters(rx64, p1::kLed);
  EXPECT_EQ(rx64.register_raw(p1::kLed), 1);
  Protocol2Servo xm{p2_model_spec("XM430-W350"), 1, 3, 0};
  ASSERT_EQ(transact(xm, kP2SwitchToP1), kP2Ok);
  expect_protocol1_counters(xm, static_cast<uint8_t>(x430::kLed));
  EXPECT_EQ(xm.register_value(x430::kLed), 1);
}

TEST_F(XmInProtocol1, RegWriteAndAction) {
  // REG_WRITE 116 = 1024, then ACTION.
  EXPECT_EQ(transact(sut, {0xFF, 0xFF, 0x01, 0x07, 0x04, 0x74, 0x00, 0x04, 0x00, 0x00, 0x7B}), kP1Ok);
  EXPECT_EQ(sut.register_value(x430::kRegisteredInstruction), 1);
  EXPECT_EQ(sut.register_value(x430::kGoalPosition), 2048);
  EXPECT_EQ(transact(sut, {0xFF, 0xFF, 0x01, 0x02, 0x05, 0xF7}), kP1Ok);
  EXPECT_EQ(sut.register_value(x430::kGoalPosition), 1024);
  EXPECT_EQ(sut.register_value(x430::kRegisteredInstruction), 0);
}

TEST_F(XmInProtocol1, BadChecksumIsAnsweredWithTheChecksumBitAndNotExecuted) {
  EXPECT_EQ(transact(sut, {0xFF, 0xFF, 0x01, 0x07, 0x03, 0x74, 0x00, 0x02, 0x00, 0x00, 0x00}), kP1Checksum);
  EXPECT_EQ(sut.register_value(x430::kGoalPosition), 2048);
  // A PING with a bad checksum is not answered (as Doppel's P1 firmware, §1.4).
  EXPECT_TRUE(transact(sut, {0xFF, 0xFF, 0x01, 0x02, 0x01, 0x00}).empty());
}

TEST_F(XmInProtocol1, HardwareErrorsShowAsTheirProtocol1Bits) {
  ServoFeedback hot;
  hot.temperature_c = 90.0;  // > Temperature Limit 80; Overheating is in the default Shutdown (52)
  hot.voltage_v = 12.0;
  sut.apply(hot);
  ASSERT_EQ(sut.hardware_error(), x430::kOverheatingError);
  EXPECT_EQ(transact(sut, kP1Ping), (Bytes{0xFF, 0xFF, 0x01, 0x02, 0x04, 0xF8}));  // Overheating bit (0x04)
}

TEST_F(XmInProtocol1, FactoryResetAnswersInProtocol1ThenSpeaksProtocol2) {
  EXPECT_EQ(transact(sut, {0xFF, 0xFF, 0x01, 0x02, 0x06, 0xF6}), kP1Ok);
  EXPECT_EQ(sut.protocol(), Protocol::kV2);
  EXPECT_EQ(sut.register_value(x430::kBaudRate), 1);  // factory 57 600
}

TEST(ProtocolType, BulkReadAndSyncWriteOverProtocol1) {
  Protocol2Servo s1{p2_model_spec("XM430-W350"), 1, 3, 0};
  Protocol2Servo s2{p2_model_spec("XM430-W350"), 2, 3, 0, (1023 - 2048) * 2.0 * std::numbers::pi / 4096.0};
  const Bytes switch2 = {0xFF, 0xFF, 0xFD, 0x00, 0x02, 0x06, 0x00, 0x03, 0x0D, 0x00, 0x01, 0x0F, 0x60};
  ASSERT_EQ(transact(s1, kP2SwitchToP1), kP2Ok);
  ASSERT_FALSE(transact(s2, switch2).empty());
  BusDevices bus;
  bus.add(s1);
  bus.add(s2);
  // BULK READ [len, ID, addr]: ID 1 and ID 2, Present Position (132), 4 bytes; chained replies.
  const auto statuses =
      bus.dispatch(parse({0xFF, 0xFF, 0xFE, 0x09, 0x92, 0x00, 0x04, 0x01, 0x84, 0x04, 0x02, 0x84, 0x53}), 1000000);
  ASSERT_EQ(statuses.size(), 2u);
  EXPECT_EQ(Bytes(statuses[0].packet->bytes.begin(), statuses[0].packet->bytes.begin() + statuses[0].packet->size),
            (Bytes{0xFF, 0xFF, 0x01, 0x06, 0x00, 0x00, 0x08, 0x00, 0x00, 0xF0}));
  EXPECT_EQ(Bytes(statuses[1].packet->bytes.begin(), statuses[1].packet->bytes.begin() + statuses[1].packet->size),
            (Bytes{0xFF, 0xFF, 0x02, 0x06, 0x00, 0xFF, 0x03, 0x00, 0x00, 0xF5}));
  EXPECT_TRUE(statuses[1].after_previous);
  // SYNC WRITE [addr, len, (ID, data)...]: LED (65) := 1 on both.
  EXPECT_TRUE(bus.dispatch(parse({0xFF, 0xFF, 0xFE, 0x08, 0x83, 0x41, 0x01, 0x01, 0x01, 0x02, 0x01, 0x2F}), 1000000).empty());
  EXPECT_EQ(s1.register_value(x430::kLed), 1);
  EXPECT_EQ(s2.register_value(x430::kLed), 1);
}

TEST(ProtocolType, MixedBusAnswersEachProtocolFromItsOwnServos) {
  Protocol2Servo s1{p2_model_spec("XM430-W350"), 1, 3, 0};
  Protocol2Servo s2{p2_model_spec("XM430-W350"), 2, 3, 0};
  ASSERT_EQ(transact(s1, kP2SwitchToP1), kP2Ok);
  BusDevices bus;
  bus.add(s1);
  bus.add(s2);
  // P2 broadcast PING (§2.2): only ID 2 answers.
  const auto p2 = bus.dispatch(parse({0xFF, 0xFF, 0xFD, 0x00, 0xFE, 0x03, 0x00, 0x01, 0x31, 0x42}), 1000000);
  ASSERT_EQ(p2.size(), 1u);
  EXPECT_EQ(Bytes(p2[0].packet->bytes.begin(), p2[0].packet->bytes.begin() + p2[0].packet->size),
            (Bytes{0xFF, 0xFF, 0xFD, 0x00, 0x02, 0x07, 0x00, 0x55, 0x00, 0xFC, 0x03, 0x2D, 0x1D, 0x73}));
  // P1 PING of ID 1 is answered by ID 1.
  const auto p1 = bus.dispatch(parse(kP1Ping), 1000000);
  ASSERT_EQ(p1.size(), 1u);
  EXPECT_EQ(Bytes(p1[0].packet->bytes.begin(), p1[0].packet->bytes.begin() + p1[0].packet->size), kP1Ok);
}

}  // namespace
}  // namespace doppel::dynamixel
