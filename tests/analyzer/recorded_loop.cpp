// The analyzer on a real recording (doppel --record): a driver's loop recorded in wire mode, and
// the analyzer's what-if at the recording's own settings (keeping the driver's own time between a
// reply and its next instruction) against the recording's own timestamps. What is asserted holds
// on any machine: the wire model's cycle is never shorter than the bytes and delays physics gives,
// and never longer than the recorded one (doppel delivers a status at its due time or later, never
// earlier). How close the prediction comes to the cycle the driver measured depends on the
// machine's load: it is printed and kept as test properties, and docs/benchmarks.md has figures.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "analyzer/analysis.h"
#include "analyzer/recording_reader.h"
#include "analyzer/what_if.h"
#include "doppel_process.h"
#include "reference_client.h"

namespace doppel::analyzer {
namespace {

using testing::Bytes;
using testing::DoppelProcess;
using testing::p1_instruction;
using testing::SerialClient;
using Clock = std::chrono::steady_clock;

// A DynamixelSDK-style loop as fast as the bus allows: GroupSyncWrite of 21 goal positions, then
// each servo's Present Position by a READ of its own (RX servos have no BULK READ), `cycles` times
// (a count, not a duration: a loaded machine runs fewer cycles a second). Returns the mean cycle
// time the driver measured, ns.
double sdk_loop(SerialClient& client, int cycles) {
  Bytes sync = {30, 2};
  for (uint8_t id = 1; id <= 21; ++id) sync.insert(sync.end(), {id, 0x00, 0x02});
  const Bytes write = p1_instruction(0xFE, 0x83, sync);
  std::vector<Bytes> reads;
  for (uint8_t id = 1; id <= 21; ++id) reads.push_back(p1_instruction(id, 0x02, {36, 2}));
  const auto start = Clock::now();
  for (int cycle = 0; cycle < cycles; ++cycle) {
    client.send(write);
    for (const Bytes& read : reads) {
      if (client.transact(read, 8).size() != 8) ADD_FAILURE() << "no answer";
    }
  }
  return std::chrono::duration<double, std::nano>(Clock::now() - start).count() / cycles;
}

TEST(RecordedLoop, TheWhatIfAtTheRecordedSettingsLiesBetweenTheWireAndTheRecordedCycle) {
  const std::string file =
      (std::filesystem::temp_directory_path() / ("recorded_loop_" + std::to_string(getpid()) + ".mcap")).string();
  double measured_ns = 0.0;
  {
    DoppelProcess doppel({"--record", file, "--timing", "wire"});
    doppel.wait_for_output("running until");
    SerialClient client(doppel.link(), 1'000'000);
    measured_ns = sdk_loop(client, 300);
    ASSERT_EQ(doppel.stop(15), 0);
  }
  const Recording recording = read_recording(file);
  const Analysis analysis = analyze(recording.run, recording.transactions, 0);
  ASSERT_TRUE(analysis.cycle.found);
  EXPECT_EQ(analysis.cycle.opener_kind, "P1 SYNC WRITE");
  const WhatIf predicted = what_if(recording.run, recording.transactions, analysis, parse_scenario("driver=recorded"));
  ASSERT_GT(predicted.cycles, 100u) << predicted.note;
  // One cycle on the wire at 1 Mbps (10 bit times a byte, 10 us): the SYNC WRITE of 21 x 3 data
  // bytes (7 + 63 + 1 = 71 bytes), then 21 READs of 8 bytes answered with 8 bytes each after the
  // firmware time (50 us, doppel's default) and the Return Delay Time (RX default 250 = 500 us).
  const double wire_ns = 71 * 10'000.0 + 21 * (16 * 10'000.0 + 50'000.0 + 500'000.0);
  EXPECT_GE(predicted.cycle.min_ns, wire_ns - 1.0);
  // The same cycles in the recording's own timestamps (first_seen of one opener to the next).
  ASSERT_EQ(analysis.cycle.period.count, predicted.cycles);
  EXPECT_LE(predicted.cycle.mean_ns, analysis.cycle.period.mean_ns + 1'000.0)
      << "predicted " << predicted.cycle.mean_ns / 1000.0 << " us, recorded " << analysis.cycle.period.mean_ns / 1000.0
      << " us";
  const double predicted_ns = 1e9 / predicted.rate_hz;
  RecordProperty("measured_cycle_us", std::to_string(measured_ns / 1000.0));
  RecordProperty("recorded_cycle_us", std::to_string(analysis.cycle.period.mean_ns / 1000.0));
  RecordProperty("predicted_cycle_us", std::to_string(predicted_ns / 1000.0));
  std::printf("cycle: driver measured %.1f us, recorded %.1f us, what-if at the recorded settings %.1f us (%.3f)\n",
              measured_ns / 1000.0, analysis.cycle.period.mean_ns / 1000.0, predicted_ns / 1000.0,
              predicted_ns / measured_ns);
  std::filesystem::remove(file);
}

}  // namespace
}  // namespace doppel::analyzer
