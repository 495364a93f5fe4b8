// Persistent EEPROM and mixed-protocol buses, end to end: the real doppel executable, real ptys,
// and the reference clients of tests/support written from shared/reference/dynamixel.md.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

#include "doppel_process.h"
#include "reference_client.h"
#include "reference_client_p2.h"

namespace doppel::testing {
namespace {

constexpr uint8_t kPing = 0x01, kRead = 0x02, kWrite = 0x03;

Bytes cat(Bytes a, const Bytes& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

// A fresh directory with `robot` written to robot.textproto.
class StateDir {
 public:
  explicit StateDir(const std::string& robot) {
    char tmpl[] = "/tmp/doppel-state-test-XXXXXX";
    dir_ = ::mkdtemp(tmpl);
    std::ofstream(robot_file()) << robot;
  }
  ~StateDir() {
    std::error_code ignored;
    std::filesystem::remove_all(dir_, ignored);
  }
  std::string robot_file() const { return dir_ + "/robot.textproto"; }
  std::string state() const { return dir_ + "/state"; }
  const std::string& dir() const { return dir_; }

 private:
  std::string dir_;
};

std::string read_file(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

const char* kOneXm430 = R"(name: "state-test"
bus {
  baud_bps: 1000000
  protocol: PROTOCOL_2
  device { id: 1 model: "XM430-W350" name: "SERVO" }
  device { id: 2 model: "RX-64" name: "P1_SERVO" protocol: PROTOCOL_1 }
}
)";

std::vector<std::string> args(const StateDir& dir) {
  return {"--robot", dir.robot_file(), "--physics", "none", "--timing", "fast", "--state-dir", dir.state()};
}

// Reference §2.2 / §3.7: WRITE to an XM430 and its empty status.
void p2_write(SerialClient& client, uint8_t id, uint16_t address, uint8_t value) {
  const auto statuses = parse_p2_statuses(client.transact(p2_instruction(id, kWrite, cat(le16(address), {value})), 11));
  ASSERT_TRUE(statuses && statuses->size() == 1) << "no status for WRITE " << address << " to ID " << int(id);
  EXPECT_EQ((*statuses)[0].error, 0);
}

// A PING answered; `timeout_ms` guards against a hang, and is short only where silence is expected
// (an answer late on a loaded machine then passes unnoticed; it never fails a test that should pass).
bool p2_pings(SerialClient& client, uint8_t id, int timeout_ms = 5000) {
  const auto statuses = parse_p2_statuses(client.transact(p2_instruction(id, kPing), 14, timeout_ms));
  return statuses && statuses->size() == 1 && (*statuses)[0].id == id;
}

bool p1_pings(SerialClient& client, uint8_t id, int timeout_ms = 5000) {
  const auto statuses = parse_p1_statuses(client.transact(p1_instruction(id, kPing), 6, timeout_ms));
  return statuses && statuses->size() == 1 && (*statuses)[0].id == id && (*statuses)[0].error == 0;
}

TEST(PersistentEeprom, IdAndProtocolTypeSurviveARestartAndAKill) {
  StateDir dir(kOneXm430);
  {
    DoppelProcess doppel(args(dir));
    doppel.wait_for_output("running until");
    SerialClient client(doppel.link(), 1000000);
    ASSERT_TRUE(p2_pings(client, 1));
    // ID (7) = 5 (XM430-W350, reference §3.7), then doppel is killed without warning once the
    // state thread saved it (the file appears with the first change; 60 s only against a hang).
    p2_write(client, 1, 7, 5);
    ASSERT_TRUE(p2_pings(client, 5));
    const std::string file = dir.state() + "/state-test.json";
    for (int i = 0; i < 6000 && !std::filesystem::exists(file); ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    ASSERT_TRUE(std::filesystem::exists(file));
    doppel.stop(SIGKILL);
  }
  {
    DoppelProcess doppel(args(dir));
    doppel.wait_for_output("running until");
    SerialClient client(doppel.link(), 1000000);
    EXPECT_FALSE(p2_pings(client, 1, 200));
    ASSERT_TRUE(p2_pings(client, 5));
    // Protocol Type (13) = 1: the servo speaks Protocol 1.0 from the next packet on.
    p2_write(client, 5, 13, 1);
    EXPECT_TRUE(p1_pings(client, 5));
    doppel.stop(SIGTERM);
  }
  const std::string saved = read_file(dir.state() + "/state-test.json");
  EXPECT_NE(saved.find("\"layout\""), std::string::npos) << saved;
  {
    DoppelProcess doppel(args(dir));
    doppel.wait_for_output("running until");
    SerialClient client(doppel.link(), 1000000);
    EXPECT_TRUE(p1_pings(client, 5));
    EXPECT_FALSE(p2_pings(client, 5, 200));
    EXPECT_TRUE(p1_pings(client, 2));  // the Protocol 1.0 RX-64 beside it
    doppel.stop(SIGTERM);
  }
  {
    // --fresh: the robot file's values again, and the saved state is overwritten.
    std::vector<std::string> fresh = args(dir);
    fresh.push_back("--fresh");
    DoppelProcess doppel(fresh);
    doppel.wait_for_output("running until");
    SerialClient client(doppel.link(), 1000000);
    EXPECT_TRUE(p2_pings(client, 1));
    doppel.stop(SIGTERM);
  }
  DoppelProcess doppel(args(dir));
  doppel.wait_for_output("running until");
  SerialClient client(doppel.link(), 1000000);
  EXPECT_TRUE(p2_pings(client, 1));
}

// Runs doppel until it serves (its "running until" line) or exits by itself, then stops it with
// SIGTERM; its exit code and output.
std::pair<int, std::string> run_doppel(const StateDir& dir, const std::string& state_dir) {
  const std::string out = dir.dir() + "/run_doppel.txt";
  return run_command(doppel_executable() + " --robot " + dir.robot_file() + " --physics none --no-camera --no-viewer " +
                     "--no-handshake-tcp --link-dir " + dir.dir() + "/links --state-dir " + state_dir + " >" + out +
                     " 2>&1 & pid=$!; for i in $(seq 600); do grep -q 'running until' " + out +
                     " && break; kill -0 $pid 2>/dev/null || break; sleep 0.1; done; kill $pid 2>/dev/null; wait $pid; "
                     "code=$?; cat " + out + "; exit $code");
}

TEST(PersistentEeprom, CorruptMismatchedAndUnwritableStateIsRefusedWithTheReason) {
  StateDir dir(kOneXm430);
  std::filesystem::create_directories(dir.state());
  const std::string file = dir.state() + "/state-test.json";
  std::ofstream(file) << "{\"format\": \"doppel-eeprom-state 1\", \"robot\": \"state-test\", \"lay";
  auto [code, said] = run_doppel(dir, dir.state());
  EXPECT_EQ(code, 1) << said;
  EXPECT_NE(said.find("state file " + file + ": corrupt"), std::string::npos) << said;
  EXPECT_NE(said.find("--fresh"), std::string::npos) << said;
  EXPECT_EQ(read_file(file).substr(0, 10), "{\"format\":");  // not discarded

  // A state file of another layout: the same robot name with the devices of another file.
  StateDir other(R"(name: "state-test"
bus { baud_bps: 1000000 protocol: PROTOCOL_2 device { id: 1 model: "XL430-W250" } }
)");
  std::filesystem::remove(file);
  auto [made_code, made] = run_doppel(other, dir.state());
  ASSERT_EQ(made_code, 0) << made;
  ASSERT_TRUE(std::filesystem::exists(file));
  std::tie(code, said) = run_doppel(dir, dir.state());
  EXPECT_EQ(code, 1) << said;
  EXPECT_NE(said.find("state file " + file + ": written for another bus/device layout"), std::string::npos) << said;

  // A state directory that cannot be made (below a regular file; refused even for root).
  const std::string blocked = dir.robot_file() + "/state";
  std::tie(code, said) = run_doppel(dir, blocked);
  EXPECT_EQ(code, 1) << said;
  EXPECT_NE(said.find("state directory " + blocked), std::string::npos) << said;
}

// The start listing says where the EEPROM comes from: a state file (and what it changed from the
// robot file, by e-Manual item name), or the robot file (and where a driver's writes will be kept);
// a device whose baud rate is not its bus' is flagged. --fresh is the way back.
TEST(PersistentEeprom, TheStartListingSaysWhatTheStateFileChanged) {
  StateDir dir(kOneXm430);
  const std::string file = dir.state() + "/state-test.json";
  {
    DoppelProcess doppel(args(dir));
    const std::string listing = doppel.wait_for_output("running until");
    EXPECT_NE(listing.find("EEPROM state from the robot file; what drivers write to EEPROM is kept in " + file),
              std::string::npos) << listing;
    EXPECT_EQ(listing.find("EEPROM from the state file"), std::string::npos) << listing;
    SerialClient client(doppel.link(), 1000000);
    p2_write(client, 1, 7, 5);  // XM430-W350 ID (7) := 5
    // Baud Rate (8) := 1 (57600 bps, reference §3.2): the status still goes out at 1 Mbps.
    client.transact(p2_instruction(5, kWrite, cat(le16(8), {1})), 11);
    // RX-64 CW Angle Limit (6, 2 bytes) := 100 (Protocol 1.0 WRITE, reference §1).
    EXPECT_EQ(client.transact(p1_instruction(2, kWrite, {6, 100, 0}), 6), (Bytes{0xFF, 0xFF, 0x02, 0x02, 0x00, 0xFB}));
    doppel.stop(SIGTERM);  // saves the EEPROM as it is now
  }
  {
    DoppelProcess doppel(args(dir));
    const std::string listing = doppel.wait_for_output("running until");
    EXPECT_NE(listing.find("EEPROM state loaded from " + file), std::string::npos) << listing;
    EXPECT_NE(listing.find("2 devices differ from the robot file"), std::string::npos) << listing;
    EXPECT_NE(listing.find("ID   5 XM430-W350"), std::string::npos) << listing;
    EXPECT_NE(listing.find("EEPROM from the state file, not the robot file: ID 1 -> 5, Baud Rate 3 (1000000 bps) -> 1 "
                           "(57600 bps)"),
              std::string::npos)
        << listing;
    EXPECT_NE(listing.find("! listens at 57600 bps, the bus runs at 1000000 bps"), std::string::npos) << listing;
    EXPECT_NE(listing.find("EEPROM from the state file, not the robot file: CW Angle Limit 0 -> 100"), std::string::npos)
        << listing;
    // The flag is the truth: at the bus' rate the XM430 is silent, at its own it answers.
    SerialClient bus_rate(doppel.link(), 1000000);
    EXPECT_FALSE(p2_pings(bus_rate, 5, 200));
    doppel.stop(SIGTERM);
  }
  std::vector<std::string> fresh = args(dir);
  fresh.push_back("--fresh");
  DoppelProcess doppel(fresh);
  const std::string listing = doppel.wait_for_output("running until");
  EXPECT_NE(listing.find("EEPROM state from the robot file; what drivers write to EEPROM is kept in " + file),
            std::string::npos) << listing;
  EXPECT_EQ(listing.find("EEPROM from the state file"), std::string::npos) << listing;
  EXPECT_EQ(listing.find("! listens at"), std::string::npos) << listing;
  EXPECT_NE(listing.find("ID   1 XM430-W350"), std::string::npos) << listing;
}

// DynamixelSDK's protocol_combined example: an MX-28 with Protocol 1.0 firmware (ID 1) and a
// Protocol 2.0 servo (ID 2) on one port at 57600 bps, each addressed in its own protocol.
TEST(MixedBus, Protocol1AndProtocol2ServosShareOnePort) {
  StateDir dir(R"(name: "protocol-combined"
bus {
  baud_bps: 57600
  protocol: PROTOCOL_2
  device { id: 1 model: "MX-28" name: "MX28_P1" protocol: PROTOCOL_1 }
  device { id: 2 model: "XM430-W350" name: "XM430_P2" }
}
)");
  DoppelProcess doppel(args(dir));
  doppel.wait_for_output("running until");
  SerialClient client(doppel.link(), 57600);
  // Reference §1.7: PING ID 1 -> FF FF 01 02 00 FC.
  EXPECT_EQ(client.transact({0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB}, 6), (Bytes{0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC}));
  // Reference §2.2: PING ID 2 is answered by an XM430-W350 (model 1020, firmware 45).
  const auto ping = parse_p2_statuses(client.transact(p2_instruction(2, kPing), 14));
  ASSERT_TRUE(ping && ping->size() == 1);
  EXPECT_EQ((*ping)[0].params, (Bytes{0xFC, 0x03, 0x2D}));
  // As the example: Torque Enable and Goal Position over Protocol 1.0 to ID 1 (MX-28: 24, 30),
  // over Protocol 2.0 to ID 2 (64, 116); each answers in its own protocol without error.
  for (const Bytes& params : {Bytes{24, 1}, Bytes{30, 0x00, 0x08}}) {
    const auto status = parse_p1_statuses(client.transact(p1_instruction(1, kWrite, params), 6));
    ASSERT_TRUE(status && status->size() == 1);
    EXPECT_EQ((*status)[0].error, 0);
  }
  p2_write(client, 2, 64, 1);
  const auto read = parse_p2_statuses(client.transact(p2_instruction(2, kRead, cat(le16(132), le16(4))), 15));
  ASSERT_TRUE(read && read->size() == 1 && (*read)[0].params.size() == 4);
  // Neither answers the other's protocol.
  EXPECT_FALSE(p2_pings(client, 1, 200));
  EXPECT_FALSE(p1_pings(client, 2, 200));
}

}  // namespace
}  // namespace doppel::testing
