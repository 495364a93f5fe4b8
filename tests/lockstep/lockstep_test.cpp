// End to end: doppel --lockstep (fumanoid-2011, wire timing at 1 Mbps) and controllers under
// doppel-run --lockstep. Two runs of the same controller must give the same run hash for every
// simulated second (issue 15: bit-identical bus traffic and world state), the controller must see
// simulation time (it stops after exactly its simulated seconds, whatever the wall clock did), and
// a thread that waits in a way the shim cannot see is named by the watchdog instead of hanging
// the run silently.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/mman.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "doppel_process.h"
#include "lockstep/clock_file.h"

namespace doppel::testing {
namespace {

const std::string kDoppelRun = DOPPEL_RUN;
const std::string kWalk = DOPPEL_WALK;
const std::string kController = LOCKSTEP_CONTROLLER;

std::vector<std::string> lines_of(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

std::string value(const std::string& output, const std::string& name) {
  const std::regex field("(^|[\\s])" + name + "=([^\\s]*)");
  std::smatch match;
  return std::regex_search(output, match, field) ? match[2].str() : "";
}

struct LockstepRun {
  int code = -1;
  std::string output;                 // the controller's
  std::vector<std::string> hashes;    // doppel's `hash SECOND HEX` lines
  std::string doppel_output;
};

// One lockstep run: a fresh doppel, `controller` (a command line; /dev/ttyUSB0 is doppel's bus)
// under doppel-run --lockstep, then doppel stopped.
LockstepRun run_lockstep(const std::string& controller, const std::vector<std::string>& extra = {}) {
  const std::string hashes = std::filesystem::temp_directory_path() /
                             ("doppel-lockstep-hashes-" + std::to_string(::getpid()) + "-" + std::to_string(std::rand()));
  std::vector<std::string> args = {"--lockstep", "--hashes-file", hashes};
  args.insert(args.end(), extra.begin(), extra.end());
  DoppelProcess doppel(args);
  doppel.wait_for_output("running until");
  LockstepRun run;
  std::tie(run.code, run.output) =
      run_command(kDoppelRun + " --lockstep --link-dir " + doppel.link_dir() + " -- " + controller);
  doppel.stop();
  run.doppel_output = doppel.output();
  run.hashes = lines_of(hashes);
  std::filesystem::remove(hashes);
  return run;
}

void expect_hash_lines(const LockstepRun& run, int seconds) {
  ASSERT_GE(run.hashes.size(), static_cast<std::size_t>(seconds)) << run.doppel_output;
  for (int s = 0; s < seconds; ++s) {
    EXPECT_TRUE(std::regex_match(run.hashes[s], std::regex("hash " + std::to_string(s + 1) + " [0-9a-f]{16}")))
        << run.hashes[s];
  }
}

TEST(Lockstep, SingleThreadedControllerGivesTheSameHashesTwice) {
  const std::string controller = kController + " single /dev/ttyUSB0 3";
  const LockstepRun first = run_lockstep(controller);
  const LockstepRun second = run_lockstep(controller);
  ASSERT_EQ(first.code, 0) << first.output << first.doppel_output;
  ASSERT_EQ(second.code, 0) << second.output << second.doppel_output;
  // Every READ answered: the bus served every request in simulation time.
  EXPECT_EQ(value(first.output, "timeouts"), "0") << first.output;
  EXPECT_GT(std::stol(value(first.output, "replies")), 1000) << first.output;
  // The controller stops at its first cycle at or after 3 s of its (simulated) clock; a cycle of
  // SYNC WRITE (71 bytes) + READ at 1 Mbps with the RX servos' 0.5 ms return delay is ~1.4 ms.
  const double end_s = std::stod(value(first.output, "end_s"));
  EXPECT_GE(end_s, 3.0);
  EXPECT_LT(end_s, 3.003);
  expect_hash_lines(first, 3);
  EXPECT_EQ(first.hashes, second.hashes);
  EXPECT_EQ(first.output, second.output);
}

TEST(Lockstep, TimerThreadControllerGivesTheSameHashesTwice) {
  // A timerfd thread wakes the main thread through a condition variable; the main thread polls
  // its replies with non-blocking reads and CLOCK_REALTIME, as DynamixelSDK does.
  const std::string controller = kController + " timer /dev/ttyUSB0 3";
  const LockstepRun first = run_lockstep(controller);
  const LockstepRun second = run_lockstep(controller);
  ASSERT_EQ(first.code, 0) << first.output << first.doppel_output;
  ASSERT_EQ(second.code, 0) << second.output << second.doppel_output;
  EXPECT_EQ(value(first.output, "timeouts"), "0") << first.output;
  EXPECT_GT(std::stol(value(first.output, "cycles")), 1000) << first.output;
  // termios(3), MIN == 0, TIME == 0: "If no data is available, read(2) returns 0", O_NONBLOCK or
  // not (drivers add read()'s result to a count: -1 would take a byte off).
  EXPECT_EQ(value(first.output, "read_errors"), "0") << first.output;
  expect_hash_lines(first, 3);
  EXPECT_EQ(first.hashes, second.hashes);
  EXPECT_EQ(first.output, second.output);
}

TEST(Lockstep, SemaphoreAndPipeThreadControllersGiveTheSameHashesTwice) {
  for (const std::string mode : {"sem", "pipe"}) {
    const std::string controller = kController + " " + mode + " /dev/ttyUSB0 2";
    const LockstepRun first = run_lockstep(controller);
    const LockstepRun second = run_lockstep(controller);
    ASSERT_EQ(first.code, 0) << mode << first.output << first.doppel_output;
    ASSERT_EQ(second.code, 0) << mode << second.output << second.doppel_output;
    EXPECT_EQ(value(first.output, "timeouts"), "0") << mode << first.output;
    EXPECT_GT(std::stol(value(first.output, "cycles")), 500) << mode << first.output;
    expect_hash_lines(first, 2);
    EXPECT_EQ(first.hashes, second.hashes) << mode;
    EXPECT_EQ(first.output, second.output) << mode;
  }
}

TEST(Lockstep, ReferenceWalkGivesTheSameHashesTwice) {
  const std::string walk = kWalk + " --port /dev/ttyUSB0 --seconds 4";
  const LockstepRun first = run_lockstep(walk);
  const LockstepRun second = run_lockstep(walk);
  ASSERT_EQ(first.code, 0) << first.output << first.doppel_output;
  ASSERT_EQ(second.code, 0) << second.output << second.doppel_output;
  expect_hash_lines(first, 4);
  EXPECT_EQ(first.hashes, second.hashes);
}

TEST(Lockstep, PyserialControllerSeesTheWireTimeInSimulationTime) {
  const std::string controller = "/usr/bin/python3 " + std::string(PYSERIAL_PING) + " /dev/ttyUSB0";
  const LockstepRun first = run_lockstep(controller);
  const LockstepRun second = run_lockstep(controller);
  ASSERT_EQ(first.code, 0) << first.output << first.doppel_output;
  EXPECT_EQ(value(first.output, "answered"), "200") << first.output;
  // Each round: PING 6 bytes at 1 Mbps (60 us), doppel's default firmware time (50 us), the RX-28's
  // default Return Delay Time (250 x 2 us = 500 us, e-Manual), the 6-byte status (60 us), then
  // 5 ms of sleep: 5.670 ms, 200 times. Exactly, because every wait is simulation time.
  EXPECT_EQ(value(first.output, "elapsed_s"), "1.134000") << first.output;
  EXPECT_EQ(first.output, second.output);
  EXPECT_EQ(first.hashes, second.hashes);
}

TEST(Lockstep, TheDarwinOpFrameworksUncheckedReadsAndZeroSleepsWork) {
  // The framework's Linux port adds read()'s result to its byte count and waits with usleep(0)
  // loops (lockstep_controller.c, MODE framework). An empty read of its VMIN = VTIME = 0 port
  // must say 0 as the kernel's does, not -1 (EAGAIN); a zero sleep must let simulation time pass,
  // else the loop spins for ever with time standing still (`timeout` ends it: exit 124).
  // One epoch for both runs: the client's millisecond arithmetic on gettimeofday rounds by it.
  std::string first;
  for (int run = 0; run < 2; ++run) {
    DoppelProcess doppel({"--lockstep", "--lockstep-epoch", "1767225600"});
    doppel.wait_for_output("running until");
    const auto [code, output] = run_command("timeout 60 " + kDoppelRun + " --lockstep --link-dir " + doppel.link_dir() +
                                            " -- " + kController + " framework /dev/ttyUSB0 0.5");
    doppel.stop();
    ASSERT_EQ(code, 0) << output << doppel.output();
    EXPECT_EQ(value(output, "read_errors"), "0") << output;
    EXPECT_EQ(value(output, "timeouts"), "0") << output;
    EXPECT_EQ(value(output, "replies"), value(output, "cycles")) << output;
    // A cycle is at least the 1 ms wait (plus the READ's 0.7 ms on the wire and in return delay).
    EXPECT_GT(std::stol(value(output, "cycles")), 100) << output;
    EXPECT_LE(std::stol(value(output, "cycles")), 500) << output;
    const double end_s = std::stod(value(output, "end_s"));
    EXPECT_GE(end_s, 0.5);
    EXPECT_LT(end_s, 0.505);
    if (run == 0) first = output;
    EXPECT_EQ(output, first);  // simulation time only: the same run twice
  }
}

TEST(Lockstep, DifferentControllersGiveDifferentHashes) {
  // The hash sees the traffic: a controller with another timing gives other hashes.
  const LockstepRun single = run_lockstep(kController + " single /dev/ttyUSB0 1");
  const LockstepRun timer = run_lockstep(kController + " timer /dev/ttyUSB0 1");
  ASSERT_EQ(single.code, 0) << single.output;
  ASSERT_EQ(timer.code, 0) << timer.output;
  expect_hash_lines(single, 1);
  expect_hash_lines(timer, 1);
  EXPECT_NE(single.hashes[0], timer.hashes[0]);
}

TEST(Lockstep, WatchdogNamesAThreadThatNeverWaitsAndTheNextControllerRuns) {
  DoppelProcess doppel({"--lockstep", "--lockstep-watchdog", "0.5"});
  doppel.wait_for_output("running until");
  const std::string run = kDoppelRun + " --lockstep --link-dir " + doppel.link_dir() + " -- ";
  // `timeout` kills the spinning controller once the watchdog had time to speak (under any load).
  const auto [busy_code, busy_output] = run_command("timeout 4 " + run + kController + " busy /dev/ttyUSB0 1");
  EXPECT_EQ(busy_code, 124) << busy_output;
  const std::string output = doppel.wait_for_output("lockstep watchdog");
  EXPECT_NE(output.find("lockstep watchdog: controller thread"), std::string::npos) << output;
  EXPECT_NE(output.find("(lockstep_contro)"), std::string::npos) << output;  // its name (15 characters)
  EXPECT_NE(output.find("simulation time stands still at 0.000 s"), std::string::npos) << output;
  // The killed controller's thread is removed: the next one runs to its end.
  const auto [code, next] = run_command(run + kController + " single /dev/ttyUSB0 0.5");
  EXPECT_EQ(code, 0) << next << doppel.output();
  EXPECT_EQ(value(next, "timeouts"), "0") << next;
}

TEST(Lockstep, ASleepUntilATimeAlreadyPastReturnsWithoutAHandOverAndAZeroSleepLetsTimeMove) {
  // clock_nanosleep(2): a TIMER_ABSTIME time "less than or equal to the current value of the clock"
  // returns immediately without suspending the thread. Under lockstep such a sleep must neither
  // move simulation time nor wait for doppel: the clock file counts the waits the thread began.
  // A loop of usleep(0) until the clock has moved 1 ms must end (each waits for the next event).
  DoppelProcess doppel({"--lockstep"});
  doppel.wait_for_output("running until");
  const auto [code, output] = run_command("timeout 60 " + kDoppelRun + " --lockstep --link-dir " + doppel.link_dir() +
                                          " -- " + kController + " overrun /dev/ttyUSB0 0.5");
  ASSERT_EQ(code, 0) << output << doppel.output();
  EXPECT_EQ(value(output, "late_sleeps"), "1000") << output;
  const long zero_sleeps = std::stol(value(output, "zero_sleeps"));
  EXPECT_GE(zero_sleeps, 1) << output;
  EXPECT_LE(zero_sleeps, 2) << output;  // the next 1 ms step is at most 1 ms away
  const int fd = ::open((doppel.link_dir() + "/" + lockstep::kClockFileName).c_str(), O_RDONLY | O_CLOEXEC);
  ASSERT_GE(fd, 0);
  void* memory = ::mmap(nullptr, sizeof(lockstep::ClockFile), PROT_READ, MAP_SHARED, fd, 0);
  ::close(fd);
  ASSERT_NE(memory, MAP_FAILED);
  const auto* clock = static_cast<const lockstep::ClockFile*>(memory);
  // The controller's only thread had slot 0 (released at its exit, its counters kept): a wait per
  // usleep(0) and one for the final sleep, none for the 1000 sleeps to a time past.
  EXPECT_EQ(clock->threads[0].waits.load(), static_cast<uint64_t>(zero_sleeps) + 1) << output;
  EXPECT_EQ(clock->slots_used.load(), 1u);
  ::munmap(memory, sizeof(lockstep::ClockFile));
}

TEST(Lockstep, DoppelRunLockstepNeedsALockstepDoppel) {
  DoppelProcess doppel({});
  doppel.wait_for_output("running until");
  const auto [code, output] =
      run_command(kDoppelRun + " --lockstep --link-dir " + doppel.link_dir() + " -- " + kController + " single /dev/ttyUSB0 1");
  EXPECT_EQ(code, 1) << output;
  EXPECT_NE(output.find("is doppel running with --lockstep"), std::string::npos) << output;
}

TEST(Lockstep, HashesNeedLockstep) {
  const auto [code, output] = run_command(doppel_executable() + " --hashes");
  EXPECT_EQ(code, 2) << output;
  EXPECT_NE(output.find("--hashes, --hashes-file and --lockstep-epoch need --lockstep"), std::string::npos) << output;
}

}  // namespace
}  // namespace doppel::testing
