#include "analyzer/analysis.h"

#include <gtest/gtest.h>

#include <algorithm>

#include "transaction_builder.h"

namespace doppel::analyzer {
namespace {

using testing::Bytes;
using testing::p1_instruction;
using testing::p1_status;
using testing::p2_instruction;
using testing::p2_status;
using testing::StatusSpec;
using testing::TransactionBuilder;

const KindStats& kind(const Analysis& a, const std::string& name) {
  const auto it = std::find_if(a.kinds.begin(), a.kinds.end(), [&](const KindStats& k) { return k.kind == name; });
  EXPECT_NE(it, a.kinds.end()) << name;
  return *it;
}

TEST(AnalysisTest, SummarizeUsesNearestRankPercentiles) {
  std::vector<double> values;
  for (int i = 100; i >= 1; --i) values.push_back(i);
  const Distribution d = summarize(values);
  EXPECT_EQ(d.count, 100u);
  EXPECT_DOUBLE_EQ(d.mean_ns, 50.5);
  EXPECT_DOUBLE_EQ(d.p50_ns, 50.0);
  EXPECT_DOUBLE_EQ(d.p99_ns, 99.0);
  EXPECT_DOUBLE_EQ(d.min_ns, 1.0);
  EXPECT_DOUBLE_EQ(d.max_ns, 100.0);
  EXPECT_EQ(summarize({}).count, 0u);
}

// A P1 READ of 2 bytes at 1 Mbps, the driver writing 30 us before the packet is on the wire:
// READ 8 B = 80 us, 50 us firmware + 250 us RDT, status 8 B = 80 us, 900 us in the adapter, 40 us late.
TEST(AnalysisTest, TimeSplitOfHandComputedTransactions) {
  std::vector<recording::BusTransaction> list;
  recording::BusTransaction t;
  t.set_bus(0);
  t.set_protocol(1);
  const Bytes read = p1_instruction(3, 0x02, {36, 2});
  const Bytes status = p1_status(3, {0x00, 0x02});
  t.set_instruction(std::string(read.begin(), read.end()));
  t.set_checksum_ok(true);
  t.set_baud_bps(1'000'000);
  t.set_first_seen_ns(1'000'000);
  t.set_seen_ns(1'000'000);
  t.set_instruction_start_ns(1'030'000);
  t.set_instruction_end_ns(1'110'000);
  auto* s = t.add_statuses();
  s->set_id(3);
  s->set_bytes(std::string(status.begin(), status.end()));
  s->set_start_ns(1'410'000);
  s->set_end_ns(1'490'000);
  s->set_return_delay_us(250);
  t.set_due_ns(2'390'000);
  t.set_written_ns(2'430'000);
  list.push_back(t);

  const Analysis a = analyze(recording::RunInfo(), list, 0);
  const KindStats& k = kind(a, "P1 READ");
  EXPECT_EQ(k.count, 1u);
  EXPECT_EQ(k.answered, 1u);
  EXPECT_DOUBLE_EQ(k.host_write.mean_ns, 110'000.0);
  EXPECT_DOUBLE_EQ(k.return_delay.mean_ns, 300'000.0);
  EXPECT_DOUBLE_EQ(k.status_wire.mean_ns, 80'000.0);
  EXPECT_DOUBLE_EQ(k.status_gaps.mean_ns, 0.0);
  EXPECT_DOUBLE_EQ(k.adapter.mean_ns, 900'000.0);
  EXPECT_DOUBLE_EQ(k.lateness.mean_ns, 40'000.0);
  EXPECT_DOUBLE_EQ(k.total.mean_ns, 1'430'000.0);
  EXPECT_EQ(k.timeouts, 0u);
  // Busy 160 us of the 460 us from the READ's first byte to the status' last.
  ASSERT_EQ(a.buses.size(), 1u);
  EXPECT_EQ(a.buses[0].busy_ns, 160'000);
  EXPECT_EQ(a.buses[0].span_ns, 460'000);
  EXPECT_NEAR(a.buses[0].utilisation, 160.0 / 460.0, 1e-12);
}

// A chained SYNC READ of 3 servos at 1 Mbps (P2, 2 data bytes: 13 B statuses = 130 us): the
// gaps between its statuses are the firmware time + RDT of the 2nd and 3rd servo.
TEST(AnalysisTest, StatusGapsHoldTheLaterDevicesDelays) {
  TransactionBuilder builder(0, 2, 1'000'000, 50'000);
  builder.add(0, p2_instruction(0xFE, 0x82, {132, 0, 2, 0, 1, 2, 3}),
              {{1, p2_status(1, {0, 0}), 10}, {2, p2_status(2, {0, 0}), 20}, {3, p2_status(3, {0, 0}), 30}}, true);
  const Analysis a = analyze(recording::RunInfo(), builder.transactions(), 0);
  const KindStats& k = kind(a, "P2 SYNC READ");
  EXPECT_EQ(k.statuses, 3u);
  EXPECT_DOUBLE_EQ(k.return_delay.mean_ns, 60'000.0);
  EXPECT_DOUBLE_EQ(k.status_wire.mean_ns, 3 * 130'000.0);
  EXPECT_DOUBLE_EQ(k.status_gaps.mean_ns, 70'000.0 + 80'000.0);
}

// Start-up (a PING and a table READ for each of 6 servos, a torque-on WRITE each), then a 10 ms
// loop: SYNC WRITE, SYNC READ, READ of the IMU, with a deterministic +-300 us jitter on the start.
std::vector<recording::BusTransaction> loop_with_startup(int cycles, std::vector<int64_t>& starts) {
  TransactionBuilder builder(0, 2, 1'000'000, 0);
  int64_t t = 0;
  for (uint8_t id = 1; id <= 6; ++id) {
    builder.add(t, p2_instruction(id, 0x01, {}), {{id, p2_status(id, {0x06, 0x04, 0x26}), 0}});
    t = builder.last_done_ns() + 20'000;
    builder.add(t, p2_instruction(id, 0x02, {0, 0, 64, 0}), {{id, p2_status(id, Bytes(64, 1)), 0}});
    t = builder.last_done_ns() + 20'000;
    builder.add(t, p2_instruction(id, 0x03, {64, 0, 1}), {{id, p2_status(id, {}), 0}});
    t = builder.last_done_ns() + 20'000;
  }
  Bytes write{116, 0, 4, 0};
  Bytes read{132, 0, 4, 0};
  std::vector<StatusSpec> statuses;
  for (uint8_t id = 1; id <= 6; ++id) {
    write.insert(write.end(), {id, 0, 8, 0, 0});
    read.push_back(id);
    statuses.push_back({id, p2_status(id, {0, 8, 0, 0}), 0});
  }
  const int64_t loop_start = 20'000'000;
  int jitter = 7;
  for (int c = 0; c < cycles; ++c) {
    jitter = (jitter * 37 + 11) % 61;  // 0..60
    const int64_t start = loop_start + c * 10'000'000 + (jitter - 30) * 10'000;
    starts.push_back(start);
    builder.add(start, p2_instruction(0xFE, 0x83, write), {});
    builder.add(start + 5'000, p2_instruction(0xFE, 0x82, read), statuses, true);
    builder.add(builder.last_done_ns() + 10'000, p2_instruction(200, 0x02, {34, 0, 12, 0}),
                {{200, p2_status(200, Bytes(12, 3)), 0}});
  }
  return builder.transactions();
}

TEST(AnalysisTest, CycleFoundAfterStartUpWithJitter) {
  std::vector<int64_t> starts;
  const auto list = loop_with_startup(200, starts);
  const Analysis a = analyze(recording::RunInfo(), list, 0);
  ASSERT_TRUE(a.cycle.found);
  EXPECT_EQ(a.cycle.opener_kind, "P2 SYNC WRITE");
  EXPECT_EQ(a.cycle.cycles, 200u);
  EXPECT_EQ(a.cycle.startup_transactions, 18u);
  EXPECT_EQ(a.cycle.starts_ns, starts);
  std::vector<double> periods;
  for (std::size_t i = 1; i < starts.size(); ++i) periods.push_back(static_cast<double>(starts[i] - starts[i - 1]));
  const Distribution expected = summarize(periods);
  EXPECT_NEAR(a.cycle.period.mean_ns, 10e6, 10e6 * 0.001);
  EXPECT_DOUBLE_EQ(a.cycle.period.p50_ns, expected.p50_ns);
  EXPECT_DOUBLE_EQ(a.cycle.period.max_ns, expected.max_ns);
  EXPECT_GT(a.cycle.period.stddev_ns, 100'000.0);  // jitter of up to +-300 us on each start
  EXPECT_LE(a.cycle.period.max_ns, 10.6e6);
  EXPECT_NEAR(a.cycle.rate_hz, 100.0, 0.1);
}

// A flat-out loop (no sleep) reading the IMU twice per cycle: the opener is the coarsest
// repetition, not the IMU read that is twice as frequent.
TEST(AnalysisTest, FlatOutLoopOpensWithItsCoarsestRepetition) {
  TransactionBuilder builder(0, 1, 1'000'000, 50'000);
  const Bytes sync_write = p1_instruction(0xFE, 0x83, {30, 2, 1, 0, 2, 2, 0, 2});
  const Bytes imu = p1_instruction(200, 0x02, {36, 6});
  const Bytes read = p1_instruction(1, 0x02, {36, 2});
  int64_t t = 0;
  for (int c = 0; c < 50; ++c) {
    builder.add(t, sync_write, {});
    builder.add(t + 10'000, imu, {{200, p1_status(200, Bytes(6, 1)), 0}});
    builder.add(builder.last_done_ns() + 10'000, read, {{1, p1_status(1, {0, 2}), 0}});
    builder.add(builder.last_done_ns() + 10'000, imu, {{200, p1_status(200, Bytes(6, 1)), 0}});
    t = builder.last_done_ns() + 10'000;
  }
  const Analysis a = analyze(recording::RunInfo(), builder.transactions(), 0);
  ASSERT_TRUE(a.cycle.found);
  EXPECT_EQ(a.cycle.cycles, 50u);
  EXPECT_EQ(a.cycle.opener_kind, "P1 SYNC WRITE");
}

TEST(AnalysisTest, TooFewRepetitionsIsNoCycle) {
  TransactionBuilder builder(0, 1, 1'000'000, 50'000);
  builder.add(0, p1_instruction(1, 0x01, {}), {{1, p1_status(1, {}), 0}});
  builder.add(1'000'000, p1_instruction(1, 0x01, {}), {{1, p1_status(1, {}), 0}});
  const Analysis a = analyze(recording::RunInfo(), builder.transactions(), 0);
  EXPECT_FALSE(a.cycle.found);
}

// A READ to a missing ID 9 sent three times (two retries), a SYNC READ where ID 3 stays silent,
// a WRITE without status to a servo that answers WRITEs, and one to a servo that never does
// (Status Return Level 1: not a timeout).
TEST(AnalysisTest, TimeoutsAndRetries) {
  TransactionBuilder builder(0, 1, 1'000'000, 50'000);
  const Bytes missing = p1_instruction(9, 0x02, {36, 2});
  int64_t t = 0;
  for (int attempt = 0; attempt < 3; ++attempt) {
    builder.add(t, missing, {});
    t = builder.transactions().back().instruction_end_ns() + 16'000'000;
  }
  builder.add(t, p1_instruction(1, 0x02, {36, 2}), {{1, p1_status(1, {0, 2}), 0}});
  t = builder.last_done_ns() + 10'000;
  TransactionBuilder p2(1, 2, 1'000'000, 50'000);
  p2.add(t, p2_instruction(0xFE, 0x82, {132, 0, 4, 0, 1, 2, 3}),
         {{1, p2_status(1, {0, 0, 0, 0}), 0}, {2, p2_status(2, {0, 0, 0, 0}), 0}}, true);
  t = p2.last_done_ns() + 10'000;
  p2.add(t, p2_instruction(1, 0x03, {116, 0, 0, 8, 0, 0}), {{1, p2_status(1, {}), 0}});
  t = p2.last_done_ns() + 10'000;
  p2.add(t, p2_instruction(1, 0x03, {116, 0, 0, 8, 0, 0}), {});
  t = p2.transactions().back().instruction_end_ns() + 5'000'000;
  p2.add(t, p2_instruction(2, 0x03, {116, 0, 0, 8, 0, 0}), {});
  t = p2.transactions().back().instruction_end_ns() + 10'000;
  p2.add(t, p2_instruction(2, 0x02, {132, 0, 4, 0}), {{2, p2_status(2, {0, 0, 0, 0}), 0}});

  std::vector<recording::BusTransaction> list = builder.transactions();
  for (auto& x : p2.transactions()) list.push_back(x);
  const Analysis a = analyze(recording::RunInfo(), list, 0);

  ASSERT_EQ(a.timeouts.size(), 5u);
  EXPECT_EQ(a.retries, 2u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(a.timeouts[static_cast<std::size_t>(i)].kind, "P1 READ");
    EXPECT_EQ(a.timeouts[static_cast<std::size_t>(i)].missing_ids, std::vector<uint8_t>{9});
    EXPECT_EQ(a.timeouts[static_cast<std::size_t>(i)].wait_ns, 16'000'000);
  }
  EXPECT_TRUE(a.timeouts[0].retried);
  EXPECT_TRUE(a.timeouts[1].retried);
  EXPECT_FALSE(a.timeouts[2].retried);
  EXPECT_EQ(a.timeouts[3].kind, "P2 SYNC READ");
  EXPECT_EQ(a.timeouts[3].missing_ids, std::vector<uint8_t>{3});
  EXPECT_EQ(a.timeouts[4].kind, "P2 WRITE");
  EXPECT_EQ(a.timeouts[4].missing_ids, std::vector<uint8_t>{1});
  EXPECT_EQ(a.timeouts[4].wait_ns, 5'000'000);
  EXPECT_EQ(kind(a, "P1 READ").timeouts, 3u);
  EXPECT_EQ(kind(a, "P1 READ").retries, 2u);
  ASSERT_EQ(a.buses.size(), 2u);
  EXPECT_EQ(a.buses[0].timeouts, 3u);
  EXPECT_EQ(a.buses[0].timeout_wait.count, 3u);
  EXPECT_EQ(a.buses[1].timeouts, 2u);
}

TEST(AnalysisTest, SequenceGapsAndDroppedRepliesAreCounted) {
  TransactionBuilder builder(0, 1, 1'000'000, 50'000);
  for (int i = 0; i < 4; ++i) builder.add(i * 1'000'000, p1_instruction(1, 0x01, {}), {{1, p1_status(1, {}), 0}});
  auto list = builder.transactions();
  list[2].set_sequence(7);  // 4 lost
  list[3].set_sequence(8);
  list[3].set_reply_dropped(true);
  const Analysis a = analyze(recording::RunInfo(), list, 0);
  EXPECT_EQ(a.buses[0].missing_transactions, 5u);
  EXPECT_EQ(a.buses[0].dropped_replies, 1u);
}

TEST(AnalysisTest, SeveralBusesHaveTheirOwnAndACombinedCycle) {
  std::vector<recording::BusTransaction> list;
  for (uint32_t bus = 0; bus < 2; ++bus) {
    TransactionBuilder builder(bus, 2, 4'000'000, 0);
    for (int c = 0; c < 20; ++c) {
      const int64_t t = c * 2'000'000 + bus * 1000;
      builder.add(t, p2_instruction(0xFE, 0x82, {132, 0, 4, 0, static_cast<uint8_t>(1 + bus)}),
                  {{static_cast<uint8_t>(1 + bus), p2_status(static_cast<uint8_t>(1 + bus), {0, 0, 0, 0}), 0}});
    }
    for (auto& x : builder.transactions()) list.push_back(x);
  }
  const Analysis a = analyze(recording::RunInfo(), list, 0);
  ASSERT_EQ(a.buses.size(), 2u);
  EXPECT_EQ(a.buses[1].cycle.cycles, 20u);
  EXPECT_NEAR(a.buses[1].cycle.rate_hz, 500.0, 1e-6);
  ASSERT_TRUE(a.cycle.found);
  EXPECT_EQ(a.cycle.cycles, 20u);
  EXPECT_NEAR(a.cycle.period.mean_ns, 2e6, 1.0);
}

}  // namespace
}  // namespace doppel::analyzer

namespace doppel::analyzer {
namespace {

// Recordings are input: transactions with garbage bytes, times out of order, empty or huge fields
// must give a report, never a crash or a hang.
TEST(AnalysisTest, GarbageTransactionsGiveAReport) {
  uint64_t state = 42;
  auto next = [&](uint64_t range) {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return range == 0 ? 0 : (state >> 33) % range;
  };
  std::vector<recording::BusTransaction> list;
  const Bytes templates[] = {p2_instruction(0xFE, 0x82, {132, 0, 4, 0, 1, 2, 3}), p1_instruction(0xFE, 0x92, {0, 2, 1, 36}),
                             p2_instruction(0xFE, 0x8A, {132, 0, 4, 0, 1, 2}), p1_instruction(0xFD, 0x84, {36, 2, 1, 2})};
  for (int i = 0; i < 3000; ++i) {
    recording::BusTransaction t;
    t.set_robot(static_cast<uint32_t>(next(2)));
    t.set_bus(static_cast<uint32_t>(next(3)));
    t.set_sequence(next(5000));
    t.set_protocol(static_cast<uint32_t>(next(4)));
    Bytes bytes = templates[next(4)];
    for (uint64_t k = next(4); k > 0; --k) bytes[next(bytes.size())] = static_cast<uint8_t>(next(256));
    if (next(5) == 0) bytes.resize(next(bytes.size() + 1));
    t.set_instruction(std::string(bytes.begin(), bytes.end()));
    t.set_checksum_ok(next(10) != 0);
    t.set_baud_bps(static_cast<uint32_t>(next(3) == 0 ? 0 : next(5'000'000)));
    t.set_first_seen_ns(static_cast<int64_t>(next(1'000'000'000)));
    t.set_seen_ns(static_cast<int64_t>(next(1'000'000'000)));
    t.set_instruction_start_ns(static_cast<int64_t>(next(1'000'000'000)));
    t.set_instruction_end_ns(static_cast<int64_t>(next(1'000'000'000)));
    for (uint64_t k = next(4); k > 0; --k) {
      auto* s = t.add_statuses();
      s->set_id(static_cast<uint32_t>(next(300)));
      s->set_bytes(std::string(next(40), '\xFF'));
      s->set_start_ns(static_cast<int64_t>(next(1'000'000'000)));
      s->set_end_ns(static_cast<int64_t>(next(1'000'000'000)));
      s->set_return_delay_us(static_cast<uint32_t>(next(100'000)));
    }
    t.set_due_ns(static_cast<int64_t>(next(1'000'000'000)));
    t.set_written_ns(static_cast<int64_t>(next(1'000'000'000)));
    t.set_adapter_latency_ms(static_cast<uint32_t>(next(400)));
    t.set_adapter(next(2) ? "usb2ax" : "ftdi");
    t.set_reply_dropped(next(10) == 0);
    list.push_back(t);
  }
  for (uint32_t robot = 0; robot < 2; ++robot) {
    const Analysis a = analyze(recording::RunInfo(), list, robot);
    EXPECT_GT(a.transactions, 0u);
    EXPECT_FALSE(a.kinds.empty());
  }
}

}  // namespace
}  // namespace doppel::analyzer
