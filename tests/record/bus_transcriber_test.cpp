#include "record/bus_transcriber.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <chrono>
#include <thread>
#include <vector>

#include "bother_line.h"
#include "bus/bus_server.h"
#include "bus/wire_timing.h"
#include "dynamixel/model_registry.h"
#include "dynamixel/protocol1.h"
#include "dynamixel/protocol1_servo.h"
#include "../bus/served_bus.h"

namespace doppel::record {
namespace {

using namespace std::chrono_literals;
using bus::TapEvent;
using bus::TapEventKind;
using bus::testing::ClientFd;
using bus::testing::ServedBus;
using Bytes = std::vector<uint8_t>;

Bytes p1(uint8_t id, uint8_t instruction, Bytes params) {
  Bytes out(params.size() + 6);
  out.resize(dynamixel::encode_protocol1_instruction(id, instruction, params.data(), params.size(), out.data(), out.size()));
  return out;
}

std::string str(const Bytes& b) { return std::string(b.begin(), b.end()); }

// Opens the port as a driver does, at `baud_bps`.
int open_client(const std::string& path, uint32_t baud_bps) {
  const int fd = bus::testing::open_client(path);
  if (fd < 0) return fd;
  if (doppel::testing::set_bother_line(fd, baud_bps) != nullptr) {
    ::close(fd);
    return -1;
  }
  return fd;
}

struct Collected {
  std::vector<recording::BusTransaction> transactions;
  std::vector<recording::BusNoise> noise;
  std::vector<recording::BusEvent> events;
  TranscriptSink sink() {
    return {[this](const recording::BusTransaction& t) { transactions.push_back(t); },
            [this](const recording::BusNoise& n) { noise.push_back(n); },
            [this](const recording::BusEvent& e) { events.push_back(e); }};
  }
};

void drain(bus::TrafficTap& tap, BusTranscriber& transcriber) {
  TapEvent event;
  std::vector<uint8_t> payload;
  while (tap.pop(event, payload)) transcriber.feed(event, payload);
}

// A driver's session on a served bus at 1 Mbps in wire mode, recorded through the tap: every
// instruction comes back as a transaction with the driver's own bytes and the bus' own answers,
// in order, and the times follow the wire model (10 bit times per byte, 50 µs firmware time).
TEST(BusTranscriber, RecordsADriversSessionByteExactWithWireTimes) {
  dynamixel::Protocol1Servo servo(dynamixel::model_spec("MX-28"), 1, 1, 0);  // 1 Mbps, Return Delay Time 0
  bus::TrafficTap tap(1 << 20);
  bus::BusServerOptions options;
  options.tap = &tap;
  Collected got;
  BusTranscriber transcriber(0, 0, "ftdi", got.sink());
  const Bytes noise = {0x00, 0x42};
  const Bytes ping = p1(1, 0x01, {});
  const Bytes read = p1(1, 0x02, {36, 2});
  const Bytes read_missing = p1(7, 0x02, {36, 2});
  const Bytes sync_write = p1(0xFE, 0x83, {30, 2, 1, 0x00, 0x02});
  std::vector<Bytes> answers;
  {
    ServedBus sut(options, {&servo});
    {
      const ClientFd client(open_client(sut.path(), 1'000'000));
      ASSERT_GE(client, 0);
      Bytes first = noise;
      first.insert(first.end(), ping.begin(), ping.end());
      ASSERT_TRUE(bus::testing::write_all(client, first));
      answers.push_back(bus::testing::read_bytes(client, 6, 1s));
      ASSERT_TRUE(bus::testing::write_all(client, read));
      answers.push_back(bus::testing::read_bytes(client, 8, 1s));
      ASSERT_TRUE(bus::testing::write_all(client, read_missing));
      std::this_thread::sleep_for(20ms);  // a driver's timeout
      ASSERT_TRUE(bus::testing::write_all(client, sync_write));
      ASSERT_TRUE(sut.eventually([](const bus::BusDiagnostics& d) { return d.packets == 4; }));
    }
    ASSERT_TRUE(sut.eventually([](const bus::BusDiagnostics& d) { return d.reconnects == 1; }));
  }
  drain(tap, transcriber);
  transcriber.finish();
  EXPECT_EQ(tap.dropped(), 0u);

  ASSERT_EQ(got.transactions.size(), 4u);
  const std::vector<Bytes> sent = {ping, read, read_missing, sync_write};
  for (std::size_t i = 0; i < 4; ++i) {
    const recording::BusTransaction& t = got.transactions[i];
    SCOPED_TRACE(i);
    EXPECT_EQ(t.sequence(), i);
    EXPECT_EQ(t.instruction(), str(sent[i]));
    EXPECT_TRUE(t.checksum_ok());
    EXPECT_EQ(t.protocol(), 1u);
    EXPECT_EQ(t.baud_bps(), 1'000'000u);
    // The instruction's bytes on the wire: 10 µs each at 1 Mbps.
    EXPECT_EQ(t.instruction_end_ns() - t.instruction_start_ns(), bus::wire_duration_ns(sent[i].size(), 1'000'000));
    EXPECT_LE(t.first_seen_ns(), t.seen_ns());
  }
  ASSERT_EQ(answers.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    const recording::BusTransaction& t = got.transactions[i];
    SCOPED_TRACE(i);
    ASSERT_EQ(t.statuses_size(), 1);
    EXPECT_EQ(t.statuses(0).id(), 1u);
    EXPECT_EQ(t.statuses(0).bytes(), str(answers[i]));
    // Firmware time (50 µs) plus Return Delay Time 0, then the status' bytes at 10 µs each.
    EXPECT_EQ(t.statuses(0).start_ns() - t.instruction_end_ns(), bus::WireTiming::kDefaultProcessingNs);
    EXPECT_EQ(t.statuses(0).end_ns() - t.statuses(0).start_ns(), bus::wire_duration_ns(answers[i].size(), 1'000'000));
    EXPECT_EQ(t.due_ns(), t.statuses(0).end_ns());  // no adapter latency timer
    EXPECT_GE(t.written_ns(), t.seen_ns());
    EXPECT_FALSE(t.reply_dropped());
  }
  EXPECT_EQ(got.transactions[2].statuses_size(), 0);  // nobody answers ID 7
  EXPECT_EQ(got.transactions[2].written_ns(), 0);
  EXPECT_EQ(got.transactions[3].statuses_size(), 0);  // broadcast: no status
  ASSERT_EQ(got.noise.size(), 1u);
  EXPECT_EQ(got.noise[0].bytes(), str(noise));
  EXPECT_EQ(got.noise[0].reason(), "unframed");
  ASSERT_EQ(got.events.size(), 2u);
  EXPECT_EQ(got.events[0].event(), "connect");
  EXPECT_EQ(got.events[1].event(), "hang_up");
}

TapEvent input(uint64_t offset, int64_t seen_ns) {
  TapEvent e;
  e.kind = TapEventKind::kInput;
  e.sequence = offset;
  e.t0_ns = e.t1_ns = seen_ns;
  return e;
}

TapEvent instruction(uint64_t sequence, uint64_t stream_end, uint32_t wire_bytes) {
  TapEvent e;
  e.kind = TapEventKind::kInstruction;
  e.protocol = 1;
  e.checksum_ok = true;
  e.sequence = sequence;
  e.stream_end = stream_end;
  e.value = wire_bytes;
  return e;
}

TapEvent of(TapEventKind kind, uint64_t sequence, int64_t t0_ns = 0) {
  TapEvent e;
  e.kind = kind;
  e.sequence = sequence;
  e.t0_ns = t0_ns;
  return e;
}

// Replies leave in order: a delivery completes every older transaction still waiting for its own
// (lost) delivery event, and transactions come out in sequence order.
TEST(BusTranscriber, ADeliveryCompletesOlderRepliesWhoseEventWasLost) {
  Collected got;
  BusTranscriber t(0, 0, "ftdi", got.sink());
  const Bytes ping = p1(1, 0x01, {});
  Bytes two = ping;
  two.insert(two.end(), ping.begin(), ping.end());
  t.feed(input(0, 100), two);
  t.feed(instruction(0, 6, 6), {});
  t.feed(of(TapEventKind::kStatus, 0, 200), Bytes{0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC});
  t.feed(of(TapEventKind::kReply, 0, 300), {});
  t.feed(instruction(1, 12, 6), {});
  t.feed(of(TapEventKind::kStatus, 1, 400), Bytes{0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC});
  t.feed(of(TapEventKind::kReply, 1, 500), {});
  EXPECT_TRUE(got.transactions.empty());  // both wait for their delivery
  t.feed(of(TapEventKind::kDelivered, 1, 600), {});
  ASSERT_EQ(got.transactions.size(), 2u);
  EXPECT_EQ(got.transactions[0].sequence(), 0u);
  EXPECT_EQ(got.transactions[0].written_ns(), 0);  // its event was lost
  EXPECT_EQ(got.transactions[1].written_ns(), 600);
  EXPECT_EQ(got.transactions[1].instruction(), str(ping));
}

// A hang-up discards undelivered replies and turns a partial packet into noise; an inter-byte
// timeout does the same to the bytes it dropped; lost input (a stream gap) is not framed across.
TEST(BusTranscriber, HangUpTimeoutAndGapsAreAccountedFor) {
  Collected got;
  BusTranscriber t(2, 3, "ftdi", got.sink());
  const Bytes ping = p1(1, 0x01, {});
  t.feed(input(0, 10), ping);
  t.feed(instruction(0, 6, 6), {});
  t.feed(of(TapEventKind::kStatus, 0, 20), Bytes{0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC});
  t.feed(of(TapEventKind::kReply, 0, 30), {});
  t.feed(input(6, 40), Bytes{0xFF, 0xFF, 0x01});
  t.feed(of(TapEventKind::kTimeout, 0, 50), {});
  t.feed(input(9, 60), Bytes{0xFF, 0xFF});
  t.feed(input(20, 70), Bytes{0x33});  // 9 bytes lost to a full tap
  t.feed(of(TapEventKind::kHangUp, 0, 80), {});
  ASSERT_EQ(got.transactions.size(), 1u);
  EXPECT_TRUE(got.transactions[0].reply_dropped());
  EXPECT_EQ(got.transactions[0].robot(), 2u);
  EXPECT_EQ(got.transactions[0].bus(), 3u);
  ASSERT_EQ(got.noise.size(), 3u);
  EXPECT_EQ(got.noise[0].reason(), "timeout");
  EXPECT_EQ(got.noise[0].bytes(), str({0xFF, 0xFF, 0x01}));
  EXPECT_EQ(got.noise[1].reason(), "gap");
  EXPECT_EQ(got.noise[1].bytes(), str({0xFF, 0xFF}));
  EXPECT_EQ(got.noise[2].reason(), "hang_up");
  EXPECT_EQ(got.noise[2].bytes(), str({0x33}));
}

// A client that never reads keeps replies waiting forever: the transcriber writes them out
// without a delivery beyond kMaxWaiting rather than growing.
TEST(BusTranscriber, WaitingIsBounded) {
  Collected got;
  BusTranscriber t(0, 0, "ftdi", got.sink());
  const Bytes ping = p1(1, 0x01, {});
  for (uint64_t i = 0; i < BusTranscriber::kMaxWaiting + 10; ++i) {
    t.feed(input(i * 6, 0), ping);
    t.feed(instruction(i, (i + 1) * 6, 6), {});
    t.feed(of(TapEventKind::kReply, i, 1), {});
  }
  EXPECT_GE(got.transactions.size(), 9u);
  EXPECT_LE(got.transactions.size(), 11u);
  t.finish();
  EXPECT_EQ(got.transactions.size(), BusTranscriber::kMaxWaiting + 10);
}

}  // namespace
}  // namespace doppel::record
