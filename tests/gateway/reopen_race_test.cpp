// The reopen race (issue #10): a driver that opens the port at one rate, closes it and opens it
// again at the bus rate before its first packet (DynamixelSDK's setBaudRate) must find the rate it
// set, and get its answers, also with the CPUs busy. The full 1000-start-up run is
// bench/reopen_race (docs/benchmarks.md).
#include <unistd.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "doppel_process.h"
#include "reopen_stress.h"

namespace doppel::testing {
namespace {

std::string write_robot() {
  const std::string dir = ::testing::TempDir() + "reopen-" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  const std::string path = dir + "/reopen.textproto";
  std::ofstream(path) << "name: \"reopen\"\n"
                         "bus { baud_bps: 1000000 protocol: PROTOCOL_1 supply_voltage_v: 12 device { id: 1 model: \"AX-12A\" } }\n"
                         "bus { baud_bps: 57600 protocol: PROTOCOL_1 supply_voltage_v: 12 device { id: 1 model: \"AX-12A\" } }\n";
  return path;
}

void expect_clean_startups(const std::string& port, uint32_t first_bps, uint32_t second_bps, int startups) {
  int kept_rate = 0, answered = 0;
  std::string failures;
  for (int i = 0; i < startups; ++i) {
    // 5 s for each status: beside four busy processes on two cores a client once waited more than
    // 1 s for one though doppel had written every reply (its exit counters); lateness is not what
    // this test looks at, a lost answer or a lost rate is.
    const StartupOutcome outcome = reopen_startup(port, first_bps, second_bps, 1, 5, 5000);
    kept_rate += outcome.line_bps_after == second_bps ? 1 : 0;
    answered += outcome.answered == 5 ? 1 : 0;
    if (!outcome.first_failure.empty()) failures += "\n  start-up " + std::to_string(i + 1) + ": " + outcome.first_failure;
  }
  // Every session keeps the rate its client set and gets every answer.
  EXPECT_EQ(kept_rate, startups) << first_bps << " -> " << second_bps;
  EXPECT_EQ(answered, startups) << first_bps << " -> " << second_bps << failures;
}

TEST(ReopenRace, ReopenAtAnotherRateKeepsThatRateUnderLoad) {
  DoppelProcess doppel({"--robot", write_robot(), "--timing", "wire"}, "ttyDXL1");
  BusyLoad busy(2);
  expect_clean_startups(doppel.link("ttyDXL0"), 57600, 1000000, 150);
  expect_clean_startups(doppel.link("ttyDXL1"), 1000000, 57600, 150);
  doppel.stop();
  // Both buses: no packet came at a rate no device listens at.
  const std::string output = doppel.output();
  const auto on_both_buses = [&output](const std::string& counted) {
    const auto first = output.find(counted);
    return first != std::string::npos && output.find(counted, first + 1) != std::string::npos;
  };
  EXPECT_TRUE(on_both_buses("not understood at the line's baud rate 0)"));
  // Both buses: every PING (150 start-ups of 5) came in whole and was answered.
  EXPECT_TRUE(on_both_buses("packets 750 (bad checksum 0,"));
  EXPECT_TRUE(on_both_buses("replies 750 (collisions 0,"));
  // Once, for whichever check failed: doppel's exit counters tell a lost answer from a late one.
  if (HasFailure()) ADD_FAILURE() << "doppel said:\n" << output;
}

}  // namespace
}  // namespace doppel::testing
