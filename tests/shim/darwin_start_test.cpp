// End-to-end: the DARwIn-OP framework's start (darwin_start.c: its bytes, threads, priorities and
// timeouts, rewritten from the Dynamixel reference and the man pages) under doppel-run against the
// darwin-op robot in wire timing. Its motion timer thread busy-polls for each answer at SCHED_RR 31;
// the pty hands its packets to doppel in a kernel work item that the scheduler often queues on that
// same CPU (docs/shim.md, "Writes"): without the shim's hand-over wait the first-cycle PINGs reach
// doppel only after they timed out, and MakeBulkReadPacket leaves their devices out for good. How
// often that happens depends on what else the machine runs (docs/drivers.md has the figures), so
// that run is opt-in; the gate below makes the same situation happen on purpose on every run.
#include <fcntl.h>
#include <signal.h>
#include <stdlib.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "base/pty_handover.h"
#include "doppel_process.h"

namespace doppel::testing {
namespace {

const std::string kDoppelRun = DOPPEL_RUN;
const std::string kDarwinStart = DARWIN_START;
const std::string kShim = SHIM_LIBRARY;
const std::string kDarwinOpen = DARWIN_OPEN;

bool may_use_real_time() { return ::geteuid() == 0; }

// doppel's bus thread above the framework's 31 (a servo needs no CPU of the robot's computer; the
// double's bus thread must not wait for the client's busy-poll), no physics (the test is the bus's).
DoppelProcess darwin_op() {
  return DoppelProcess({"--robot", "darwin-op", "--physics", "none", "--rt-priority", "50"});
}

// Load-dependent, so it runs only when asked (DOPPEL_LOAD_DEPENDENT_TESTS=1): its client keeps the
// framework's 5 ms deadlines. At load average ~10 on this 2-core machine it passed 39 of 40 runs
// (26 of 30 before the hand-over counter waited for the kernel's work item, docs/drivers.md).
TEST(DarwinStart, FirstCyclePingsAreAnsweredAndTheBulkReadHoldsTheCm730AndBothFootBoards) {
  const char* asked = ::getenv("DOPPEL_LOAD_DEPENDENT_TESTS");
  if (asked == nullptr || std::string(asked) != "1") GTEST_SKIP() << "load-dependent: DOPPEL_LOAD_DEPENDENT_TESTS=1 runs it";
  if (!may_use_real_time()) GTEST_SKIP() << "the framework's start needs SCHED_RR (root), as on the robot";
  DoppelProcess doppel = darwin_op();
  doppel.wait_for_output("running until");
  const auto [code, output] =
      run_command(kDoppelRun + " --link-dir " + doppel.link_dir() + " -- " + kDarwinStart + " /dev/ttyUSB0 --cycles 40");
  EXPECT_EQ(code, 0) << output;
  EXPECT_NE(output.find("pings 200=ok 112=ok 111=ok"), std::string::npos) << output;
}

// How long the gate keeps doppel stopped before each write. The shim waits at most kHandoverLimitNs
// for a doppel that does not read; what is left of that is how late the resumer may wake.
constexpr int64_t kStallMs = 20;
constexpr int64_t kResumerSlackNs = doppel::kHandoverLimitNs - kStallMs * 1'000'000;
static_assert(kResumerSlackNs >= 50'000'000, "the gate's stall must stay well below the shim's hand-over limit");

// darwin_start's gate run, after `launcher` (doppel-run or the shim's own variables).
std::string gate_command(const std::string& launcher, const DoppelProcess& doppel, int cycles) {
  return launcher + " " + kDarwinStart + " /dev/ttyUSB0 --cycles " + std::to_string(cycles) +
         " --margin-ms 500 --stall-doppel " + std::to_string(doppel.pid()) + " --stall-ms " + std::to_string(kStallMs);
}

// The CI gate for the start. A loaded machine keeps doppel from reading while the framework
// writes its SYNC WRITE and first-cycle PINGs and starts counting each read deadline at write()'s
// return; here the client makes that happen every time: before the SYNC WRITE and before each PING
// it stops doppel (SIGSTOP, and waits until every doppel thread is stopped), and a SCHED_FIFO 80
// thread of the client continues it kStallMs later, counting the resume just before its SIGCONT
// (darwin_start.c, --stall-doppel). What is asserted holds whatever the clock says: each of those
// four write()s returned only after the resume was counted (so only once doppel could read the
// bytes: the hand-over), and the PINGs, answered, built the BULK READ of the CM-730 and both FSRs,
// which then answered every cycle.
// Without the hand-over (main before issue 22, or a link without `<link>.received`: the next test)
// write() returns at once while doppel is stopped; the timer thread (SCHED_RR 31, preempted only by
// the resumer, which sleeps, and by doppel, which is stopped) reads the count microseconds later,
// well before the resume, so each PING says while-stopped and the test fails, every run.
// It passes whatever the load as long as the resumer, at SCHED_FIFO 80, wakes within
// kResumerSlackNs (80 ms) of the end of its sleep: a later resume would let a write return at the
// shim's limit, before it.
// The read deadlines here are 500 ms, not the framework's 5 ms: even once doppel has the bytes, its
// answer reaches the client through the pty's kernel work item, a normal-priority kworker that
// competes with everything else on its CPU, so 5 ms depends on the machine's load (the opt-in test
// above; docs/drivers.md has this client's figures with 5 ms). The deadline still counts from
// write()'s return, as the framework's does.
TEST(DarwinStartGate, EveryStalledWriteReturnsOnceDoppelCanReadItAndTheFirstCyclePingsBuildTheFullBulkRead) {
  if (!may_use_real_time()) GTEST_SKIP() << "the framework's start needs SCHED_RR (root), as on the robot";
  DoppelProcess doppel = darwin_op();
  doppel.wait_for_output("running until");
  const auto [code, output] = run_command(gate_command(kDoppelRun + " --link-dir " + doppel.link_dir() + " --", doppel, 40));
  ::kill(doppel.pid(), SIGCONT);  // whatever became of the client, doppel runs on
  EXPECT_EQ(code, 0) << output;
  EXPECT_NE(output.find("stalled writes sync_write=after-resume ping200=after-resume ping112=after-resume "
                        "ping111=after-resume"),
            std::string::npos)
      << output;
  EXPECT_NE(output.find("pings 200=ok 112=ok 111=ok bulk_reads answered=39 of 39"), std::string::npos) << output;
  EXPECT_NE(output.find("initialize read=20 of 20"), std::string::npos) << output;
}

// The gate's own check: the same run through a link without doppel's hand-over counter beside it
// (what every doppel before issue 22 offered) lets each PING's write() return while doppel is
// stopped, so the gate above would fail. Only the order is asserted: whether the PINGs are then
// answered depends on when the kernel's work item runs.
TEST(DarwinStartGate, WithoutTheHandOverCounterThePingsWritesReturnWhileDoppelIsStopped) {
  if (!may_use_real_time()) GTEST_SKIP() << "the framework's start needs SCHED_RR (root), as on the robot";
  DoppelProcess doppel = darwin_op();
  doppel.wait_for_output("running until");
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("handover-gate-" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string link = (dir / "ttyDXL0").string();
  std::filesystem::create_symlink(std::filesystem::read_symlink(doppel.link()), link);

  const auto [code, output] =
      run_command(gate_command("DOPPEL_SHIM_PORTS=/dev/ttyUSB0=" + link + " LD_PRELOAD=" + kShim, doppel, 10));
  ::kill(doppel.pid(), SIGCONT);
  std::filesystem::remove_all(dir);

  EXPECT_NE(output.find(link + ".received is missing"), std::string::npos) << output;
  EXPECT_EQ(code, 1) << output;
  for (const char* ping : {"ping200=while-stopped", "ping112=while-stopped", "ping111=while-stopped"}) {
    EXPECT_NE(output.find(ping), std::string::npos) << ping << "\n" << output;
  }
}

// A port whose link has no hand-over counter beside it (an older doppel): the shim says so, names
// the file, and the program's writes still reach the port (they are not waited for).
TEST(HandOver, WithoutDoppelsCounterTheShimSaysSoAndWritesStillPass) {
  const int master = ::posix_openpt(O_RDWR | O_NOCTTY | O_NONBLOCK);
  ASSERT_GE(master, 0);
  ASSERT_EQ(::grantpt(master), 0);
  ASSERT_EQ(::unlockpt(master), 0);
  char name[128];
  ASSERT_EQ(::ptsname_r(master, name, sizeof(name)), 0);
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("handover-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string link = (dir / "ttyDXL0").string();
  std::filesystem::create_symlink(name, link);

  const auto [code, output] = run_command("DOPPEL_SHIM_PORTS=/dev/ttyUSB0=" + link + " LD_PRELOAD=" + kShim + " " +
                                          kDarwinOpen + " /dev/ttyUSB0");
  uint8_t bytes[64];
  const ssize_t n = ::read(master, bytes, sizeof(bytes));
  ::close(master);
  std::filesystem::remove_all(dir);

  EXPECT_NE(output.find(link + ".received is missing"), std::string::npos) << output;
  EXPECT_EQ(code, 3) << output;  // nobody answers the PING
  ASSERT_EQ(n, 6) << output;      // but it reached the port
  EXPECT_EQ(bytes[0], 0xFF);
  EXPECT_EQ(bytes[2], 0x01);
}

}  // namespace
}  // namespace doppel::testing
