#include "bus/bus_server.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/utsname.h>
#include <sys/wait.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <atomic>
#include <chrono>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "bus/thread_slice.h"
#include "dynamixel/bus_devices.h"
#include "dynamixel/device.h"
#include "pty_test_support.h"
#include "served_bus.h"

namespace doppel::bus {
namespace {

using namespace std::chrono_literals;
using namespace testing;  // pty client helpers (pty_test_support.h), ServedBus and fast() (served_bus.h)
using Bytes = std::vector<uint8_t>;

// Reference §1.7, bytes as printed there (client side never uses Doppel's encoder).
const Bytes kPing1{0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB};
const Bytes kPing1Status{0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC};
const Bytes kPing1BadChecksum{0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFA};
const Bytes kBulkRead{0xFF, 0xFF, 0xFE, 0x09, 0x92, 0x00, 0x02, 0x01, 0x1E, 0x02, 0x02, 0x24, 0x1D};
const Bytes kBulkStatus1{0xFF, 0xFF, 0x01, 0x04, 0x00, 0x00, 0x80, 0x7A};
const Bytes kBulkStatus2{0xFF, 0xFF, 0x02, 0x04, 0x00, 0x00, 0x80, 0x79};

// A tiny Protocol 1.0 device: answers a PING to its ID, and its block of the reference BULK READ,
// with fixed reference bytes.
class FakeDevice final : public dynamixel::Device {
 public:
  FakeDevice(uint8_t id, Bytes ping_status, Bytes bulk_status, uint32_t baud_bps = 1'000'000,
             uint32_t return_delay_us = 0)
      : id_(id), ping_status_(std::move(ping_status)), bulk_status_(std::move(bulk_status)), baud_bps_(baud_bps),
        return_delay_us_(return_delay_us) {}

  dynamixel::Protocol protocol() const noexcept override { return dynamixel::Protocol::kV1; }
  uint8_t id() const noexcept override { return id_; }
  uint32_t baud_bps() const noexcept override { return baud_bps_; }
  uint32_t return_delay_us() const noexcept override { return return_delay_us_; }
  std::string_view model_name() const noexcept override { return "fake"; }
  uint16_t model_number() const noexcept override { return 0; }

  void handle(const dynamixel::InstructionPacket& packet, dynamixel::Response& response) noexcept override {
    ++handled;
    if (log != nullptr) log->push_back('h');
    if (!packet.checksum_ok) return;
    if (packet.instruction == dynamixel::instruction::kPing && packet.id == id_) {
      answer(response, ping_status_);
    } else if (packet.instruction == dynamixel::instruction::kBulkRead && !bulk_status_.empty()) {
      // Blocks of [length, ID, address] after the leading 0x00 (reference §1.2).
      for (uint16_t block = 0; 1 + 3 * block + 2 < packet.param_count; ++block) {
        if (packet.params[1 + 3 * block + 1] != id_) continue;
        answer(response, bulk_status_);
        response.timing = block == 0 ? dynamixel::ReplyTiming::kAfterInstruction : dynamixel::ReplyTiming::kAfterPrevious;
        response.chain_position = block;
        break;
      }
    }
  }

  int handled = 0;
  std::string* log = nullptr;

 private:
  static void answer(dynamixel::Response& response, const Bytes& bytes) {
    response.transmits = true;
    response.status.size = static_cast<uint16_t>(bytes.size());
    std::copy(bytes.begin(), bytes.end(), response.status.bytes.begin());
  }

  uint8_t id_;
  Bytes ping_status_;
  Bytes bulk_status_;
  uint32_t baud_bps_;
  uint32_t return_delay_us_;
};

class RecordingSync final : public DeviceSync {
 public:
  void before_dispatch() noexcept override { log->push_back('b'); }
  void after_dispatch() noexcept override { log->push_back('a'); }
  std::string* log = nullptr;
};

// Opens the port and sets the line up as DynamixelSDK does (raw, VMIN = VTIME = 0, `speed`).
int open_sdk_client(const std::string& path, speed_t speed = B1000000) {
  const int fd = open_client(path);
  if (fd < 0) return fd;
  termios tio{};
  tio.c_cflag = CS8 | CLOCAL | CREAD;
  tio.c_iflag = IGNPAR;
  tio.c_cc[VMIN] = 0;
  tio.c_cc[VTIME] = 0;
  ::cfsetspeed(&tio, speed);
  ::tcflush(fd, TCIFLUSH);
  ::tcsetattr(fd, TCSANOW, &tio);
  return fd;
}

// Sends the reference PING from `client`, expects the reference status back, and returns the
// server's trace of that reply (nullopt when none came).
std::optional<ReplyTrace> ping_and_trace(ServedBus& bus, int client) {
  EXPECT_TRUE(write_all(client, kPing1));
  EXPECT_EQ(read_bytes(client, 6, 1s), kPing1Status);
  return bus.next_trace();
}

TEST(BusServer, AnswersPingWithReferenceBytes) {
  FakeDevice servo(1, kPing1Status, {});
  ServedBus sut(fast(), {&servo});
  const ClientFd client(open_sdk_client(sut.path()));
  ASSERT_GE(client, 0);

  ASSERT_TRUE(write_all(client, kPing1));
  const Bytes reply = read_bytes(client, 6, 1s);

  EXPECT_EQ(reply, kPing1Status);
  EXPECT_TRUE(sut.eventually([](const BusDiagnostics& d) { return d.packets == 1 && d.bytes_out == 6; }));
  const BusDiagnostics d = sut.server().diagnostics();
  EXPECT_EQ(d.bytes_in, 6u);
  EXPECT_EQ(d.replies, 1u);
  EXPECT_EQ(d.line_baud_bps, 1'000'000u);
  EXPECT_TRUE(d.connected);
}

TEST(BusServer, WireModeAnswersAtModelTimeNeverEarly) {
  FakeDevice servo(1, kPing1Status, {}, 57'600, 500);
  BusServerOptions options;  // wire mode, 50 µs processing
  options.record_traces = true;
  ServedBus sut(options, {&servo});
  const ClientFd client(open_sdk_client(sut.path(), B57600));
  ASSERT_GE(client, 0);

  const std::optional<ReplyTrace> traced = ping_and_trace(sut, client);

  ASSERT_TRUE(traced);
  const ReplyTrace& trace = *traced;
  // 50 µs processing + 500 µs RDT, then 6 bytes × 173.6 µs (reference §1.6, §4.1).
  EXPECT_EQ(trace.status_end_ns - trace.instruction_end_ns, 50'000 + 500'000 + wire_duration_ns(6, 57'600));
  EXPECT_EQ(trace.due_ns, trace.status_end_ns);  // no adapter
  EXPECT_GE(trace.instruction_end_ns, trace.seen_ns);
  EXPECT_GE(trace.written_ns, trace.due_ns);
  EXPECT_EQ(trace.bytes, 6u);
  EXPECT_EQ(trace.line_baud_bps, 57'600u);
  // The delivery is counted in the lateness histogram, in the bin of its written - due time; the
  // last bin also holds everything later than the histogram's range (a loaded machine).
  const BusDiagnostics diagnostics = sut.server().diagnostics();
  uint64_t counted = 0;
  for (uint64_t count : diagnostics.lateness_bins) counted += count;
  EXPECT_EQ(counted, 1u);
  const int64_t lateness_ns = trace.written_ns - trace.due_ns;
  const int64_t range_ns = static_cast<int64_t>(kLatenessBins) * kLatenessBinNs;
  EXPECT_EQ(lateness_quantile_ns(diagnostics, 1.0),
            std::min((lateness_ns / kLatenessBinNs + 1) * kLatenessBinNs, range_ns));
}

TEST(BusServer, WithoutASpinSlotItSleepsToTheDueTimeAndIsStillNeverEarly) {
  FakeDevice servo(1, kPing1Status, {}, 57'600, 500);
  SpinBudget no_spinning(0);
  BusServerOptions options;
  options.spin_budget = &no_spinning;
  options.record_traces = true;
  ServedBus sut(options, {&servo});
  const ClientFd client(open_sdk_client(sut.path(), B57600));
  ASSERT_GE(client, 0);

  const std::optional<ReplyTrace> traced = ping_and_trace(sut, client);

  ASSERT_TRUE(traced);
  const ReplyTrace& trace = *traced;
  EXPECT_GE(trace.written_ns, trace.due_ns);
}

TEST(BusServer, AdapterLatencyHoldsReplyUntilATimerExpiry) {
  FakeDevice servo(1, kPing1Status, {});
  BusServerOptions options;
  options.adapter_latency_ms = 16;
  options.record_traces = true;
  ServedBus sut(options, {&servo});
  const ClientFd client(open_sdk_client(sut.path()));
  ASSERT_GE(client, 0);

  const std::optional<ReplyTrace> traced = ping_and_trace(sut, client);

  ASSERT_TRUE(traced);
  const ReplyTrace& trace = *traced;
  EXPECT_EQ(trace.due_ns % 16'000'000, 0);  // first timer restart: free-running ticks from t = 0
  EXPECT_GE(trace.due_ns, trace.status_end_ns);
  EXPECT_LT(trace.due_ns - trace.status_end_ns, 16'000'000);
  EXPECT_GE(trace.written_ns, trace.due_ns);
}

TEST(BusServer, BulkReadRepliesComeChainedInListOrder) {
  FakeDevice first(1, {}, kBulkStatus1);
  FakeDevice second(2, {}, kBulkStatus2);
  ServedBus sut(BusServerOptions{}, {&second, &first});  // added in the "wrong" order on purpose
  const ClientFd client(open_sdk_client(sut.path()));
  ASSERT_GE(client, 0);

  ASSERT_TRUE(write_all(client, kBulkRead));
  const Bytes replies = read_bytes(client, 16, 1s);

  Bytes expected = kBulkStatus1;
  expected.insert(expected.end(), kBulkStatus2.begin(), kBulkStatus2.end());
  EXPECT_EQ(replies, expected);
}

TEST(BusServer, DeviceAtAnotherBaudRateDoesNotAnswer) {
  FakeDevice servo(1, kPing1Status, {}, 1'000'000);
  ServedBus sut(fast(), {&servo});
  const ClientFd client(open_sdk_client(sut.path(), B57600));
  ASSERT_GE(client, 0);

  ASSERT_TRUE(write_all(client, kPing1));
  const bool framed = sut.eventually([](const BusDiagnostics& d) { return d.packets == 1; });
  const Bytes reply = read_bytes(client, 6, 100ms);

  EXPECT_TRUE(framed);
  EXPECT_TRUE(reply.empty());
  EXPECT_EQ(sut.server().diagnostics().replies, 0u);
}

TEST(BusServer, CountsBadChecksums) {
  FakeDevice servo(1, kPing1Status, {});
  ServedBus sut(fast(), {&servo});
  const ClientFd client(open_sdk_client(sut.path()));
  ASSERT_GE(client, 0);

  ASSERT_TRUE(write_all(client, kPing1BadChecksum));

  EXPECT_TRUE(sut.eventually([](const BusDiagnostics& d) { return d.packets == 1 && d.bad_checksums == 1; }));
}

TEST(BusServer, InterByteTimeoutDropsAStalledPacket) {
  FakeDevice servo(1, kPing1Status, {});
  ServedBus sut(fast(), {&servo});
  const ClientFd client(open_sdk_client(sut.path()));
  ASSERT_GE(client, 0);

  ASSERT_TRUE(write_all(client, {0xFF, 0xFF, 0x01, 0x04, 0x02}));  // READ, cut short
  ASSERT_TRUE(sut.eventually([](const BusDiagnostics& d) { return d.bytes_in == 5; }));
  std::this_thread::sleep_for(150ms);  // longer than the 100 ms byte-to-byte timeout
  ASSERT_TRUE(write_all(client, kPing1));
  const Bytes reply = read_bytes(client, 6, 1s);

  EXPECT_EQ(reply, kPing1Status);
  EXPECT_EQ(sut.server().diagnostics().timeouts, 1u);
}

TEST(BusServer, SyncHooksSurroundEveryDispatch) {
  std::string log;
  FakeDevice servo(1, kPing1Status, {});
  servo.log = &log;
  RecordingSync sync;
  sync.log = &log;
  Bytes replies;
  {
    ServedBus sut(fast(), {&servo}, &sync);
    const ClientFd client(open_sdk_client(sut.path()));
    ASSERT_GE(client, 0);
    Bytes two_pings = kPing1;
    two_pings.insert(two_pings.end(), kPing1.begin(), kPing1.end());
    ASSERT_TRUE(write_all(client, two_pings));
    replies = read_bytes(client, 12, 1s);
    ASSERT_TRUE(sut.eventually([](const BusDiagnostics& d) { return d.packets == 2; }));
  }  // joins the bus thread, so its writes to `log` are visible here

  EXPECT_EQ(replies.size(), 12u);
  EXPECT_EQ(log, "bhabha");
}

TEST(BusServer, NextClientStartsCleanAfterPreviousLeftWithoutReading) {
  FakeDevice servo(1, kPing1Status, {});
  BusServerOptions options;
  options.adapter_latency_ms = 255;  // the reply is still pending when the client leaves
  ServedBus sut(options, {&servo});
  ClientFd first(open_sdk_client(sut.path()));
  ASSERT_GE(first, 0);
  ASSERT_TRUE(write_all(first, kPing1));
  ASSERT_TRUE(sut.eventually([](const BusDiagnostics& d) { return d.replies == 1; }));
  first.close();
  ASSERT_TRUE(sut.eventually([](const BusDiagnostics& d) { return d.reconnects == 1 && !d.connected; }));

  const ClientFd second(open_sdk_client(sut.path()));
  ASSERT_GE(second, 0);
  // The first client's status is discarded when it falls due (255 ms after its PING, later on a
  // loaded machine: waited for, not assumed); the second client never reads it.
  EXPECT_TRUE(sut.eventually([](const BusDiagnostics& d) { return d.discarded_bytes == 6; }))
      << sut.server().diagnostics().discarded_bytes << " bytes discarded";
  const Bytes stale = read_bytes(second, 1, 300ms);
  EXPECT_TRUE(stale.empty());
}

TEST(BusServer, ClientKilledMidPacketDoesNotCorruptTheNextSession) {
  FakeDevice servo(1, kPing1Status, {});
  ServedBus sut(fast(), {&servo});
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    const int fd = open_sdk_client(sut.path());
    if (fd < 0 || !write_all(fd, {0xFF, 0xFF, 0x01, 0x04, 0x02})) ::_exit(1);
    ::pause();
    ::_exit(0);
  }
  ASSERT_TRUE(sut.eventually([](const BusDiagnostics& d) { return d.bytes_in == 5; }));
  ::kill(child, SIGKILL);
  ::waitpid(child, nullptr, 0);
  ASSERT_TRUE(sut.eventually([](const BusDiagnostics& d) { return d.reconnects == 1; }));

  const ClientFd next(open_sdk_client(sut.path()));
  ASSERT_GE(next, 0);
  ASSERT_TRUE(write_all(next, kPing1));  // at once: no 100 ms pause to save it
  const Bytes reply = read_bytes(next, 6, 1s);

  EXPECT_EQ(reply, kPing1Status);
  EXPECT_EQ(sut.server().diagnostics().timeouts, 0u);
  EXPECT_TRUE(sut.eventually([](const BusDiagnostics& d) { return d.connects == 2; }));
}

TEST(BusServer, ClientThatDoesNotReadLosesNoBytes) {
  FakeDevice servo(1, kPing1Status, {});
  ServedBus sut(fast(), {&servo});
  const ClientFd client(open_sdk_client(sut.path()));
  ASSERT_GE(client, 0);
  constexpr std::size_t kPings = 15'000;  // 90 kB of replies: more than the pty buffers hold
  Bytes pings;
  for (std::size_t i = 0; i < kPings; ++i) pings.insert(pings.end(), kPing1.begin(), kPing1.end());

  ASSERT_TRUE(write_all(client, pings));
  ASSERT_TRUE(sut.eventually([](const BusDiagnostics& d) { return d.packets == kPings; }));
  const Bytes replies = read_bytes(client, kPings * 6, 5s);

  ASSERT_EQ(replies.size(), kPings * 6);
  bool all_exact = true;
  for (std::size_t i = 0; i < kPings; ++i) {
    all_exact = all_exact && std::equal(kPing1Status.begin(), kPing1Status.end(), replies.begin() + 6 * i);
  }
  EXPECT_TRUE(all_exact);
  EXPECT_EQ(sut.server().diagnostics().dropped_replies, 0u);
}

TEST(BusServer, RejectsAdapterLatencyAbove255Ms) {
  TempDir dir;
  PtyPort port(dir.file("ttyDXL0"));
  dynamixel::BusDevices devices;
  BusServerOptions options;
  options.adapter_latency_ms = 256;

  EXPECT_THROW(BusServer(port, devices, options), std::invalid_argument);
}

TEST(BusServer, RejectsANegativeSlice) {
  TempDir dir;
  PtyPort port(dir.file("ttyDXL0"));
  dynamixel::BusDevices devices;
  BusServerOptions options;
  options.slice_ns = -1;

  EXPECT_THROW(BusServer(port, devices, options), std::invalid_argument);
}

// Records, on the bus thread, the slice the scheduler gives it (sched_getattr's sched_runtime).
class SliceProbe final : public DeviceSync {
 public:
  void before_dispatch() noexcept override {}
  void after_dispatch() noexcept override {}
  void on_tick() noexcept override {
    if (const std::optional<uint64_t> slice = thread_slice_ns()) slice_ns.store(*slice);
    ticks.fetch_add(1);
  }
  std::atomic<uint64_t> slice_ns{0};
  std::atomic<int> ticks{0};
};

// Linux 6.12 added custom slices for SCHED_OTHER threads (sched_attr::sched_runtime).
bool kernel_has_custom_slices() {
  utsname u{};
  int major = 0, minor = 0;
  return ::uname(&u) == 0 && std::sscanf(u.release, "%d.%d", &major, &minor) == 2 &&
         (major > 6 || (major == 6 && minor >= 12));
}

TEST(BusServer, ItsThreadAsksForTheSliceOfItsOptionsWhileItServes) {
  if (!kernel_has_custom_slices()) GTEST_SKIP() << "the kernel has no custom slices for SCHED_OTHER (Linux < 6.12)";
  SliceProbe probe;
  BusServerOptions options = fast();
  options.slice_ns = 300'000;  // not a default slice of any kernel
  {
    ServedBus sut(options, {}, &probe);
    ASSERT_TRUE(sut.eventually([&](const BusDiagnostics&) { return probe.ticks.load() > 0; }));
  }
  EXPECT_EQ(probe.slice_ns.load(), 300'000u);
}

TEST(BusServer, SliceZeroLeavesTheKernelsDefault) {
  if (!kernel_has_custom_slices()) GTEST_SKIP() << "the kernel has no custom slices for SCHED_OTHER (Linux < 6.12)";
  const std::optional<uint64_t> mine = thread_slice_ns();  // a new thread inherits this one's
  ASSERT_TRUE(mine.has_value());
  SliceProbe probe;
  BusServerOptions options = fast();
  options.slice_ns = 0;
  {
    ServedBus sut(options, {}, &probe);
    ASSERT_TRUE(sut.eventually([&](const BusDiagnostics&) { return probe.ticks.load() > 0; }));
  }
  EXPECT_EQ(probe.slice_ns.load(), *mine);
}

}  // namespace
}  // namespace doppel::bus

namespace doppel::bus {
namespace {

TEST(LatenessQuantile, IsTheUpperEdgeOfTheBinHoldingTheRank) {
  BusDiagnostics sut;
  EXPECT_EQ(lateness_quantile_ns(sut, 0.99), 0);
  sut.lateness_bins[0] = 98;  // 98 deliveries 0..10 µs late
  sut.lateness_bins[3] = 1;   // one 30..40 µs late
  sut.lateness_bins[kLatenessBins - 1] = 1;  // one a millisecond or more late
  EXPECT_EQ(lateness_quantile_ns(sut, 0.5), 10'000);
  EXPECT_EQ(lateness_quantile_ns(sut, 0.98), 10'000);
  EXPECT_EQ(lateness_quantile_ns(sut, 0.99), 40'000);
  EXPECT_EQ(lateness_quantile_ns(sut, 1.0), static_cast<int64_t>(kLatenessBins) * kLatenessBinNs);
}

}  // namespace
}  // namespace doppel::bus
