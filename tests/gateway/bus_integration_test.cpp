// End-to-end: the real doppel executable, a real pty opened as a driver opens it (raw termios, a
// real baud rate), and a client written from shared/reference/dynamixel.md. Expected packets are
// built from the reference's framing rules or copied from its worked examples, never with Doppel's
// own encoder.
#include <poll.h>
#include <signal.h>
#include <sys/inotify.h>
#include <sys/ioctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <thread>

#include "doppel_process.h"
#include "reference_client.h"

namespace doppel::testing {
namespace {

constexpr uint32_t kBaud = 1000000;
constexpr uint8_t kPing = 0x01, kRead = 0x02, kWrite = 0x03, kRegWrite = 0x04, kAction = 0x05, kReset = 0x06,
                  kSyncWrite = 0x83, kBulkRead = 0x92;
constexpr uint8_t kBroadcast = 0xFE;
// mx-test robot: 1 MX-28, 2 MX-64, 3 MX-106, 4 AX-12A, 5 RX-28, 100 IMU, 101 foot board.

// A status packet has the instruction packet's framing with ERR in place of INST (reference §1.1).
Bytes status(uint8_t id, uint8_t error, const Bytes& params = {}) { return p1_instruction(id, error, params); }

uint16_t word(const Bytes& reply, std::size_t offset) {
  return static_cast<uint16_t>(reply.at(offset) | (reply.at(offset + 1) << 8));
}

class MxBus : public ::testing::Test {
 protected:
  MxBus() : doppel_({"--robot", "mx-test", "--timing", "fast"}), client_(doppel_.link(), kBaud) {}

  Bytes read(uint8_t id, uint8_t address, uint8_t length) {
    return client_.transact(p1_instruction(id, kRead, {address, length}), 6u + length);
  }
  Bytes write(uint8_t id, const Bytes& address_and_data) {
    return client_.transact(p1_instruction(id, kWrite, address_and_data), 6);
  }

  DoppelProcess doppel_;
  SerialClient client_;
};

TEST_F(MxBus, PingIsAnsweredByEveryDeviceWithTheReferenceStatus) {
  // Reference §1.7: PING ID 1 = FF FF 01 02 01 FB, its status FF FF 01 02 00 FC.
  EXPECT_EQ(client_.transact({0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB}, 6), (Bytes{0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC}));
  for (uint8_t id : {2, 3, 4, 5, 100, 101}) {
    EXPECT_EQ(client_.transact(p1_instruction(id, kPing), 6), status(id, 0)) << int(id);
  }
}

TEST_F(MxBus, ModelNumbersAreThoseOfTheReference) {
  // Reference §3.1: MX-28 29, MX-64 310, MX-106 320, AX-12A 12, RX-28 28.
  const std::pair<uint8_t, uint16_t> models[] = {{1, 29}, {2, 310}, {3, 320}, {4, 12}, {5, 28}};
  for (auto [id, model] : models) {
    Bytes reply = read(id, 0, 2);
    EXPECT_EQ(reply, status(id, 0, {static_cast<uint8_t>(model & 0xFF), static_cast<uint8_t>(model >> 8)})) << int(id);
  }
}

TEST_F(MxBus, UnknownIdStaysSilent) { EXPECT_TRUE(client_.transact(p1_instruction(42, kPing), 6, 100).empty()); }

TEST_F(MxBus, WrittenGoalIsReachedAndReadBack) {
  ASSERT_EQ(write(1, {24, 1}), status(1, 0));                      // Torque Enable
  ASSERT_EQ(write(1, {30, 0x00, 0x0A}), status(1, 0));             // Goal Position 2560
  EXPECT_EQ(read(1, 30, 2), status(1, 0, {0x00, 0x0A}));
  // 512 units = 45 deg at the MX-28's no-load speed (~55 rpm) take about 0.14 s.
  uint16_t position = 0;
  for (int i = 0; i < 200 && position != 2560; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    position = word(read(1, 36, 2), 5);
  }
  EXPECT_EQ(position, 2560);
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_EQ(read(1, 46, 1), status(1, 0, {0}));                    // Moving = 0 once there
}

TEST_F(MxBus, PresentPositionMovesGraduallyAtMovingSpeed) {
  write(2, {24, 1});
  write(2, {32, 100, 0});                                          // Moving Speed 100 x 0.114 rpm = 1.19 rad/s
  write(2, {30, 0x00, 0x0C});                                      // Goal 3072, 1024 units (90 deg) away
  // Polled every few ms (not after a fixed wall-clock time, which a loaded machine stretches): once
  // the joint has left its start it must be on its way, far from the goal, and report Moving. At
  // 1.19 rad/s (0.78 units per ms) it needs 1.3 s for the 1024 units.
  uint16_t position = 2048;
  for (int i = 0; i < 2000 && position <= 2048 + 50; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
    position = word(read(2, 36, 2), 5);
  }
  Bytes moving = read(2, 46, 1);
  EXPECT_EQ(moving, status(2, 0, {1}));
  EXPECT_GT(position, 2048 + 50);
  EXPECT_LT(position, 3072 - 300);
}

TEST_F(MxBus, RegWriteWaitsForAction) {
  // Reference §1.2: REG_WRITE stores and sets Registered (44); ACTION executes it.
  ASSERT_EQ(client_.transact(p1_instruction(1, kRegWrite, {30, 0xF4, 0x01}), 6), status(1, 0));
  EXPECT_EQ(read(1, 44, 1), status(1, 0, {1}));
  EXPECT_NE(read(1, 30, 2), status(1, 0, {0xF4, 0x01}));
  client_.send({0xFF, 0xFF, 0xFE, 0x02, 0x05, 0xFA});              // ACTION broadcast (§1.7): no status
  EXPECT_TRUE(client_.drain(50).empty());
  EXPECT_EQ(read(1, 44, 1), status(1, 0, {0}));
  EXPECT_EQ(read(1, 30, 2), status(1, 0, {0xF4, 0x01}));
}

TEST_F(MxBus, ActionWithoutRegWriteIsAnInstructionError) {
  EXPECT_EQ(client_.transact(p1_instruction(3, kAction), 6), status(3, 0x40));
}

TEST_F(MxBus, SyncWriteSetsEveryListedServoAndIsNotAnswered) {
  // Goal Position + Moving Speed of IDs 1 and 2 (layout of the §1.7 example).
  client_.send(p1_instruction(kBroadcast, kSyncWrite, {30, 4, 1, 0x10, 0x00, 0x50, 0x01, 2, 0x20, 0x02, 0x60, 0x03}));
  EXPECT_TRUE(client_.drain(50).empty());
  EXPECT_EQ(read(1, 30, 4), status(1, 0, {0x10, 0x00, 0x50, 0x01}));
  EXPECT_EQ(read(2, 30, 4), status(2, 0, {0x20, 0x02, 0x60, 0x03}));
}

TEST_F(MxBus, BulkReadAnswersInListOrder) {
  // Blocks are [length, ID, address] (§1.2): 2 bytes of ID 3, 1 byte of ID 1, 2 bytes of ID 2.
  Bytes request = p1_instruction(kBroadcast, kBulkRead, {0x00, 2, 3, 0, 1, 1, 0, 2, 2, 0});
  Bytes reply = client_.transact(request, 8 + 7 + 8);
  Bytes expected = status(3, 0, {0x40, 0x01});                     // MX-106: 320
  Bytes second = status(1, 0, {29});                               // MX-28, 1 byte
  Bytes third = status(2, 0, {0x36, 0x01});                        // MX-64: 310
  expected.insert(expected.end(), second.begin(), second.end());
  expected.insert(expected.end(), third.begin(), third.end());
  EXPECT_EQ(reply, expected);
}

TEST_F(MxBus, BulkReadChainStopsAtADeviceThatCannotAnswer) {
  // The AX-12A (ID 4) does not know BULK READ; the MX-64 listed after it waits for a status that
  // never comes (docs/devices.md).
  Bytes reply = client_.transact(p1_instruction(kBroadcast, kBulkRead, {0x00, 2, 1, 0, 2, 4, 0, 2, 2, 0}), 24);
  EXPECT_EQ(reply, status(1, 0, {29, 0}));
}

TEST_F(MxBus, BadChecksumIsReportedAndNotExecuted) {
  // READ with a wrong checksum: status with the Checksum bit (§1.4), no data.
  EXPECT_EQ(client_.transact({0xFF, 0xFF, 0x01, 0x04, 0x02, 0x24, 0x02, 0x00}, 6), status(1, 0x10));
  // A PING with a wrong checksum is not answered (§1.4, RX-64 manual).
  EXPECT_TRUE(client_.transact({0xFF, 0xFF, 0x01, 0x02, 0x01, 0x00}, 6, 100).empty());
  // A WRITE with a wrong checksum does not change the register.
  Bytes bad_write = p1_instruction(1, kWrite, {25, 1});
  bad_write.back() ^= 0x5A;
  EXPECT_EQ(client_.transact(bad_write, 6), status(1, 0x10));
  EXPECT_EQ(read(1, 25, 1), status(1, 0, {0}));
}

TEST_F(MxBus, UndefinedInstructionIsAnInstructionError) {
  EXPECT_EQ(client_.transact(p1_instruction(1, 0x50), 6), status(1, 0x40));
}

TEST_F(MxBus, WritesOutOfRangeOrToReadOnlyRegistersAreRangeErrors) {
  EXPECT_EQ(write(1, {16, 3}), status(1, 0x08));                   // Status Return Level 0..2
  EXPECT_EQ(write(1, {0, 0x00, 0x00}), status(1, 0x08));           // Model Number is read-only
  EXPECT_EQ(read(1, 0, 2), status(1, 0, {29, 0}));
  EXPECT_EQ(write(4, {30, 0x00, 0x04}), status(4, 0x08));          // AX-12A Goal Position 1024 > 1023
}

TEST_F(MxBus, GarbageBeforeAPacketIsSkipped) {
  Bytes bytes{0x00, 0x13, 0xFF, 0x42, 0xFF, 0xFF, 0xFF};
  Bytes ping{0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB};
  bytes.insert(bytes.end(), ping.begin(), ping.end());
  // The leading FF FF FF is a header followed by another header byte; a third FF keeps hunting.
  EXPECT_EQ(client_.transact(bytes, 6), status(1, 0));
}

TEST_F(MxBus, TruncatedPacketIsDroppedAfterTheInterByteTimeout) {
  client_.send({0xFF, 0xFF, 0x01, 0x04, 0x02});                    // READ cut short
  // > 100 ms: the device gives up on it (300 ms: a margin for a bus thread slowed by a sanitizer)
  EXPECT_TRUE(client_.drain(300).empty());
  EXPECT_EQ(client_.transact(p1_instruction(1, kPing), 6), status(1, 0));
}

TEST_F(MxBus, StatusReturnLevelDecidesWhatIsAnswered) {
  ASSERT_EQ(write(2, {16, 1}), status(2, 0));                      // the write itself is still answered at SRL 2
  EXPECT_TRUE(client_.transact(p1_instruction(2, kWrite, {25, 1}), 6, 100).empty());
  EXPECT_EQ(read(2, 25, 1), status(2, 0, {1}));
  EXPECT_EQ(client_.transact(p1_instruction(2, kPing), 6), status(2, 0));
  client_.send(p1_instruction(2, kWrite, {16, 0}));
  EXPECT_TRUE(client_.transact(p1_instruction(2, kRead, {25, 1}), 7, 100).empty());
  EXPECT_EQ(client_.transact(p1_instruction(2, kPing), 6), status(2, 0));
}

TEST_F(MxBus, IdChangeTakesEffectAfterTheStatus) {
  EXPECT_EQ(write(3, {3, 50}), status(3, 0));                      // answered with the old ID
  EXPECT_TRUE(client_.transact(p1_instruction(3, kPing), 6, 100).empty());
  EXPECT_EQ(client_.transact(p1_instruction(50, kPing), 6), status(50, 0));
}

TEST_F(MxBus, BaudChangeTakesEffectAfterTheStatus) {
  EXPECT_EQ(write(1, {4, 34}), status(1, 0));                      // 57 600 bps from now on (§3.2)
  EXPECT_TRUE(client_.transact(p1_instruction(1, kPing), 6, 100).empty());
  SerialClient slow(doppel_.link(), 57600);
  EXPECT_EQ(slow.transact(p1_instruction(1, kPing), 6), status(1, 0));
  EXPECT_TRUE(slow.transact(p1_instruction(2, kPing), 6, 100).empty());  // ID 2 still listens at 1 Mbps
}

TEST_F(MxBus, PortOpenedAtTheWrongBaudRateGetsNoAnswer) {
  SerialClient wrong(doppel_.link(), 115200);
  EXPECT_TRUE(wrong.transact(p1_instruction(1, kPing), 6, 100).empty());
  SerialClient right(doppel_.link(), kBaud);
  EXPECT_EQ(right.transact(p1_instruction(1, kPing), 6), status(1, 0));
}

TEST_F(MxBus, BroadcastPingOfSeveralDevicesCollides) {
  // §1.3: every device answers a broadcast PING at once; on a shared line that is garbage.
  Bytes reply = client_.transact(p1_instruction(kBroadcast, kPing), 6, 100);
  auto statuses = parse_p1_statuses(reply);
  EXPECT_FALSE(statuses.has_value() && statuses->size() == 1 && (*statuses)[0].id != kBroadcast);
}

TEST_F(MxBus, ImuAndFootBoardReportARobotAtRest) {
  Bytes imu = read(100, 26, 18);                                   // pitch, roll, yaw, gyro xyz, accel xyz
  ASSERT_EQ(imu.size(), 24u);
  EXPECT_EQ(word(imu, 5), 0);                                      // pitch 0
  EXPECT_EQ(word(imu, 7), 0);                                      // roll 0
  EXPECT_NEAR(static_cast<int16_t>(word(imu, 21)), 981, 1);        // accel z = g in 0.01 m/s^2
  Bytes foot = read(101, 26, 10);
  ASSERT_EQ(foot.size(), 16u);
  uint16_t total = word(foot, 13);                                 // 0.01 N
  EXPECT_EQ(total, word(foot, 5) + word(foot, 7) + word(foot, 9) + word(foot, 11));
  EXPECT_GT(total, 0);
}

// Reads the inotify events waiting on `fd` (opened IN_NONBLOCK) and hands each to `on_event`;
// false when none were waiting.
template <typename OnEvent>
bool read_inotify_events(int fd, OnEvent on_event) {
  alignas(inotify_event) char events[4096];
  const ssize_t n = ::read(fd, events, sizeof(events));
  for (ssize_t at = 0; at < n;) {
    const auto* event = reinterpret_cast<const inotify_event*>(events + at);
    on_event(*event);
    at += static_cast<ssize_t>(sizeof(inotify_event) + event->len);
  }
  return n > 0;
}

// Watches the closes of the line behind a link (inotify on the pty slave). When its client hangs
// up, doppel's bus thread cleans the line: it opens the slave itself, flushes what the old client
// left and closes it again (bus/pty_port.h). That second close ends the window in which a new
// client could still be handed its predecessor's bytes, so the reconnect tests wait for it. Opens
// are watched too, though not counted: inotify merges two identical events in a row, and an open
// between the client's close and doppel's keeps them apart (the clean-up's open raises IN_OPEN,
// which libs/bus/src/pty_port.cpp relies on as well).
class LineCloses {
 public:
  explicit LineCloses(const std::string& link) : fd_(::inotify_init1(IN_NONBLOCK | IN_CLOEXEC)) {
    EXPECT_GE(fd_, 0);
    EXPECT_GE(::inotify_add_watch(fd_, link.c_str(), IN_OPEN | IN_CLOSE), 0) << link;
  }
  ~LineCloses() { ::close(fd_); }
  LineCloses(const LineCloses&) = delete;
  LineCloses& operator=(const LineCloses&) = delete;

  // Waits until `count` more closes of the line have happened (up to 5 s); false if they did not.
  bool wait(int count) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
    while (seen_ < count) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
      if (left.count() <= 0) return false;
      pollfd pfd{fd_, POLLIN, 0};
      if (::poll(&pfd, 1, static_cast<int>(left.count())) <= 0) continue;
      read_inotify_events(fd_, [this](const inotify_event& event) { seen_ += (event.mask & IN_CLOSE) != 0 ? 1 : 0; });
    }
    seen_ -= count;
    return true;
  }

 private:
  int fd_;
  int seen_ = 0;
};

// Waits until at least `n` bytes are waiting in the input queue of `fd` (up to 2 s).
bool wait_input(int fd, int n) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(2);
  int waiting = 0;
  while (::ioctl(fd, FIONREAD, &waiting) == 0 && waiting < n) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return waiting >= n;
}

// The reconnect tests hold no other client open: a port opened twice is one line for both.
TEST(Reconnect, NextOpenStartsClean) {
  DoppelProcess doppel({"--robot", "mx-test", "--timing", "fast"});
  LineCloses line(doppel.link());
  {
    SerialClient first(doppel.link(), kBaud);
    first.send(p1_instruction(2, kPing));                          // a reply this client never reads
    ASSERT_TRUE(wait_input(first.fd(), 6));                        // it is waiting in the pty
    const Bytes half_read = {0xFF, 0xFF, 0x01, 0x04};              // half a READ (no flush: the reply stays), then close
    ASSERT_EQ(::write(first.fd(), half_read.data(), half_read.size()), 4);
  }
  ASSERT_TRUE(line.wait(2)) << "the client's close and doppel's clean-up of the line";
  SerialClient second(doppel.link(), kBaud);
  Bytes ping = p1_instruction(1, kPing);
  ASSERT_EQ(::write(second.fd(), ping.data(), ping.size()), 6);    // no flush: stale bytes would show
  EXPECT_EQ(second.receive(6, 5000), status(1, 0));
  EXPECT_TRUE(second.drain(50).empty());
}

TEST(Reconnect, ClientKilledMidPacketLeavesTheBusWorking) {
  DoppelProcess doppel({"--robot", "mx-test", "--timing", "fast"});
  std::string port = doppel.link();
  LineCloses line(port);
  for (int session = 0; session < 3; ++session) {
    pid_t child = fork();
    if (child == 0) {
      SerialClient dying(port, kBaud);
      dying.send({0xFF, 0xFF, 0x03, 0x04, 0x02});
      kill(getpid(), SIGKILL);
    }
    int wait_status = 0;
    waitpid(child, &wait_status, 0);
    ASSERT_TRUE(WIFSIGNALED(wait_status));
    ASSERT_TRUE(line.wait(2)) << "the killed client's close and doppel's clean-up, session " << session;
    {
      SerialClient next(port, kBaud);
      EXPECT_EQ(next.transact(p1_instruction(3, kPing), 6), status(3, 0)) << "session " << session;
    }
    ASSERT_TRUE(line.wait(2)) << "the next client's close and doppel's clean-up, session " << session;
  }
}

TEST(Doppel, StopsCleanlyOnSigtermAndSigintAndRemovesItsLinks) {
  for (int signal : {SIGTERM, SIGINT}) {
    DoppelProcess doppel({"--robot", "mx-test", "--timing", "fast"});
    std::string link = doppel.link();
    { SerialClient client(link, kBaud); }
    int wait_status = doppel.stop(signal);
    EXPECT_TRUE(WIFEXITED(wait_status) && WEXITSTATUS(wait_status) == 0) << wait_status;
    EXPECT_FALSE(std::filesystem::exists(std::filesystem::symlink_status(link))) << link;
  }
}

TEST(Doppel, DefaultRobotServesAll24DevicesAndPrintsThem) {
  DoppelProcess doppel({"--timing", "fast"});
  SerialClient client(doppel.link(), kBaud);
  for (int id = 1; id <= 21; ++id) {
    EXPECT_EQ(client.transact(p1_instruction(static_cast<uint8_t>(id), kPing), 6), status(static_cast<uint8_t>(id), 0));
  }
  for (uint8_t id : {100, 101, 102}) {
    EXPECT_EQ(client.transact(p1_instruction(id, kPing), 6), status(id, 0));
  }
  // HEAD_YAW (ID 2) is an RX-64 (thesis figure 27b).
  EXPECT_EQ(client.transact(p1_instruction(2, kRead, {0, 2}), 8), status(2, 0, {64, 0}));
  std::string output = doppel.wait_for_output("running until");
  EXPECT_NE(output.find(doppel.link()), std::string::npos) << output;
  EXPECT_NE(output.find("HEAD_YAW"), std::string::npos) << output;
}

TEST(Doppel, SecondRobotGetsItsOwnPort) {
  DoppelProcess doppel({"--robot", "mx-test", "--robot", "mx-test", "--timing", "fast"}, "robot1/ttyDXL0");
  SerialClient first(doppel.link("ttyDXL0"), kBaud);
  SerialClient second(doppel.link("robot1/ttyDXL0"), kBaud);
  ASSERT_EQ(first.transact(p1_instruction(1, kWrite, {25, 1}), 6), status(1, 0));
  EXPECT_EQ(first.transact(p1_instruction(1, kRead, {25, 1}), 7), status(1, 0, {1}));
  EXPECT_EQ(second.transact(p1_instruction(1, kRead, {25, 1}), 7), status(1, 0, {0}));
}

TEST(Doppel, FactoryResetAnswersWithTheOldIdThenListensAsId1At57600) {
  char dir_template[] = "/tmp/doppel-reset-XXXXXX";
  std::string dir = mkdtemp(dir_template);
  std::string file = dir + "/one.textproto";
  std::ofstream(file) << "name: \"one\"\nbus {\n baud_bps: 1000000\n protocol: PROTOCOL_1\n"
                         " device { id: 7 model: \"RX-28\" }\n}\n";
  DoppelProcess doppel({"--robot", file, "--timing", "fast"});
  {
    SerialClient client(doppel.link(), kBaud);
    EXPECT_EQ(client.transact(p1_instruction(7, kReset), 6), status(7, 0));
    EXPECT_TRUE(client.transact(p1_instruction(1, kPing), 6, 100).empty());
  }
  SerialClient slow(doppel.link(), 57600);                          // RX-28 default Baud Rate 34
  EXPECT_EQ(slow.transact(p1_instruction(1, kPing), 6), status(1, 0));
  std::filesystem::remove_all(dir);
}

TEST(Doppel, WireTimingIsNeverFasterThanTheWire) {
  DoppelProcess doppel({"--robot", "mx-test", "--timing", "wire"});
  SerialClient client(doppel.link(), kBaud);
  // READ 2 B: 8 bytes out + 8 back at 10 µs each, 50 µs firmware time, 500 µs Return Delay Time.
  const double model_us = 16 * 10.0 + 50.0 + 500.0;
  for (int i = 0; i < 20; ++i) {
    auto start = std::chrono::steady_clock::now();
    Bytes reply = client.transact(p1_instruction(1, kRead, {36, 2}), 8);
    double us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - start).count();
    ASSERT_EQ(reply.size(), 8u);
    EXPECT_GE(us, model_us - 1.0);
  }
}

TEST(Doppel, UsbLatencyTimerDelaysReplies) {
  DoppelProcess doppel({"--robot", "mx-test", "--timing", "wire", "--latency-timer", "16"});
  SerialClient client(doppel.link(), kBaud);
  std::vector<double> ms;
  for (int i = 0; i < 20; ++i) {
    auto start = std::chrono::steady_clock::now();
    ASSERT_EQ(client.transact(p1_instruction(1, kPing), 6).size(), 6u);
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
  }
  // A 16 ms timer holds a short status until it expires: 8 ms on average (reference §4.3).
  EXPECT_GT(std::accumulate(ms.begin(), ms.end(), 0.0) / static_cast<double>(ms.size()), 4.0);
}

TEST(Doppel, CommandLineErrorsAreClear) {
  auto run = [](const std::string& args) { return run_command(doppel_executable() + " " + args); };
  auto [help_code, help] = run("--help");
  EXPECT_EQ(help_code, 0);
  EXPECT_NE(help.find("--link-dir"), std::string::npos);
  auto [bad_code, bad] = run("--timing slow");
  EXPECT_EQ(bad_code, 2);
  EXPECT_NE(bad.find("--timing"), std::string::npos) << bad;
  auto [robot_code, robot] = run("--robot no-such-robot --link-dir /tmp/doppel-never");
  EXPECT_EQ(robot_code, 1);
  EXPECT_NE(robot.find("fumanoid-2011"), std::string::npos) << robot;
  auto [list_code, list] = run("--list-robots");
  EXPECT_EQ(list_code, 0);
  // One line a robot, with the description from its file.
  EXPECT_NE(list.find("mx-test         MX-28, MX-64, MX-106, AX-12A"), std::string::npos) << list;
}

// Issue 16: a /tmp/doppel made beforehand by another user as a symlink must not receive the links.
TEST(Doppel, RefusesASymlinkedLinkDirectoryAndCreatesNothingThere) {
  char dir_template[] = "/tmp/doppel-linkdir-XXXXXX";
  const std::string dir = mkdtemp(dir_template);
  std::filesystem::create_directory(dir + "/elsewhere");
  std::filesystem::create_directory_symlink(dir + "/elsewhere", dir + "/links");

  auto [code, said] = run_command(doppel_executable() + " --robot mx-test --robot mx-test --no-camera --link-dir " +
                                  dir + "/links");

  EXPECT_EQ(code, 1) << said;
  EXPECT_NE(said.find("'" + dir + "/links' is a symbolic link"), std::string::npos) << said;
  EXPECT_NE(said.find("--allow-shared-link-dir"), std::string::npos) << said;
  EXPECT_TRUE(std::filesystem::is_empty(dir + "/elsewhere"));
  std::filesystem::remove_all(dir);
}

TEST(Doppel, RemovesTheLinkDirectoriesItCreatedAtExit) {
  std::string parent;
  {
    DoppelProcess doppel({"--robot", "mx-test", "--robot", "mx-test"}, "robot1/ttyDXL0");
    parent = std::filesystem::path(doppel.link_dir()).parent_path().string();
    EXPECT_TRUE(std::filesystem::is_symlink(doppel.link("robot1/ttyDXL0")));
    const int status = doppel.stop(SIGTERM);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << doppel.output();
    EXPECT_FALSE(std::filesystem::exists(doppel.link_dir())) << doppel.output();
    EXPECT_TRUE(std::filesystem::is_directory(parent)) << "only what doppel created goes";
  }
}

TEST(Doppel, SaysSoAndLeavesALinkReplacedWhileItRan) {
  DoppelProcess doppel({"--robot", "mx-test"});
  const std::string foreign = std::filesystem::path(doppel.link_dir()).parent_path().string() + "/foreign";
  std::ofstream(foreign) << "x";
  std::filesystem::create_symlink(foreign, doppel.link_dir() + "/tmp");
  std::filesystem::rename(doppel.link_dir() + "/tmp", doppel.link());

  doppel.stop(SIGTERM);

  EXPECT_EQ(std::filesystem::read_symlink(doppel.link()).string(), foreign);
  EXPECT_NE(doppel.output().find("'" + doppel.link() + "' no longer points at"), std::string::npos)
      << doppel.output();
}

// Issue 16: doppel ignored SIGINT/SIGTERM while it read a robot file.
TEST(Doppel, ASignalWhileLoadingEndsItAtOnceWithAMessage) {
  char dir_template[] = "/tmp/doppel-load-XXXXXX";
  const std::string dir = mkdtemp(dir_template);
  const std::string file = dir + "/big.textproto";
  {
    std::ofstream out(file);
    out << "name: \"big\"\nbus {\n baud_bps: 1000000\n protocol: PROTOCOL_1\n device { id: 1 model: \"RX-28\" }\n}\n";
    const std::string comment = "# " + std::string(1000, 'x') + "\n";
    for (int i = 0; i < 15 * 1024; ++i) out << comment;  // ~15 MiB: loading takes a while
  }
  // Six of them: loading takes far longer than the 0.1 s before the signal, also on a fast machine
  // (one alone sometimes loaded within 0.1 s, and the test then saw a normal start).
  std::string robots;
  for (int i = 0; i < 6; ++i) robots += " --robot " + file;
  // The signal goes once doppel's main thread has blocked it (SigBlk in /proc has SIGTERM, bit
  // 15): a signal before that is the kernel's default action, which ends any program at once
  // (seen on a loaded machine after a fixed 0.1 s: "Terminated", exit 143).
  const std::string command =
      "( " + doppel_executable() + robots + " --no-camera --no-viewer --link-dir " + dir + "/links & pid=$!; " +
      "for i in $(seq 3000); do m=$(awk '/^SigBlk/ {print $2}' /proc/$pid/status 2>/dev/null); " +
      "[ -n \"$m\" ] && [ $(( 0x$m & 16384 )) -ne 0 ] && break; sleep 0.01; done; " +
      "kill -TERM $pid; wait $pid; echo \"exit $?\" )";
  // Ended at once, while still loading: the link directory's parent never saw it created (doppel
  // creates it only when it sets the ports up, after loading).
  const int watch = inotify_init1(IN_CLOEXEC | IN_NONBLOCK);
  ASSERT_GE(watch, 0);
  ASSERT_GE(inotify_add_watch(watch, dir.c_str(), IN_CREATE), 0);
  auto [code, said] = run_command(command);
  std::vector<std::string> created;
  while (read_inotify_events(watch, [&](const inotify_event& event) {
    if (event.len > 0) created.emplace_back(event.name);
  })) {
  }
  ::close(watch);

  EXPECT_NE(said.find("doppel: SIGTERM while starting up; stopping"), std::string::npos) << said;
  EXPECT_NE(said.find("exit 0"), std::string::npos) << said;
  EXPECT_EQ(std::count(created.begin(), created.end(), "links"), 0) << said;
  EXPECT_FALSE(std::filesystem::exists(dir + "/links")) << said;
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace doppel::testing
