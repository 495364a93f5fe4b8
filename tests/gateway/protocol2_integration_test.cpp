// End-to-end Protocol 2.0: the real doppel executable serving data/robots/fumanoid-x430 (four buses
// at 4 Mbps), four real ptys opened as DynamixelSDK opens them (raw, TCSETS2/BOTHER 4 000 000),
// and the reference client of tests/support/reference_client_p2.h written from
// shared/reference/dynamixel.md. Expected bytes are the reference's worked packets or built with
// the reference's framing rules, never with Doppel's encoder.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <memory>
#include <thread>
#include <vector>

#include "doppel_process.h"
#include "gateway/robot_config.h"
#include "reference_client.h"
#include "reference_client_p2.h"

namespace doppel::testing {
namespace {

constexpr uint32_t kBaud = 4000000;
constexpr uint8_t kPing = 0x01, kRead = 0x02, kWrite = 0x03, kRegWrite = 0x04, kAction = 0x05, kFactoryReset = 0x06,
                  kReboot = 0x08, kClear = 0x10, kBackup = 0x20, kSyncRead = 0x82, kSyncWrite = 0x83,
                  kFastSyncRead = 0x8A, kBulkRead = 0x92, kBulkWrite = 0x93, kFastBulkRead = 0x9A;
constexpr uint8_t kBroadcast = 0xFE;
// XM430-W350 control table (reference §3.7).
constexpr uint16_t kReturnDelayTime = 9, kOperatingMode = 11, kVelocityLimit = 44, kTorqueEnable = 64, kLed = 65,
                   kHardwareErrorStatus = 70, kGoalPosition = 116, kMoving = 122, kPresentPosition = 132,
                   kPresentInputVoltage = 144, kPresentTemperature = 146;
// PING status parameters of an XM430-W350: model 1020 (0x03FC), firmware 45 (§2.2).
const Bytes kXmPing = {0xFC, 0x03, 0x2D};

// fumanoid-x430: bus 0 IDs 1, 2, 21 + IMU 241 + CORE 42; bus 1 IDs 3..8; bus 2 IDs 9..19 odd +
// BitFoot 102; bus 3 IDs 10..20 even + BitFoot 101.
const std::vector<std::vector<uint8_t>> kServos = {{1, 2, 21}, {3, 4, 5, 6, 7, 8}, {9, 11, 13, 15, 17, 19},
                                                   {10, 12, 14, 16, 18, 20}};

Bytes cat(Bytes a, const Bytes& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

Bytes read_params(uint16_t address, uint16_t length) { return cat(le16(address), le16(length)); }

// The bus, not the body: the servos move kinematically from 0 rad (Present Position 2048), as
// --physics none runs them (x430_physics_test.cpp drives the simulated body).
class X430Robot : public ::testing::Test {
 protected:
  explicit X430Robot(const char* timing = "fast")
      : doppel_({"--robot", "fumanoid-x430", "--physics", "none", "--timing", timing}, "ttyDXL3") {
    for (int bus = 0; bus < 4; ++bus) {
      clients_.push_back(std::make_unique<SerialClient>(doppel_.link("ttyDXL" + std::to_string(bus)), kBaud));
    }
  }
  SerialClient& bus(int index) { return *clients_.at(static_cast<std::size_t>(index)); }

  Bytes read(int b, uint8_t id, uint16_t address, uint16_t length) {
    return transact_p2(bus(b), p2_instruction(id, kRead, read_params(address, length)), 1);
  }
  Bytes write(int b, uint8_t id, uint16_t address, const Bytes& data) {
    return bus(b).transact(p2_instruction(id, kWrite, cat(le16(address), data)), 11);
  }
  int32_t read32(int b, uint8_t id, uint16_t address) {
    const auto statuses = parse_p2_statuses(read(b, id, address, 4));
    if (!statuses || statuses->size() != 1 || (*statuses)[0].params.size() != 4) {
      ADD_FAILURE() << "no 4-byte READ reply from ID " << int(id);
      return 0;
    }
    return le32_at((*statuses)[0].params, 0);
  }

  DoppelProcess doppel_;
  std::vector<std::unique_ptr<SerialClient>> clients_;
};

TEST_F(X430Robot, EveryServoOnEveryBusAnswersPing) {
  // Reference §2.2: PING ID 1 and the XM430-W350 answer, byte for byte.
  EXPECT_EQ(bus(0).transact({0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x03, 0x00, 0x01, 0x19, 0x4E}, 14),
            (Bytes{0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x07, 0x00, 0x55, 0x00, 0xFC, 0x03, 0x2D, 0x17, 0x43}));
  for (int b = 0; b < 4; ++b) {
    for (uint8_t id : kServos[static_cast<std::size_t>(b)]) {
      EXPECT_EQ(bus(b).transact(p2_instruction(id, kPing), 14), p2_status(id, 0, kXmPing)) << "bus " << b << " ID " << int(id);
    }
  }
  // A servo of another bus is not on this one.
  EXPECT_TRUE(bus(0).transact(p2_instruction(3, kPing), 14, 50).empty());
}

TEST_F(X430Robot, BitbotsBoardsAnswerTheirDriversPackets) {
  // Reference §8.7: IMU PING and the per-cycle READ 36/40 of a level IMU at rest.
  EXPECT_EQ(bus(0).transact({0xFF, 0xFF, 0xFD, 0x00, 0xF1, 0x03, 0x00, 0x01, 0x31, 0x8E}, 14),
            (Bytes{0xFF, 0xFF, 0xFD, 0x00, 0xF1, 0x07, 0x00, 0x55, 0x00, 0xFF, 0xBA, 0x01, 0xCB, 0xD7}));
  Bytes level = {0xFF, 0xFF, 0xFD, 0x00, 0xF1, 0x2C, 0x00, 0x55, 0x00};
  level.insert(level.end(), 20, 0x00);
  level = cat(level, {0x0A, 0xE8, 0x1C, 0x41});
  level.insert(level.end(), 12, 0x00);
  level = cat(level, {0x00, 0x00, 0x80, 0x3F, 0x2B, 0xEC});
  EXPECT_EQ(bus(0).transact({0xFF, 0xFF, 0xFD, 0x00, 0xF1, 0x07, 0x00, 0x02, 0x24, 0x00, 0x28, 0x00, 0x2F, 0x7F}, 55),
            level);
  // BitFoot PINGs (model 0, fw 1) on the leg buses.
  EXPECT_EQ(bus(3).transact(p2_instruction(101, kPing), 14),
            (Bytes{0xFF, 0xFF, 0xFD, 0x00, 0x65, 0x07, 0x00, 0x55, 0x00, 0x00, 0x00, 0x01, 0x80, 0x84}));
  EXPECT_EQ(bus(2).transact(p2_instruction(102, kPing), 14),
            (Bytes{0xFF, 0xFF, 0xFD, 0x00, 0x66, 0x07, 0x00, 0x55, 0x00, 0x00, 0x00, 0x01, 0x8A, 0xB4}));
  // BitFoot per-cycle READ (36, 16): four int32 counts, the robot's weight on the load cells.
  const auto foot = parse_p2_statuses(
      bus(3).transact({0xFF, 0xFF, 0xFD, 0x00, 0x65, 0x07, 0x00, 0x02, 0x24, 0x00, 0x10, 0x00, 0x62, 0x2C}, 27));
  ASSERT_TRUE(foot && foot->size() == 1);
  EXPECT_EQ((*foot)[0].params.size(), 16u);
  // CORE (model 0xABBA) answers the start-up PING of the Bit-Bots driver.
  EXPECT_EQ(bus(0).transact(p2_instruction(42, kPing), 14), p2_status(42, 0, {0xBA, 0xAB, 0x01}));
}

TEST_F(X430Robot, BroadcastPingFindsTheServosInIdOrderButNotTheBoards) {
  Bytes reply = bus(2).transact({0xFF, 0xFF, 0xFD, 0x00, 0xFE, 0x03, 0x00, 0x01, 0x31, 0x42}, 14 * 7);
  const auto statuses = parse_p2_statuses(reply);
  ASSERT_TRUE(statuses);
  ASSERT_EQ(statuses->size(), 6u);  // BitFoot 102 ignores broadcast (§8.1)
  for (std::size_t i = 0; i < 6; ++i) {
    EXPECT_EQ((*statuses)[i].id, kServos[2][i]);
    EXPECT_EQ((*statuses)[i].params, kXmPing);
  }
}

TEST_F(X430Robot, WriteReadAndMove) {
  // Reference §2.4: WRITE Goal Position 512 to ID 1 and its status.
  EXPECT_EQ(bus(0).transact({0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x09, 0x00, 0x03, 0x74, 0x00, 0x00, 0x02, 0x00, 0x00, 0xCA, 0x89}, 11),
            (Bytes{0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x04, 0x00, 0x55, 0x00, 0xA1, 0x0C}));
  EXPECT_EQ(read(0, 1, kGoalPosition, 4), p2_status(1, 0, le32(512)));
  EXPECT_EQ(read32(0, 1, kPresentPosition), 2048);  // powered on at 0 rad, torque off: still there
  ASSERT_EQ(write(0, 1, kTorqueEnable, {1}), p2_status(1, 0));
  ASSERT_EQ(write(0, 1, kGoalPosition, le32(2560)), p2_status(1, 0));
  // 512 pulses = 45 deg at Velocity Limit 200 x 0.229 rpm (4.8 rad/s): about 0.16 s.
  int32_t position = 0;
  for (int i = 0; i < 300 && position != 2560; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    position = read32(0, 1, kPresentPosition);
  }
  EXPECT_EQ(position, 2560);
  const auto voltage = parse_p2_statuses(read(0, 1, kPresentInputVoltage, 3));
  ASSERT_TRUE(voltage && voltage->size() == 1);
  EXPECT_EQ((*voltage)[0].params, (Bytes{120, 0, 25}));  // 12.0 V supply, 25 C
}

TEST_F(X430Robot, ErrorNumbersOverTheWire) {
  // CRC Error (3): the §2.4 WRITE with its CRC's low byte changed; not executed.
  EXPECT_EQ(bus(1).transact({0xFF, 0xFF, 0xFD, 0x00, 0x03, 0x09, 0x00, 0x03, 0x74, 0x00, 0x00, 0x02, 0x00, 0x00, 0x00, 0x00}, 11),
            p2_status(3, 0x03));
  EXPECT_EQ(bus(1).transact(p2_instruction(3, kAction), 11), p2_status(3, 0x02));               // Instruction Error
  EXPECT_EQ(write(1, 3, kGoalPosition, le32(5000)), p2_status(3, 0x06));                       // Data Limit (mode 3)
  EXPECT_EQ(write(1, 3, kGoalPosition, le16(512)), p2_status(3, 0x05));                        // Data Length
  EXPECT_EQ(write(1, 3, kOperatingMode, {2}), p2_status(3, 0x04));                             // Data Range
  EXPECT_EQ(write(1, 3, 0, le16(1)), p2_status(3, 0x07));                                      // Access: read-only
  EXPECT_EQ(bus(1).transact(p2_instruction(3, kRead, read_params(660, 4)), 11), p2_status(3, 0x07));  // no data
  ASSERT_EQ(write(1, 3, kTorqueEnable, {1}), p2_status(3, 0));
  EXPECT_EQ(write(1, 3, kReturnDelayTime, {0}), p2_status(3, 0x07));                           // EEPROM locked
  ASSERT_EQ(write(1, 3, kTorqueEnable, {0}), p2_status(3, 0));
  EXPECT_EQ(bus(1).transact(p2_instruction(3, kBackup, {0x01, 0x43, 0x54, 0x52, 0x4C}), 11), p2_status(3, 0));
}

TEST_F(X430Robot, RegWriteActionRebootAndFactoryReset) {
  // Reference §2.4 REG WRITE ID 1 Goal Velocity 200 (mode 3: stored, no motion).
  ASSERT_EQ(bus(0).transact({0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x09, 0x00, 0x04, 0x68, 0x00, 0xC8, 0x00, 0x00, 0x00, 0xAE, 0x8E}, 11),
            p2_status(1, 0));
  EXPECT_EQ(read(0, 1, 69, 1), p2_status(1, 0, {1}));  // Registered Instruction
  bus(0).send(p2_instruction(kBroadcast, kAction));
  EXPECT_TRUE(bus(0).drain(50).empty());
  EXPECT_EQ(read(0, 1, 104, 4), p2_status(1, 0, le32(200)));
  // REBOOT (§2.4 bytes): status, then RAM back to power-on values.
  ASSERT_EQ(write(0, 1, kLed, {1}), p2_status(1, 0));
  EXPECT_EQ(bus(0).transact({0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x03, 0x00, 0x08, 0x2F, 0x4E}, 11), p2_status(1, 0));
  EXPECT_EQ(read(0, 1, kLed, 1), p2_status(1, 0, {0}));
  // FACTORY RESET keeping ID and baud (option 0x02): EEPROM back to the factory values.
  ASSERT_EQ(write(0, 2, kVelocityLimit, le32(100)), p2_status(2, 0));
  EXPECT_EQ(bus(0).transact(p2_instruction(2, kFactoryReset, {0x02}), 11), p2_status(2, 0));
  EXPECT_EQ(read(0, 2, kVelocityLimit, 4), p2_status(2, 0, le32(200)));
  EXPECT_EQ(read(0, 2, kReturnDelayTime, 1), p2_status(2, 0, {250}));
  // Option 0x01 also restores the factory baud (57 600): the servo leaves the 4 Mbps bus.
  EXPECT_EQ(bus(0).transact(p2_instruction(21, kFactoryReset, {0x01}), 11), p2_status(21, 0));
  EXPECT_TRUE(bus(0).transact(p2_instruction(21, kPing), 14, 50).empty());
}

TEST_F(X430Robot, ClearMultiTurnAndBackupRestore) {
  ASSERT_EQ(write(1, 4, kOperatingMode, {4}), p2_status(4, 0));  // extended position
  // Reference §2.4 CLEAR layout for ID 4: P1 = 0x01, "DXL\"".
  EXPECT_EQ(bus(1).transact(p2_instruction(4, kClear, {0x01, 0x44, 0x58, 0x4C, 0x22}), 11), p2_status(4, 0));
  // BACKUP store, change an EEPROM item, restore (§2.4 corrected CRC for ID 1 shown in the unit tests).
  ASSERT_EQ(bus(1).transact(p2_instruction(4, kBackup, {0x01, 0x43, 0x54, 0x52, 0x4C}), 11), p2_status(4, 0));
  ASSERT_EQ(write(1, 4, kOperatingMode, {1}), p2_status(4, 0));
  EXPECT_EQ(bus(1).transact(p2_instruction(4, kBackup, {0x02, 0x43, 0x54, 0x52, 0x4C}), 11), p2_status(4, 0));
  EXPECT_EQ(read(1, 4, kOperatingMode, 1), p2_status(4, 0, {4}));
}

TEST_F(X430Robot, SyncWriteAndSyncRead) {
  // SYNC WRITE Goal Position of IDs 9, 11, 13 (layout of §2.4), then SYNC READ them back.
  Bytes params = cat(le16(kGoalPosition), le16(4));
  for (uint8_t id : {9, 11, 13}) {
    params = cat(cat(params, {id}), le32(1000 + id));
  }
  bus(2).send(p2_instruction(kBroadcast, kSyncWrite, params));
  EXPECT_TRUE(bus(2).drain(50).empty());
  const Bytes reply = bus(2).transact(p2_instruction(kBroadcast, kSyncRead, cat(read_params(kGoalPosition, 4), {13, 9, 11})), 3 * 15);
  const auto statuses = parse_p2_statuses(reply);
  ASSERT_TRUE(statuses);
  ASSERT_EQ(statuses->size(), 3u);
  const uint8_t order[] = {13, 9, 11};
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ((*statuses)[i].id, order[i]);
    EXPECT_EQ((*statuses)[i].params, le32(1000 + order[i]));
  }
}

TEST_F(X430Robot, FastSyncReadAndFastBulkRead) {
  const Bytes reply =
      bus(3).transact(p2_instruction(kBroadcast, kFastSyncRead, cat(read_params(kPresentPosition, 4), {10, 12, 14, 16, 18, 20})),
                      8 + 6 * 8);
  const auto blocks = parse_p2_fast_status(reply, {4, 4, 4, 4, 4, 4});
  ASSERT_TRUE(blocks);
  for (std::size_t i = 0; i < 6; ++i) {
    EXPECT_EQ((*blocks)[i].id, kServos[3][i]);
    EXPECT_EQ((*blocks)[i].error, 0);
    EXPECT_EQ((*blocks)[i].data, le32(2048));
  }
  // FAST BULK READ: ID 12 Present Position (4 B), ID 10 Present Temperature (1 B), ID 20 Moving (1 B).
  Bytes params = cat(cat(cat(Bytes{12}, le16(kPresentPosition)), le16(4)), cat(cat(Bytes{10}, le16(kPresentTemperature)), le16(1)));
  params = cat(params, cat(cat(Bytes{20}, le16(kMoving)), le16(1)));
  const auto bulk = parse_p2_fast_status(bus(3).transact(p2_instruction(kBroadcast, kFastBulkRead, params), 8 + 18), {4, 1, 1});
  ASSERT_TRUE(bulk);
  EXPECT_EQ((*bulk)[0].data, le32(2048));
  EXPECT_EQ((*bulk)[1].data, Bytes{25});
  EXPECT_EQ((*bulk)[2].data, Bytes{0});
}

TEST_F(X430Robot, BulkWriteAndBulkRead) {
  // BULK WRITE: ID 5 LED = 1, ID 6 Goal Position = 3000 (layout of §2.4).
  Bytes params = cat(cat(cat(Bytes{5}, le16(kLed)), le16(1)), Bytes{1});
  params = cat(params, cat(cat(cat(Bytes{6}, le16(kGoalPosition)), le16(4)), le32(3000)));
  bus(1).send(p2_instruction(kBroadcast, kBulkWrite, params));
  EXPECT_TRUE(bus(1).drain(50).empty());
  Bytes read_list = cat(cat(Bytes{6}, le16(kGoalPosition)), le16(4));
  read_list = cat(read_list, cat(cat(Bytes{5}, le16(kLed)), le16(1)));
  const auto statuses = parse_p2_statuses(bus(1).transact(p2_instruction(kBroadcast, kBulkRead, read_list), 15 + 12));
  ASSERT_TRUE(statuses);
  ASSERT_EQ(statuses->size(), 2u);
  EXPECT_EQ((*statuses)[0].id, 6);
  EXPECT_EQ((*statuses)[0].params, le32(3000));
  EXPECT_EQ((*statuses)[1].id, 5);
  EXPECT_EQ((*statuses)[1].params, Bytes{1});
}

TEST_F(X430Robot, FourBusesServeTheirCyclesAtTheSameTime) {
  // One thread per bus, as the Bit-Bots driver runs them: SYNC WRITE goals + FAST SYNC READ positions.
  std::atomic<int> failures{0};
  std::vector<std::thread> threads;
  for (int b = 0; b < 4; ++b) {
    threads.emplace_back([&, b] {
      const auto& ids = kServos[static_cast<std::size_t>(b)];
      std::vector<std::size_t> lengths(ids.size(), 4);
      for (int cycle = 0; cycle < 200; ++cycle) {
        Bytes goals = cat(le16(kGoalPosition), le16(4));
        for (uint8_t id : ids) goals = cat(cat(goals, {id}), le32(2048));
        bus(b).send(p2_instruction(kBroadcast, kSyncWrite, goals));
        Bytes request = read_params(kPresentPosition, 4);
        request.insert(request.end(), ids.begin(), ids.end());
        const Bytes reply = bus(b).transact(p2_instruction(kBroadcast, kFastSyncRead, request), 8 + ids.size() * 8);
        const auto blocks = parse_p2_fast_status(reply, lengths);
        if (!blocks) {
          ++failures;
          continue;
        }
        for (std::size_t i = 0; i < ids.size(); ++i) {
          if ((*blocks)[i].id != ids[i]) ++failures;
        }
      }
    });
  }
  for (auto& t : threads) t.join();
  EXPECT_EQ(failures.load(), 0);
}

TEST_F(X430Robot, ByteStuffingBothWays) {
  // Homing Offset (20) = -131073 = FF FF FD FF: the WRITE carries a stuffed FD, and so does the
  // READ reply (§2.3).
  const Bytes request = p2_instruction(7, kWrite, cat(le16(20), le32(-131073)));
  ASSERT_EQ(request.size(), 17u);  // header 7 + INST + 2 address + 4 data + 1 stuffing + CRC 2
  EXPECT_EQ(bus(1).transact(request, 11), p2_status(7, 0));
  const Bytes reply = bus(1).transact(p2_instruction(7, kRead, read_params(20, 4)), 16);
  ASSERT_EQ(reply.size(), 16u);  // 11 + 4 + 1 stuffing byte
  const auto statuses = parse_p2_statuses(reply);
  ASSERT_TRUE(statuses && statuses->size() == 1);
  EXPECT_EQ((*statuses)[0].params, le32(-131073));
  // A driver that reads LEN bytes after the 7-byte header (the SDK's rxPacket, transact_p2) gets
  // the whole stuffed status; one that expects 11 + 4 bytes would stop one short.
  EXPECT_EQ(transact_p2(bus(1), p2_instruction(7, kRead, read_params(20, 4)), 1), reply);
  EXPECT_EQ(read32(1, 7, kPresentPosition), 2048 - 131073);
}

TEST_F(X430Robot, HardwareErrorStatusReadsZeroAndNoAlertAtTwelveVolts) {
  EXPECT_EQ(read(0, 1, kHardwareErrorStatus, 1), p2_status(1, 0, {0}));
}

class X430RobotWire : public X430Robot {
 protected:
  X430RobotWire() : X430Robot("wire") {}
};

TEST_F(X430RobotWire, SyncReadChainArrivesWhole) {
  // Return Delay Time 250 (500 us) per device in the chain: 6 x (50 + 500 us + 15 B x 2.5 us).
  const auto start = std::chrono::steady_clock::now();
  const Bytes reply =
      bus(1).transact(p2_instruction(kBroadcast, kSyncRead, cat(read_params(kPresentPosition, 4), {3, 4, 5, 6, 7, 8})), 6 * 15);
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  const auto statuses = parse_p2_statuses(reply);
  ASSERT_TRUE(statuses);
  EXPECT_EQ(statuses->size(), 6u);
  EXPECT_GE(ms, 6 * 0.55);  // never earlier than the wire model
}

TEST_F(X430Robot, ProtocolTypeSwitchesAServoToProtocol1OverTheWire) {
  // WRITE Protocol Type (13) := 1 to ID 3 on the arms bus: answered in Protocol 2.0 (§2.2's empty status).
  EXPECT_EQ(write(1, 3, 13, {1}), p2_status(3, 0));
  // Now ID 3 answers Protocol 1.0 (§1.1 framing and checksum) and no longer Protocol 2.0.
  EXPECT_EQ(bus(1).transact(p1_instruction(3, 0x01), 6), (Bytes{0xFF, 0xFF, 0x03, 0x02, 0x00, 0xFA}));
  EXPECT_TRUE(bus(1).transact(p2_instruction(3, kPing), 14, 50).empty());
  // READ 0, 2 over P1: model number 1020 (0x03FC); the other servos on the bus still speak P2.
  EXPECT_EQ(bus(1).transact(p1_instruction(3, kRead, {0, 2}), 8), (Bytes{0xFF, 0xFF, 0x03, 0x04, 0x00, 0xFC, 0x03, 0xF9}));
  EXPECT_EQ(bus(1).transact(p2_instruction(4, kPing), 14), p2_status(4, 0, kXmPing));
  // WRITE 13 := 2 over P1, answered in P1; then P2 again.
  EXPECT_EQ(bus(1).transact(p1_instruction(3, kWrite, {13, 2}), 6), (Bytes{0xFF, 0xFF, 0x03, 0x02, 0x00, 0xFA}));
  EXPECT_EQ(bus(1).transact(p2_instruction(3, kPing), 14), p2_status(3, 0, kXmPing));
}

TEST(Protocol2RobotConfig, ProtocolTwoBusesLoadAndAreChecked) {
  const std::string bus = "name: \"r\" bus { baud_bps: 4000000 protocol: PROTOCOL_2 ";
  const gateway::RobotConfig ok = gateway::parse_robot(bus + "device { id: 1 model: \"XL430-W250\" } }", "ok.textproto");
  ASSERT_EQ(ok.buses.size(), 1u);
  EXPECT_EQ(ok.buses[0].protocol, dynamixel::Protocol::kV2);
  // IDs stop at 252 on Protocol 2.0 (§2.1); a P1 model on a P2 bus is named as such.
  EXPECT_THROW(gateway::parse_robot(bus + "device { id: 253 model: \"XM430-W350\" } }", "id.textproto"),
               std::invalid_argument);
  try {
    gateway::parse_robot(bus + "device { id: 1 model: \"MX-28\" } }", "p1.textproto");
    ADD_FAILURE() << "a Protocol 1.0 model on a PROTOCOL_2 bus must be refused";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("Protocol 1.0 model"), std::string::npos) << e.what();
  }
  // MX servos with the Protocol 2.0 firmware by their e-Manual names; on a P1 bus they are named as P2 models.
  EXPECT_NO_THROW(gateway::parse_robot(bus + "device { id: 1 model: \"MX-28(2.0)\" } device { id: 2 model: "
                                             "\"MX-64(2.0)\" } device { id: 3 model: \"MX-106(2.0)\" } }",
                                       "mx2.textproto"));
  EXPECT_THROW(gateway::parse_robot("name: \"r\" bus { baud_bps: 1000000 protocol: PROTOCOL_1 device { id: 1 model: "
                                    "\"MX-64(2.0)\" } }", "mx2p1.textproto"),
               std::invalid_argument);
  // 4.5 Mbps exists on the X series (index 7), 5 Mbps only on the CORE board.
  EXPECT_NO_THROW(gateway::parse_robot("name: \"r\" bus { baud_bps: 4500000 protocol: PROTOCOL_2 device { id: 1 model: "
                                       "\"XM430-W350\" } }", "b.textproto"));
  EXPECT_THROW(gateway::parse_robot("name: \"r\" bus { baud_bps: 5000000 protocol: PROTOCOL_2 device { id: 1 model: "
                                    "\"XM430-W350\" } }", "c.textproto"),
               std::invalid_argument);
}

}  // namespace
}  // namespace doppel::testing
