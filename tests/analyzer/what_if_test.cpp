#include "analyzer/what_if.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <stdexcept>

#include "bitbots_cycle.h"
#include "transaction_builder.h"

namespace doppel::analyzer {
namespace {

using testing::BitBots;
using testing::bitbots;
using testing::Bytes;
using testing::p1_instruction;
using testing::p1_status;
using testing::p2_instruction;
using testing::p2_status;
using testing::StatusSpec;
using testing::TransactionBuilder;

WhatIf run_scenario(const BitBots& b, const std::string& text) {
  const Analysis analysis = analyze(b.run, b.transactions, 0);
  return what_if(b.run, b.transactions, analysis, parse_scenario(text));
}

TEST(WhatIfTest, BitBotsPacketsHaveTheReferenceByteCounts) {
  const BitBots b = bitbots(3);
  // Reference §2.4: a packet is LEN + 7 bytes; SYNC WRITE LEN = 3 + 4 + 20 * (1 + 4), SYNC READ
  // LEN = 3 + 4 + 20, a status with 10 data bytes LEN = 4 + 10.
  EXPECT_EQ(b.sync_write.size(), 114u);
  EXPECT_EQ(b.sync_read.size(), 34u);
  EXPECT_EQ(b.status_bytes, 21u);
}

// Hand derivation, as docs/benchmarks.md: one bus carries 114 + 34 + 20 * 21 = 568 bytes a
// cycle, 2.5 us each at 4 Mbps: 1420 us, 704 Hz; with 50 us firmware time per status 1420 +
// 1000 = 2420 us, 413 Hz. Four buses of 5 servos: SYNC WRITE LEN 3 + 4 + 25 = 32 (39 B), SYNC
// READ LEN 12 (19 B), 5 statuses of 21 B: 163 B = 407.5 us, 2454 Hz; + 250 us: 657.5 us, 1521 Hz.
TEST(WhatIfTest, BitBotsCycleOnOneBusMatchesTheWireModelRates) {
  const BitBots b = bitbots(50);
  const double byte_us = 10.0 / 4.0;
  const double one_bus_us = (114 + 34 + 20 * 21) * byte_us;
  ASSERT_DOUBLE_EQ(one_bus_us, 1420.0);

  const WhatIf wire = run_scenario(b, "fw=0");
  EXPECT_EQ(wire.cycles, 49u);
  EXPECT_NEAR(wire.rate_hz, 704.0, 704.0 * 0.02);
  EXPECT_NEAR(wire.cycle.mean_ns, one_bus_us * 1000.0, 1.0);

  const WhatIf firmware = run_scenario(b, "fw=50");
  EXPECT_NEAR(firmware.rate_hz, 413.0, 413.0 * 0.02);
  EXPECT_NEAR(firmware.cycle.mean_ns, (one_bus_us + 20 * 50.0) * 1000.0, 1.0);

  // The recording's own settings (50 us) are the same as fw=50.
  EXPECT_NEAR(run_scenario(b, "recorded").cycle.mean_ns, firmware.cycle.mean_ns, 1.0);
}

TEST(WhatIfTest, BitBotsCycleOnFourBusesMatchesTheWireModelRates) {
  const BitBots b = bitbots(50);
  const double four_bus_us = (39 + 19 + 5 * 21) * 2.5;
  ASSERT_DOUBLE_EQ(four_bus_us, 407.5);

  const WhatIf wire = run_scenario(b, "fw=0,buses=4");
  EXPECT_EQ(wire.buses, 4u);
  EXPECT_NEAR(wire.rate_hz, 2454.0, 2454.0 * 0.02);
  EXPECT_NEAR(wire.cycle.mean_ns, four_bus_us * 1000.0, 1.0);

  const WhatIf firmware = run_scenario(b, "fw=50,buses=4");
  EXPECT_NEAR(firmware.rate_hz, 1521.0, 1521.0 * 0.02);
  EXPECT_NEAR(firmware.cycle.mean_ns, (four_bus_us + 5 * 50.0) * 1000.0, 1.0);
}

TEST(WhatIfTest, UnevenSplitIsBoundByTheLargestGroup) {
  const BitBots b = bitbots(10);
  // 20 servos over 3 buses: groups of 6, 7, 7 (contiguous). The slowest bus has 7: SYNC WRITE
  // LEN 3 + 4 + 35 = 42 (49 B), SYNC READ LEN 14 (21 B), 7 statuses of 21 B: 217 B = 542.5 us.
  const WhatIf wire = run_scenario(b, "fw=0,buses=3");
  EXPECT_NEAR(wire.cycle.mean_ns, 542'500.0, 1.0);
}

// One P1 READ of 2 bytes at 1 Mbps per cycle: READ 8 B (80 us), status 8 B (80 us).
struct ReadLoop {
  recording::RunInfo run;
  std::vector<recording::BusTransaction> transactions;
};

ReadLoop read_loop(uint32_t rdt_us, uint32_t latency_ms, int cycles) {
  ReadLoop r;
  auto* info = r.run.add_buses();
  info->set_bus(0);
  info->set_processing_ns(50'000);
  info->set_adapter_latency_ms(latency_ms);
  info->set_adapter("ftdi");
  auto* d = info->add_devices();
  d->set_id(3);
  d->set_protocol(1);
  d->set_return_delay_us(rdt_us);
  TransactionBuilder builder(0, 1, 1'000'000, 50'000);
  const Bytes read = p1_instruction(3, 0x02, {36, 2});
  int64_t t = 0;
  for (int c = 0; c < cycles; ++c) {
    auto& tr = builder.add(t, read, {{3, p1_status(3, {0x00, 0x02}), rdt_us}});
    tr.set_adapter_latency_ms(latency_ms);
    t += 10'000'000;
  }
  r.transactions = builder.transactions();
  return r;
}

WhatIf run_scenario(const ReadLoop& r, const std::string& text) {
  const Analysis analysis = analyze(r.run, r.transactions, 0);
  return what_if(r.run, r.transactions, analysis, parse_scenario(text));
}

TEST(WhatIfTest, ReturnDelayTimeAndBaudRateChangeTheCycleAsTheWireModelSays) {
  const ReadLoop r = read_loop(500, 0, 20);
  // 80 us READ + 50 us firmware + 500 us RDT + 80 us status = 710 us.
  EXPECT_NEAR(run_scenario(r, "recorded").cycle.mean_ns, 710'000.0, 1.0);
  EXPECT_NEAR(run_scenario(r, "rdt=0").cycle.mean_ns, 210'000.0, 1.0);
  // At 500 kbps every byte takes twice as long: 160 + 50 + 0 + 160.
  EXPECT_NEAR(run_scenario(r, "rdt=0,baud=500000").cycle.mean_ns, 370'000.0, 1.0);
}

TEST(WhatIfTest, LatencyTimerHoldsShortRepliesUntilItsTick) {
  const ReadLoop r = read_loop(0, 16, 40);
  // A reply much shorter than 62 bytes waits for the timer's next tick: each cycle starts at a
  // tick and ends at the next one, so the cycle is the latency period (after the first).
  const WhatIf sixteen = run_scenario(r, "recorded");
  EXPECT_NEAR(sixteen.cycle.p50_ns, 16e6, 1.0);
  EXPECT_NEAR(run_scenario(r, "latency=1").cycle.p50_ns, 1e6, 1.0);
  EXPECT_NEAR(run_scenario(r, "latency=0").cycle.p50_ns, 210'000.0, 1.0);
}

TEST(WhatIfTest, RecordedTimeoutCostsItsRecordedWait) {
  ReadLoop r;
  r.run.add_buses()->set_processing_ns(50'000);
  TransactionBuilder builder(0, 1, 1'000'000, 50'000);
  const Bytes read = p1_instruction(3, 0x02, {36, 2});
  const Bytes missing = p1_instruction(9, 0x02, {36, 2});
  int64_t t = 0;
  for (int c = 0; c < 10; ++c) {
    builder.add(t, read, {{3, p1_status(3, {0x00, 0x02}), 0}});
    // ID 9 is missing: the driver waits 2 ms after the READ's last byte before going on.
    builder.add(builder.last_done_ns(), missing, {});
    t = builder.transactions().back().instruction_end_ns() + 2'000'000;
  }
  r.transactions = builder.transactions();
  // 210 us for ID 3, 80 us for the READ to ID 9, then the recorded 2 ms.
  EXPECT_NEAR(run_scenario(r, "recorded").cycle.mean_ns, 2'290'000.0, 1.0);
}

TEST(WhatIfTest, DriverTimeIsKeptOnlyWhenAsked) {
  ReadLoop r;
  r.run.add_buses()->set_processing_ns(50'000);
  TransactionBuilder builder(0, 1, 1'000'000, 50'000);
  int64_t t = 0;
  for (int c = 0; c < 10; ++c) {
    builder.add(t, p1_instruction(1, 0x02, {36, 2}), {{1, p1_status(1, {0x00, 0x02}), 0}});
    // The driver takes 100 us after the reply (the pty, its own code) before the next READ.
    builder.add(builder.last_done_ns() + 100'000, p1_instruction(2, 0x02, {36, 2}), {{2, p1_status(2, {0x00, 0x02}), 0}});
    t = builder.last_done_ns() + 3'000'000;
  }
  r.transactions = builder.transactions();
  // Each READ: 80 us + 50 us firmware + 80 us status = 210 us; the 3 ms sleep before the next
  // cycle is pacing, never driver time.
  EXPECT_NEAR(run_scenario(r, "recorded").cycle.mean_ns, 420'000.0, 1.0);
  EXPECT_NEAR(run_scenario(r, "driver=recorded").cycle.mean_ns, 520'000.0, 1.0);
}

// FAST SYNC READ of 4 servos, 4 B each, at 1 Mbps (10 us a byte): one combined status, the
// 8-byte header (FF FF FD 00 FE LEN LEN 55) in front of the first block, each block ERR ID data
// CRC = 8 B (reference §2.7). Instruction LEN 3 + 4 + 4 = 11 (18 B); status 8 + 4 * 8 = 40 B.
TEST(WhatIfTest, FastSyncReadSplitGivesEachBusItsOwnHeader) {
  ReadLoop r;
  auto* info = r.run.add_buses();
  info->set_processing_ns(0);
  TransactionBuilder builder(0, 2, 1'000'000, 0);
  const Bytes fast = p2_instruction(0xFE, 0x8A, {132, 0, 4, 0, 1, 2, 3, 4});
  ASSERT_EQ(fast.size(), 18u);
  std::vector<StatusSpec> blocks;
  for (uint8_t id = 1; id <= 4; ++id) {
    blocks.push_back({id, Bytes(id == 1 ? 16 : 8, 0x11), 0});
    info->add_devices()->set_id(id);
  }
  int64_t t = 0;
  for (int c = 0; c < 10; ++c) {
    builder.add(t, fast, blocks, true);
    t = builder.last_done_ns() + 1'000'000;
  }
  r.transactions = builder.transactions();
  EXPECT_NEAR(run_scenario(r, "recorded").cycle.mean_ns, (18 + 40) * 10'000.0, 1.0);
  // Two buses of 2: instruction LEN 3 + 4 + 2 = 9 (16 B), status 8 + 2 * 8 = 24 B.
  EXPECT_NEAR(run_scenario(r, "buses=2").cycle.mean_ns, (16 + 24) * 10'000.0, 1.0);
}

// A USB2AX SYNC READ (0x84) of 3 servos, 2 B each, at 1 Mbps: the host's packet FF FF FD LEN 84
// ADDR N ID ID ID CK (LEN 7, 11 B), then the adapter sends each servo a READ (8 B) and gets its
// answer (6 + 2 B), then hands its status to the host after its send timeout ((4 + 1) x 20 us).
TEST(WhatIfTest, Usb2axSyncReadIsReadServoByServo) {
  ReadLoop r;
  auto* info = r.run.add_buses();
  info->set_processing_ns(50'000);
  info->set_adapter("usb2ax");
  for (uint8_t id = 1; id <= 3; ++id) info->add_devices()->set_id(id);
  TransactionBuilder builder(0, 1, 1'000'000, 50'000);
  const Bytes sync_read = p1_instruction(0xFD, 0x84, {36, 2, 1, 2, 3});
  ASSERT_EQ(sync_read.size(), 11u);
  int64_t t = 0;
  for (int c = 0; c < 10; ++c) {
    auto& x = builder.add(t, sync_read, {{0xFD, p1_status(0xFD, Bytes(6, 0)), 0}});
    x.set_adapter("usb2ax");
    t = builder.last_done_ns() + 1'000'000;
  }
  r.transactions = builder.transactions();
  EXPECT_NEAR(run_scenario(r, "fw=0").cycle.mean_ns, 110'000.0 + 3 * (80'000.0 + 80'000.0) + 100'000.0, 1.0);
  EXPECT_NEAR(run_scenario(r, "fw=50").cycle.mean_ns, 110'000.0 + 3 * (80'000.0 + 50'000.0 + 80'000.0) + 100'000.0, 1.0);
}

TEST(WhatIfTest, ScenarioTextRoundTripsAndBadPartsAreNamed) {
  EXPECT_EQ(describe(parse_scenario("baud=3000000,rdt=0,latency=1,buses=4")), "baud=3000000,rdt=0,latency=1,buses=4");
  EXPECT_EQ(describe(parse_scenario("")), "recorded");
  EXPECT_EQ(describe(parse_scenario("adapter=usb2ax,fw=20")), "fw=20,adapter=usb2ax");
  EXPECT_EQ(describe(parse_scenario("driver=recorded")), "driver=recorded");
  EXPECT_THROW(parse_scenario("driver=fast"), std::invalid_argument);
  try {
    parse_scenario("baud=fast");
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("baud=fast"), std::string::npos) << e.what();
  }
  EXPECT_THROW(parse_scenario("buses=0"), std::invalid_argument);
  EXPECT_THROW(parse_scenario("colour=red"), std::invalid_argument);
  EXPECT_THROW(parse_scenario("latency=300"), std::invalid_argument);
  EXPECT_THROW(parse_scenario("rdt"), std::invalid_argument);
}

TEST(WhatIfTest, NoCycleNoSimulation) {
  const ReadLoop r = read_loop(0, 0, 2);
  const WhatIf result = run_scenario(r, "recorded");
  EXPECT_EQ(result.cycles, 0u);
  EXPECT_FALSE(result.note.empty());
}

}  // namespace
}  // namespace doppel::analyzer

namespace doppel::analyzer {
namespace {

// The Bit-Bots traffic with garbage in its recorded fields still gives a finite what-if.
TEST(WhatIfTest, GarbageFieldsGiveAFiniteAnswer) {
  BitBots b = bitbots(20);
  int k = 0;
  for (auto& t : b.transactions) {
    ++k;
    if (k % 3 == 0) t.set_baud_bps(0);
    if (k % 4 == 0) t.set_adapter_latency_ms(100'000);
    if (k % 5 == 0) t.set_instruction(t.instruction().substr(0, 9));
    for (auto& s : *t.mutable_statuses()) {
      if (k % 7 == 0) s.set_start_ns(-s.start_ns());
      if (k % 2 == 0) s.set_return_delay_us(4'000'000'000u);
    }
  }
  for (const char* s : {"recorded", "buses=4", "buses=64,driver=recorded", "adapter=usb2ax,buses=3", "latency=255,baud=9600"}) {
    const Analysis analysis = analyze(b.run, b.transactions, 0);
    const WhatIf result = what_if(b.run, b.transactions, analysis, parse_scenario(s));
    EXPECT_TRUE(std::isfinite(result.rate_hz)) << s;
  }
}

}  // namespace
}  // namespace doppel::analyzer

namespace doppel::analyzer {
namespace {

// The Bit-Bots cycle as p2_bitbots_cycle --buses 4 runs it: one client thread per bus, released
// together by a barrier every 2 ms, starting in a different order each cycle. The combined cycle
// and the what-if must not depend on which thread went first.
TEST(WhatIfTest, FourBusThreadsInChangingOrder) {
  recording::RunInfo run;
  std::vector<recording::BusTransaction> list;
  std::vector<TransactionBuilder> builders;
  std::vector<Bytes> writes(4), reads(4);
  std::vector<std::vector<StatusSpec>> statuses(4);
  for (uint32_t bus = 0; bus < 4; ++bus) {
    auto* info = run.add_buses();
    info->set_bus(bus);
    info->set_processing_ns(0);
    builders.emplace_back(bus, 2, testing::kFourMbps, 0);
    writes[bus] = {116, 0, 4, 0};
    reads[bus] = {126, 0, 10, 0};
    for (uint8_t k = 1; k <= 5; ++k) {
      const auto id = static_cast<uint8_t>(bus * 5 + k);
      info->add_devices()->set_id(id);
      writes[bus].insert(writes[bus].end(), {id, 0, 8, 0, 0});
      reads[bus].push_back(id);
      statuses[bus].push_back({id, p2_status(id, {1, 0, 2, 0, 0, 0, 0x10, 0x08, 0, 0}), 0});
    }
  }
  uint32_t noise = 99;
  constexpr int kCycles = 200;
  for (int c = 0; c < kCycles; ++c) {
    std::array<uint32_t, 4> order{0, 1, 2, 3};
    for (std::size_t i = 3; i > 0; --i) {
      noise = noise * 1103515245u + 12345u;
      std::swap(order[i], order[(noise >> 8) % (i + 1)]);
    }
    const int64_t release = 1'000'000 + int64_t{c} * 2'000'000;
    for (std::size_t rank = 0; rank < 4; ++rank) {
      TransactionBuilder& b = builders[order[rank]];
      const int64_t t = release + static_cast<int64_t>(rank) * 15'000;
      b.add(t, p2_instruction(0xFE, 0x83, writes[order[rank]]), {});
      b.add(t + 2'000, p2_instruction(0xFE, 0x82, reads[order[rank]]), statuses[order[rank]], true);
    }
  }
  for (auto& b : builders) {
    for (auto& t : b.transactions()) list.push_back(t);
  }
  const Analysis analysis = analyze(run, list, 0);
  ASSERT_TRUE(analysis.cycle.found);
  EXPECT_EQ(analysis.cycle.cycles, static_cast<uint64_t>(kCycles));
  // Every cycle starts when the first thread writes, exactly at each 2 ms release.
  EXPECT_EQ(analysis.cycle.first_start_ns, 1'000'000);
  EXPECT_DOUBLE_EQ(analysis.cycle.period.min_ns, 2e6);
  EXPECT_DOUBLE_EQ(analysis.cycle.period.max_ns, 2e6);
  // Each bus alone: 39 + 19 + 5 x 21 bytes at 2.5 us = 407.5 us (what_if_test's derivation).
  const WhatIf wire = what_if(run, list, analysis, Scenario{});
  EXPECT_NEAR(wire.cycle.p50_ns, 407'500.0, 1.0);
  EXPECT_NEAR(wire.rate_hz, 2454.0, 2454.0 * 0.02);
}

}  // namespace
}  // namespace doppel::analyzer
