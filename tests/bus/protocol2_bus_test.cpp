// Protocol 2.0 on a served bus: mixed P1/P2 framing, the 1.5 ms inter-byte timeout, the wire
// timing of broadcast PING slots and fast-read blocks, BOTHER rates, and the periodic device tick.
// Client bytes are the reference's worked packets (shared/reference/dynamixel.md §1.7, §2.2-2.7).
#include <asm/termbits.h>
#include <sys/ioctl.h>

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <numbers>
#include <optional>
#include <thread>
#include <vector>

#include "bus/bus_server.h"
#include "bus/wire_timing.h"
#include "dynamixel/bus_devices.h"
#include "dynamixel/protocol1_servo.h"
#include "dynamixel/protocol2_servo.h"
#include "bother_line.h"
#include "pty_test_support.h"
#include "served_bus.h"

namespace doppel::bus {
namespace {

using namespace std::chrono_literals;
using namespace testing;  // pty client helpers (pty_test_support.h), ServedBus and fast() (served_bus.h)
using Bytes = std::vector<uint8_t>;

const Bytes kP2Ping1{0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x03, 0x00, 0x01, 0x19, 0x4E};
const Bytes kP2Ping1Status{0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x07, 0x00, 0x55, 0x00, 0xFC, 0x03, 0x2D, 0x17, 0x43};
const Bytes kP2BroadcastPing{0xFF, 0xFF, 0xFD, 0x00, 0xFE, 0x03, 0x00, 0x01, 0x31, 0x42};
const Bytes kP1Ping1{0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB};
const Bytes kP1Ping1Status{0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC};
// FAST SYNC READ IDs 3, 7, 4 at 132, 4 B and its reply for Present Position 166, 2079, 1023 (§2.7).
const Bytes kFastSyncRead{0xFF, 0xFF, 0xFD, 0x00, 0xFE, 0x0A, 0x00, 0x8A, 0x84, 0x00, 0x04, 0x00, 0x03, 0x07, 0x04, 0x20, 0xF2};
const Bytes kFastSyncReply{0xFF, 0xFF, 0xFD, 0x00, 0xFE, 0x19, 0x00, 0x55, 0x00, 0x03, 0xA6, 0x00, 0x00, 0x00, 0x84, 0x08,
                           0x00, 0x07, 0x1F, 0x08, 0x00, 0x00, 0x16, 0xCA, 0x00, 0x04, 0xFF, 0x03, 0x00, 0x00, 0xD1, 0x9E};

double rad_of(int present) { return (present - 2048) * 2.0 * std::numbers::pi / 4096.0; }

class CountingSync final : public DeviceSync {
 public:
  void before_dispatch() noexcept override {}
  void after_dispatch() noexcept override {}
  void on_tick() noexcept override { ticks.fetch_add(1); }
  std::atomic<int> ticks{0};
};

// Opens the port as DynamixelSDK does for rates without a Bxxxx constant: TCSETS2 with BOTHER.
int open_bother_client(const std::string& path, uint32_t baud_bps) {
  const int fd = open_client(path);
  if (fd < 0) return fd;
  if (doppel::testing::set_bother_line(fd, baud_bps) != nullptr) {
    ::close(fd);
    return -1;
  }
  ::ioctl(fd, TCFLSH, TCIFLUSH);
  return fd;
}

const dynamixel::P2ModelSpec& xm() { return dynamixel::p2_model_spec("XM430-W350"); }

TEST(Protocol2Bus, P1AndP2DevicesWithTheSameIdShareABus) {
  dynamixel::Protocol1Servo p1(dynamixel::model_spec("MX-28"), 1, 1, 0);  // 1 Mbps
  dynamixel::Protocol2Servo p2(xm(), 1, 3, 0);                            // index 3 = 1 Mbps
  ServedBus sut(fast(), {&p1, &p2});
  const ClientFd client(open_bother_client(sut.path(), 1'000'000));
  ASSERT_GE(client, 0);
  ASSERT_TRUE(write_all(client, kP1Ping1));
  EXPECT_EQ(read_bytes(client, 6, 1s), kP1Ping1Status);
  ASSERT_TRUE(write_all(client, kP2Ping1));
  EXPECT_EQ(read_bytes(client, 14, 1s), kP2Ping1Status);
  // Both in one write: each protocol's device answers its own packet.
  Bytes both = kP2Ping1;
  both.insert(both.end(), kP1Ping1.begin(), kP1Ping1.end());
  ASSERT_TRUE(write_all(client, both));
  Bytes expected = kP2Ping1Status;
  expected.insert(expected.end(), kP1Ping1Status.begin(), kP1Ping1Status.end());
  EXPECT_EQ(read_bytes(client, expected.size(), 1s), expected);
}

TEST(Protocol2Bus, P2PacketWithAGapOfMoreThanOneAndAHalfMillisecondsIsDropped) {
  dynamixel::Protocol2Servo servo(xm(), 1, 6, 0);
  ServedBus sut(fast(), {&servo});
  const ClientFd client(open_bother_client(sut.path(), 4'000'000));
  ASSERT_GE(client, 0);
  ASSERT_TRUE(write_all(client, Bytes(kP2Ping1.begin(), kP2Ping1.begin() + 6)));
  // The gap is measured between the bus thread's reads: the first part read, then 20 ms at least.
  ASSERT_TRUE(sut.eventually([](const BusDiagnostics& d) { return d.bytes_in == 6; }));
  std::this_thread::sleep_for(20ms);
  ASSERT_TRUE(write_all(client, Bytes(kP2Ping1.begin() + 6, kP2Ping1.end())));
  EXPECT_TRUE(read_bytes(client, 14, 100ms).empty());
  EXPECT_TRUE(sut.eventually([](const BusDiagnostics& d) { return d.timeouts == 1; }));
  ASSERT_TRUE(write_all(client, kP2Ping1));
  EXPECT_EQ(read_bytes(client, 14, 1s), kP2Ping1Status);
}

TEST(Protocol2Bus, P1PacketKeepsItsHundredMillisecondTimeout) {
  dynamixel::Protocol1Servo servo(dynamixel::model_spec("MX-28"), 1, 1, 0);
  ServedBus sut(fast(), {&servo});
  const ClientFd client(open_bother_client(sut.path(), 1'000'000));
  ASSERT_GE(client, 0);
  ASSERT_TRUE(write_all(client, Bytes(kP1Ping1.begin(), kP1Ping1.begin() + 3)));
  // A gap of 5 ms, more than Protocol 2.0's 1.5 ms, measured from the bus thread's read of the first
  // part; only a stall of 95 ms between the two would reach Protocol 1.0's 100 ms.
  ASSERT_TRUE(sut.eventually([](const BusDiagnostics& d) { return d.bytes_in == 3; }));
  std::this_thread::sleep_for(5ms);
  ASSERT_TRUE(write_all(client, Bytes(kP1Ping1.begin() + 3, kP1Ping1.end())));
  EXPECT_EQ(read_bytes(client, 6, 1s), kP1Ping1Status);
}

TEST(Protocol2Bus, FastSyncReadAtFourMegabaudInWireMode) {
  dynamixel::Protocol2Servo s3(xm(), 3, 6, 0, rad_of(166));
  dynamixel::Protocol2Servo s7(xm(), 7, 6, 0, rad_of(2079));
  dynamixel::Protocol2Servo s4(xm(), 4, 6, 0, rad_of(1023));
  BusServerOptions options;
  options.record_traces = true;
  ServedBus sut(options, {&s3, &s7, &s4});
  const ClientFd client(open_bother_client(sut.path(), 4'000'000));
  ASSERT_GE(client, 0);
  ASSERT_TRUE(write_all(client, kFastSyncRead));
  EXPECT_EQ(read_bytes(client, kFastSyncReply.size(), 1s), kFastSyncReply);
  const std::optional<ReplyTrace> traced = sut.next_trace();
  ASSERT_TRUE(traced);
  const ReplyTrace& trace = *traced;
  // One packet: firmware time (RDT 0) once, then 32 bytes back to back at 2.5 µs each.
  EXPECT_EQ(trace.status_end_ns - trace.instruction_end_ns, WireTiming::kDefaultProcessingNs + wire_duration_ns(32, 4'000'000));
  EXPECT_EQ(trace.line_baud_bps, 4'000'000u);
}

TEST(Protocol2Bus, BroadcastPingWaitsThreeMillisecondsPerMissingId) {
  dynamixel::Protocol2Servo s1(xm(), 1, 6, 0);
  dynamixel::Protocol2Servo s4(xm(), 4, 6, 0);
  BusServerOptions options;
  options.record_traces = true;
  ServedBus sut(options, {&s4, &s1});
  const ClientFd client(open_bother_client(sut.path(), 4'000'000));
  ASSERT_GE(client, 0);
  ASSERT_TRUE(write_all(client, kP2BroadcastPing));
  const Bytes reply = read_bytes(client, 28, 1s);
  ASSERT_EQ(reply.size(), 28u);
  EXPECT_EQ(reply[4], 1);
  EXPECT_EQ(reply[14 + 4], 4);
  const std::optional<ReplyTrace> traced = sut.next_trace();
  ASSERT_TRUE(traced);
  const ReplyTrace& trace = *traced;
  const int64_t status_ns = wire_duration_ns(14, 4'000'000);
  EXPECT_EQ(trace.status_end_ns - trace.instruction_end_ns,
            2 * (WireTiming::kDefaultProcessingNs + status_ns) + 2 * 3'000'000);  // IDs 2 and 3 idle
}

TEST(Protocol2Bus, DevicesAreTickedWithoutTraffic) {
  dynamixel::Protocol2Servo servo(xm(), 1, 6, 0);
  CountingSync sync;
  ServedBus sut(fast(), {&servo}, &sync);
  // No client, no packet: ticks still come (every BusServer::kTickNs).
  for (int i = 0; i < 2000 && sync.ticks.load() < 3; ++i) std::this_thread::sleep_for(1ms);
  EXPECT_GE(sync.ticks.load(), 3);
}

TEST(WireTimingP2, ExtraDelayAndGapFreeContinuation) {
  WireTiming sut(TimingMode::kWire, 50'000);
  sut.begin_reply(1'000'000);
  const WireSpan first = sut.status(14, 0, false, 4'000'000, 6'000'000);
  EXPECT_EQ(first.start_ns, 1'000'000 + 50'000 + 6'000'000);
  const WireSpan block = sut.status(8, 500, true, 4'000'000, 0, true);
  EXPECT_EQ(block.start_ns, first.end_ns);  // no firmware time, no Return Delay Time
  EXPECT_EQ(block.end_ns, first.end_ns + wire_duration_ns(8, 4'000'000));
}

}  // namespace
}  // namespace doppel::bus
