// Faults on demand end to end (docs/faults.md): doppel with its control API, faults added with
// doppel-ctl as a user would, and each one seen through the robot's pty by a driver: the reference
// client (written from the Dynamixel reference) and one that waits as DynamixelSDK does (its
// packet timeout: tx_time_per_byte x length + 2 x latency timer + 2 ms). Judged on what the
// firmware shows (error bits, registers), never on wall-clock time; waits count simulation time.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "controlled_doppel.h"
#include "reference_client.h"
#include "reference_client_p2.h"

namespace doppel::testing {
namespace {

using nlohmann::json;

constexpr uint32_t kBaud = 1000000;
constexpr uint8_t kPing = 0x01, kRead = 0x02, kWrite = 0x03, kReboot = 0x08, kSyncWrite = 0x83;
// Protocol 1.0 control table (reference §1.5) and error bits (§1.4).
constexpr uint8_t kTorqueEnable = 24, kGoalPosition = 30, kPresentPosition = 36, kPresentVoltage = 42,
                  kPresentTemperature = 43;
constexpr uint8_t kInputVoltageError = 0x01, kOverheatingError = 0x04;
// FUMANOID-IMU (ID 100) and FUMANOID-FOOT (ID 101), docs/devices.md.
constexpr uint8_t kImuGyroX = 32, kImuSampleCounter = 48, kFootFrontLeft = 26;

// What DynamixelSDK's Protocol 1.0 txRxPacket reports: COMM_RX_TIMEOUT when fewer bytes than the
// status came, COMM_RX_CORRUPT for a header followed by a wrong checksum. The SDK waits its packet
// timeout (PortHandlerLinux::setPacketTimeout: 34 ms for a 6-byte status at 1 Mbps); this waits
// kAnswerWaitMs instead, so that on a loaded machine an answer that comes late is not taken for a
// lost one (seen: 8 of 100 PINGs "lost" beside two busy loops). A status doppel drops never comes,
// however long the wait: the result is the same as the SDK's, only not the time it takes.
constexpr int kAnswerWaitMs = 2000;
constexpr int kSdkPacketTimeoutMs = 35;  // 10 us * 6 + 16 ms * 2 + 2 ms = 34.06 ms, rounded up
enum class SdkResult { kSuccess, kTimeout, kCorrupt };
struct SdkAnswer {
  SdkResult result = SdkResult::kTimeout;
  P1Status status;
};
SdkAnswer sdk_transact(SerialClient& client, const Bytes& request, std::size_t status_length,
                       int wait_ms = kAnswerWaitMs) {
  client.send(request);
  const Bytes bytes = client.receive(status_length, wait_ms);
  SdkAnswer answer;
  if (bytes.size() < status_length) return answer;  // COMM_RX_TIMEOUT
  const std::optional<std::vector<P1Status>> parsed = parse_p1_statuses(bytes);
  if (!parsed || parsed->size() != 1) {
    answer.result = SdkResult::kCorrupt;  // COMM_RX_CORRUPT: a header, then a wrong checksum
    return answer;
  }
  answer.result = SdkResult::kSuccess;
  answer.status = parsed->front();
  return answer;
}

// One register read with the reference client: the status (id 0 and no params when none came).
P1Status read(SerialClient& client, uint8_t id, uint8_t address, uint8_t length) {
  const Bytes reply = client.transact(p1_instruction(id, kRead, {address, length}), 6u + length, 500);
  const std::optional<std::vector<P1Status>> parsed = parse_p1_statuses(reply);
  EXPECT_TRUE(parsed && parsed->size() == 1) << "READ " << int(address) << " of ID " << int(id) << ": " << reply.size()
                                             << " bytes";
  return parsed && parsed->size() == 1 ? parsed->front() : P1Status{};
}
int read_u16(SerialClient& client, uint8_t id, uint8_t address) {
  const P1Status s = read(client, id, address, 2);
  return s.params.size() == 2 ? s.params[0] | (s.params[1] << 8) : -1;
}
int read_u8(SerialClient& client, uint8_t id, uint8_t address) {
  const P1Status s = read(client, id, address, 1);
  return s.params.size() == 1 ? s.params[0] : -1;
}
void write(SerialClient& client, uint8_t id, const Bytes& params) {
  const Bytes reply = client.transact(p1_instruction(id, kWrite, params), 6, 500);
  EXPECT_EQ(reply.size(), 6u) << "WRITE to ID " << int(id);
}
// A status that is to come gets 2 s: on a loaded machine doppel's answer can be late by far more
// than the wire takes, and a late answer is not what these tests look at.
bool pings(SerialClient& client, uint8_t id) {
  const Bytes reply = client.transact(p1_instruction(id, kPing), 6, 2000);
  const std::optional<std::vector<P1Status>> parsed = parse_p1_statuses(reply);
  return parsed && parsed->size() == 1 && parsed->front().id == id;
}

double sim_time(const ControlledDoppel& doppel) { return doppel.ok("state")["sim_time_s"].get<double>(); }
// Returns once `seconds` of simulation time have passed (fails after 60 s of wall time: a stall).
void wait_sim(const ControlledDoppel& doppel, double seconds) {
  const double start = sim_time(doppel);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (sim_time(doppel) - start < seconds) {
    ASSERT_LT(std::chrono::steady_clock::now(), deadline) << "the simulation did not advance " << seconds << " s";
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}
// Reads `address` of `id` until its status' error byte has `bit` set (or clear, `set` false).
P1Status until_error(const ControlledDoppel& doppel, SerialClient& client, uint8_t id, uint8_t address, uint8_t bit,
                     bool set = true) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  for (;;) {
    const P1Status s = read(client, id, address, 1);
    if (((s.error & bit) != 0) == set) return s;
    if (std::chrono::steady_clock::now() > deadline) {
      ADD_FAILURE() << "ID " << int(id) << ": error bit " << int(bit) << (set ? " never set" : " never cleared")
                    << " by " << sim_time(doppel) << " s of simulation";
      return s;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}
uint32_t added(const json& answer) { return answer.value("added", 0u); }

TEST(Faults, BadRequestsNameTheFieldAndChangeNothing) {
  ControlledDoppel doppel({});
  const struct {
    const char* arguments;
    const char* names;
  } refused[] = {
      {"fault add overheat 0 --id 14 --value 5", "'bus'"},
      {"fault add overheat 0 --bus 0 --value 5", "'id'"},
      {"fault add overheat 0 --bus 0 --id 14", "'rise_c_per_s'"},
      {"fault add overheat 0 --bus 0 --id 14 --value 500", "'rise_c_per_s'"},
      {"fault add overheat 0 --bus 3 --id 14 --value 5", "'bus'"},
      {"fault add overheat 0 --bus 0 --id 77 --value 5", "'id'"},
      {"fault add overheat 0 --bus 0 --id 100 --value 5", "not a servo"},
      {"fault add imu_bias 0 --bus 0 --id 14 --value 0.1", "not an IMU"},
      {"fault add overheat 4 --bus 0 --id 14 --value 5", "no robot 4"},
      {"fault add melt 0", "'kind'"},
      {"fault add drop 0 --bus 0 --rate 0", "'rate'"},
      {"fault add drop 0 --bus 0 --rate 0.5 --value 3", "'value'"},
      {"fault add silent 0 --bus 0 --for -1", "'duration_s'"},
      {"fault clear 3", "no fault 3"},
  };
  for (const auto& r : refused) {
    const auto [code, output] = doppel.ctl(r.arguments);
    EXPECT_EQ(code, 1) << r.arguments << ": " << output;
    EXPECT_NE(output.find(r.names), std::string::npos) << r.arguments << ": " << output;
  }
  EXPECT_TRUE(doppel.ok("fault list")["faults"].empty()) << "a refused fault was added";
  SerialClient client(doppel.doppel.link(), kBaud);
  EXPECT_TRUE(pings(client, 14));
  EXPECT_EQ(read(client, 14, kPresentTemperature, 1).error, 0);
}

// Protocol 1.0 (RX-64, RX-28 of the FUmanoid 2011): the firmware's own reaction follows each fault.
TEST(Faults, ServoFaultsShowAsTheFirmwareShowsThem) {
  ControlledDoppel doppel({});
  SerialClient client(doppel.doppel.link(), kBaud);

  // Overheating: the temperature climbs past the Temperature Limit (80 degC), the overheating bit
  // is in every status, and Alarm Shutdown (default 36 = overheating | overload) switches the
  // torque off; cleared, the bit goes, the torque stays off until the host enables it again.
  write(client, 14, {kTorqueEnable, 1});
  const int limit = read_u8(client, 14, 11);
  EXPECT_EQ(limit, 80) << "RX-64 Temperature Limit (e-Manual)";
  const json overheat = doppel.ok("fault add overheat 0 --bus 0 --id 14 --value 100");
  const P1Status hot = until_error(doppel, client, 14, kPresentTemperature, kOverheatingError);
  ASSERT_EQ(hot.params.size(), 1u);
  EXPECT_GT(hot.params[0], limit);
  EXPECT_EQ(read_u8(client, 14, kTorqueEnable), 0) << "Alarm Shutdown switched the torque off";
  EXPECT_EQ(read(client, 13, kPresentTemperature, 1).error, 0) << "only ID 14 overheats";
  doppel.ok("fault clear " + std::to_string(added(overheat)));
  const P1Status cool = until_error(doppel, client, 14, kPresentTemperature, kOverheatingError, false);
  ASSERT_EQ(cool.params.size(), 1u);
  EXPECT_LE(cool.params[0], limit);
  EXPECT_EQ(read_u8(client, 14, kTorqueEnable), 0) << "the host must enable the torque again";
  write(client, 14, {kTorqueEnable, 1});
  EXPECT_EQ(read_u8(client, 14, kTorqueEnable), 1);

  // Overload, with torque on: Alarm Shutdown switches the torque off (the condition, "torque on
  // and overloaded", then ends: Doppel's P1 firmware does not latch the bit, docs/devices.md).
  write(client, 15, {kTorqueEnable, 1});
  doppel.ok("fault add overload 0 --bus 0 --id 15");
  const auto overload_deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (read_u8(client, 15, kTorqueEnable) != 0) {
    ASSERT_LT(std::chrono::steady_clock::now(), overload_deadline) << "the overload never switched the torque off";
  }

  // Input voltage: 5.0 V is below the Min Voltage Limit (60 = 6.0 V): the bit, no shutdown (not in 36).
  write(client, 16, {kTorqueEnable, 1});
  doppel.ok("fault add voltage 0 --bus 0 --id 16 --value 5");
  const P1Status low = until_error(doppel, client, 16, kPresentVoltage, kInputVoltageError);
  ASSERT_EQ(low.params.size(), 1u);
  EXPECT_EQ(low.params[0], 50);
  EXPECT_EQ(read_u8(client, 16, kTorqueEnable), 1) << "input voltage is not in the default Alarm Shutdown";

  // Dead: no answer to anything, the neighbours answer; cleared, it answers again.
  const json dead = doppel.ok("fault add dead 0 --bus 0 --id 17");
  EXPECT_FALSE(pings(client, 17));
  EXPECT_EQ(sdk_transact(client, p1_instruction(17, kPing), 6).result, SdkResult::kTimeout);
  EXPECT_TRUE(pings(client, 18));
  doppel.ok("fault clear " + std::to_string(added(dead)));
  EXPECT_TRUE(pings(client, 17));

  // Stuck: the measured position of ID 1 stays while its goal is far away; ID 3 (same model),
  // given the same move, gets there.
  for (uint8_t id : {1, 3}) write(client, id, {kTorqueEnable, 1});
  wait_sim(doppel, 0.3);
  doppel.ok("fault add stuck 0 --bus 0 --id 1");
  const int stuck_at = read_u16(client, 1, kPresentPosition);
  const int free_from = read_u16(client, 3, kPresentPosition);
  for (auto [id, from] : {std::pair<uint8_t, int>{1, stuck_at}, {3, free_from}}) {
    const int goal = from + 100;
    write(client, id, {kGoalPosition, static_cast<uint8_t>(goal & 0xFF), static_cast<uint8_t>(goal >> 8)});
  }
  wait_sim(doppel, 1.0);
  EXPECT_EQ(read_u16(client, 1, kPresentPosition), stuck_at);
  EXPECT_GT(read_u16(client, 3, kPresentPosition) - free_from, 50) << "the same move without a fault";

  // Position noise (sigma 0.05 rad = 9.8 units of 0.29 deg): readings of a still servo scatter.
  doppel.ok("fault add position_noise 0 --bus 0 --id 2 --value 0.05");
  std::set<int> seen;
  for (int i = 0; i < 20; ++i) {
    seen.insert(read_u16(client, 2, kPresentPosition));
    wait_sim(doppel, 0.01);
  }
  EXPECT_GE(seen.size(), 5u);

  // The IMU and foot checks compare a reading before a bias with one after it, so the body must not
  // move in between: mostly limp, it falls once the handler lets go (a run on a quiet machine read
  // 2728 mrad/s for a 2 rad/s bias). A reset gives it back to the handler, who holds it still
  // (root pinned, joints locked) until a servo's torque goes on again; faults outlive a reset.
  doppel.ok("reset");
  wait_sim(doppel, 0.05);
  ASSERT_TRUE(doppel.ok("state")["robots"][0]["held"].get<bool>());

  // IMU bias: +2 rad/s on every gyro axis (1 mrad/s units); IMU dropout: the Sample Counter stops.
  const int gyro_before = static_cast<int16_t>(read_u16(client, 100, kImuGyroX));
  doppel.ok("fault add imu_bias 0 --bus 0 --id 100 --value 2");
  wait_sim(doppel, 0.1);
  EXPECT_NEAR(static_cast<int16_t>(read_u16(client, 100, kImuGyroX)) - gyro_before, 2000, 300);
  doppel.ok("fault add imu_dropout 0");
  wait_sim(doppel, 0.05);
  const int counter = read_u16(client, 100, kImuSampleCounter);
  wait_sim(doppel, 0.2);
  EXPECT_EQ(read_u16(client, 100, kImuSampleCounter), counter) << "0.2 s of simulation: 10 samples missed";

  // Foot bias: +50 N on each load cell (0.01 N units).
  const int force_before = read_u16(client, 101, kFootFrontLeft);
  doppel.ok("fault add foot_bias 0 --bus 0 --id 101 --value 50");
  wait_sim(doppel, 0.1);
  EXPECT_NEAR(read_u16(client, 101, kFootFrontLeft) - force_before, 5000, 1000);

  // Brown-out to 5 V: every servo measures it and reports its input-voltage error.
  doppel.ok("fault add brownout 0 --value 5");
  for (uint8_t id : {1, 9, 21}) {
    const P1Status s = until_error(doppel, client, id, kPresentVoltage, kInputVoltageError);
    ASSERT_EQ(s.params.size(), 1u);
    EXPECT_EQ(s.params[0], 50) << "ID " << int(id);
  }
  const json list = doppel.ok("fault list");
  EXPECT_EQ(list["faults"].size(), 10u);
  for (const json& f : list["faults"]) {
    const bool cleared = f["number"] == added(overheat) || f["number"] == added(dead);
    EXPECT_EQ(f["active"], !cleared) << f.dump();
    EXPECT_EQ(f["ended"], cleared) << f.dump();
  }
}

// Wire faults on bus 0, read by the SDK-style driver: a corrupted status is COMM_RX_CORRUPT, a
// lost one COMM_RX_TIMEOUT, the same seed corrupts the same statuses again.
TEST(Faults, BusFaultsCorruptDropSilenceAndCollide) {
  ControlledDoppel doppel({});
  SerialClient client(doppel.doppel.link(), kBaud);

  const json corrupt = doppel.ok("fault add corrupt 0 --bus 0 --rate 1");
  const SdkAnswer broken = sdk_transact(client, p1_instruction(1, kPing), 6);
  EXPECT_EQ(broken.result, SdkResult::kCorrupt);
  doppel.ok("fault clear " + std::to_string(added(corrupt)));
  EXPECT_EQ(sdk_transact(client, p1_instruction(1, kPing), 6).result, SdkResult::kSuccess);

  auto pattern = [&]() {
    std::vector<int> out;
    for (int i = 0; i < 100; ++i) out.push_back(static_cast<int>(sdk_transact(client, p1_instruction(1, kPing), 6).result));
    return out;
  };
  const json first = doppel.ok("fault add corrupt 0 --bus 0 --rate 0.3 --seed 5");
  const std::vector<int> a = pattern();
  doppel.ok("fault clear " + std::to_string(added(first)));
  const json second = doppel.ok("fault add corrupt 0 --bus 0 --rate 0.3 --seed 5");
  const std::vector<int> b = pattern();
  doppel.ok("fault clear " + std::to_string(added(second)));
  EXPECT_EQ(a, b) << "the same seed and traffic: the same statuses corrupted";
  const auto bad = std::count(a.begin(), a.end(), static_cast<int>(SdkResult::kCorrupt));
  EXPECT_EQ(std::count(a.begin(), a.end(), static_cast<int>(SdkResult::kTimeout)), 0);
  EXPECT_GT(bad, 10);  // binomial(100, 0.3): 30 +- 4.6; the bounds are 4 sigma away
  EXPECT_LT(bad, 50);

  const json drop = doppel.ok("fault add drop 0 --bus 0 --rate 1");
  EXPECT_EQ(sdk_transact(client, p1_instruction(1, kPing), 6).result, SdkResult::kTimeout);
  doppel.ok("fault clear " + std::to_string(added(drop)));

  // Silent (cable unplugged): nothing answers, and a write never reaches the servo.
  const int goal = read_u16(client, 5, kGoalPosition);
  const json silent = doppel.ok("fault add silent 0 --bus 0");
  for (uint8_t id : {1, 5, 100}) EXPECT_FALSE(pings(client, id)) << "ID " << int(id);
  const int other = goal + 40;
  client.send(p1_instruction(5, kWrite, {kGoalPosition, static_cast<uint8_t>(other & 0xFF), static_cast<uint8_t>(other >> 8)}));
  EXPECT_TRUE(client.drain(100).empty());
  doppel.ok("fault clear " + std::to_string(added(silent)));
  EXPECT_EQ(read_u16(client, 5, kGoalPosition), goal) << "the write was sent while the cable was out";

  // Collision: ID 30 (no such device) answers every instruction. After a SYNC WRITE, which no
  // servo answers, its status arrives alone; with a PING's answer, the wire carries both at once.
  doppel.ok("fault add collision 0 --bus 0 --id 30 --rate 1");
  client.send(p1_instruction(0xFE, kSyncWrite, {kGoalPosition, 2, 5, static_cast<uint8_t>(goal & 0xFF),
                                                static_cast<uint8_t>(goal >> 8)}));
  const Bytes stray = client.receive(6, 500);
  const std::optional<std::vector<P1Status>> strays = parse_p1_statuses(stray);
  ASSERT_TRUE(strays && strays->size() == 1) << stray.size() << " bytes after a SYNC WRITE";
  EXPECT_EQ(strays->front().id, 30);
  EXPECT_EQ(sdk_transact(client, p1_instruction(1, kPing), 6).result, SdkResult::kCorrupt)
      << "FF FF 01 02 00 FC and FF FF 1E 02 00 DF at once: FF FF 00 02 00 DC, a checksum error";
}

// A late answer (wire timing, a 16 ms latency timer as DynamixelSDK assumes): 100 ms (the fault's
// most) later than the SDK's packet timeout of 34.06 ms for a 6-byte status, so the SDK-style
// driver times out, and the status arrives afterwards, where it would be taken for the answer to
// the next request. Only a test thread kept off the CPU for 100 ms at its deadline would see it in
// time.
TEST(Faults, ALateAnswerMissesTheSdkTimeoutAndArrivesAfterwards) {
  ControlledDoppel doppel({"--latency-timer", "16"}, false);
  SerialClient client(doppel.doppel.link(), kBaud);
  doppel.ok("fault add late 0 --bus 0 --id 18 --value 100000");
  EXPECT_EQ(sdk_transact(client, p1_instruction(18, kPing), 6, kSdkPacketTimeoutMs).result, SdkResult::kTimeout);
  const Bytes late = client.receive(6, 5000);
  const std::optional<std::vector<P1Status>> parsed = parse_p1_statuses(late);
  ASSERT_TRUE(parsed && parsed->size() == 1) << late.size() << " bytes after the timeout";
  EXPECT_EQ(parsed->front().id, 18);
  EXPECT_TRUE(pings(client, 17)) << "only ID 18 is late";
}

// Protocol 2.0 (XM430-W350 of fumanoid-x430): overheating latches Hardware Error Status bit 2,
// switches the torque off, every status carries Alert (0x80), and only a REBOOT clears it.
TEST(Faults, Protocol2OverheatingLatchesTheHardwareErrorAndTheAlert) {
  ControlledDoppel doppel({"--robot", "fumanoid-x430"});
  SerialClient client(doppel.doppel.link(), 4'000'000);  // its head bus
  constexpr uint16_t kTorqueEnable2 = 64, kHardwareErrorStatus = 70, kPresentTemperature2 = 146;
  auto read2 = [&](uint8_t id, uint16_t address, uint16_t length) {
    Bytes params = le16(address);
    const Bytes l = le16(length);
    params.insert(params.end(), l.begin(), l.end());
    const Bytes reply = client.transact(p2_instruction(id, kRead, params), 11u + length, 500);
    const std::optional<std::vector<P2Status>> parsed = parse_p2_statuses(reply);
    EXPECT_TRUE(parsed && parsed->size() == 1) << reply.size() << " bytes";
    return parsed && parsed->size() == 1 ? parsed->front() : P2Status{};
  };
  Bytes enable = le16(kTorqueEnable2);
  enable.push_back(1);
  EXPECT_EQ(client.transact(p2_instruction(1, kWrite, enable), 11, 500).size(), 11u);
  ASSERT_EQ(read2(1, kTorqueEnable2, 1).params, Bytes{1});
  doppel.ok("fault add overheat 0 --bus 0 --id 1 --value 100");
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  P2Status status;
  while (((status = read2(1, kPresentTemperature2, 1)).error & 0x80) == 0) {
    ASSERT_LT(std::chrono::steady_clock::now(), deadline) << "no Alert by " << sim_time(doppel) << " s";
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_EQ(status.params.size(), 1u);
  EXPECT_GT(status.params[0], 80) << "above the XM430 Temperature Limit (80 degC)";
  EXPECT_EQ(read2(1, kHardwareErrorStatus, 1).params, Bytes{0x04}) << "bit 2: overheating";
  EXPECT_EQ(read2(1, kTorqueEnable2, 1).params, Bytes{0});
  doppel.ok("fault clear all");
  wait_sim(doppel, 0.1);
  EXPECT_EQ(read2(1, kHardwareErrorStatus, 1).params, Bytes{0x04}) << "latched until REBOOT";
  EXPECT_EQ(client.transact(p2_instruction(1, kReboot), 11, 500).size(), 11u);
  wait_sim(doppel, 0.1);
  const P2Status after = read2(1, kHardwareErrorStatus, 1);
  EXPECT_EQ(after.params, Bytes{0});
  EXPECT_EQ(after.error & 0x80, 0);
}

}  // namespace
}  // namespace doppel::testing
