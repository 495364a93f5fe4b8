// End-to-end: the real doppel (mx-test robot, 1 Mbps, wire timing), doppel-run with its preload
// library, and programs written from the man pages and the Dynamixel reference (darwin_open.c,
// serial_probe.c, sync_write_flush.py), never with Doppel's own code. Expected answers are those of
// Linux's FTDI driver (shim/ftdi_serial.h cites them).
#include <signal.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <thread>

#include "doppel_process.h"

namespace doppel::testing {
namespace {

const std::string kDoppelRun = DOPPEL_RUN;
const std::string kShim = SHIM_LIBRARY;
const std::string kDarwinOpen = DARWIN_OPEN;
const std::string kSerialProbe = SERIAL_PROBE;
const std::string kSyncWriteFlush = SYNC_WRITE_FLUSH;

// The value of "name=value" in `output`, or "" when absent.
std::string value(const std::string& output, const std::string& name) {
  const std::regex line("(^|\n)" + name + "=([^\n]*)");
  std::smatch match;
  return std::regex_search(output, match, line) ? match[2].str() : "";
}

std::string read_file(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

class DoppelRun : public ::testing::Test {
 protected:
  DoppelRun() : doppel_({"--robot", "mx-test", "--latency-timer", "16"}) { doppel_.wait_for_output("running until"); }

  // `program` under doppel-run with the default mapping of doppel's link directory.
  std::pair<int, std::string> run(const std::string& program) {
    return run_command(kDoppelRun + " --link-dir " + doppel_.link_dir() + " -- " + program);
  }

  DoppelProcess doppel_;
};

TEST_F(DoppelRun, DarwinOpSequenceOnTtyUsb0GetsThePingStatusAt1Mbps) {
  const auto [code, output] = run(kDarwinOpen + " /dev/ttyUSB0");
  EXPECT_EQ(code, 0) << output;
  EXPECT_NE(output.find("status from ID 1"), std::string::npos) << output;
}

TEST_F(DoppelRun, DarwinOpSequenceWithoutTheShimStopsAtTiocgserial) {
  const auto [code, output] = run_command(kDarwinOpen + " " + doppel_.link());
  EXPECT_EQ(code, 2) << output;
  EXPECT_NE(output.find("TIOCGSERIAL failed: Inappropriate ioctl for device (errno 25)"), std::string::npos) << output;
}

TEST_F(DoppelRun, U2d2AndTtyAcmNamesLeadToTheSamePort) {
  for (const char* device : {"/dev/U2D2", "/dev/ttyACM0"}) {
    const auto [code, output] = run(kDarwinOpen + " " + device);
    EXPECT_EQ(code, 0) << device << ": " << output;
  }
}

TEST_F(DoppelRun, TiocgserialAnswersAsAnFt232hDoes) {
  const auto [code, output] = run(kSerialProbe + " /dev/ttyUSB0 serial");
  ASSERT_EQ(code, 0) << output;
  EXPECT_EQ(value(output, "TIOCGSERIAL"), "0 errno=0");
  EXPECT_EQ(value(output, "baud_base"), "60000000");
  EXPECT_EQ(value(output, "flags"), "0");
  EXPECT_EQ(value(output, "close_delay"), "50");
  EXPECT_EQ(value(output, "closing_wait"), "3000");
  EXPECT_EQ(value(output, "line"), "0");
}

TEST_F(DoppelRun, CustomDivisorSetsTheTrueRateOnTheLineAndKeepsItThroughB38400) {
  const auto [code, output] = run(kSerialProbe + " /dev/ttyUSB0 custom");
  ASSERT_EQ(code, 0) << output;
  EXPECT_EQ(value(output, "rate_before"), "38400");
  EXPECT_EQ(value(output, "TIOCSSERIAL"), "0 errno=0");
  EXPECT_EQ(value(output, "rate_after_custom"), "1000000");
  EXPECT_EQ(value(output, "rate_after_b38400_again"), "1000000");
}

TEST_F(DoppelRun, ModemLinesAreThoseOfTheFtdiDriver) {
  const auto [code, output] = run(kSerialProbe + " /dev/ttyUSB0 modem");
  ASSERT_EQ(code, 0) << output;
  EXPECT_EQ(value(output, "TIOCMGET"), "0 errno=0");
  EXPECT_EQ(value(output, "lines"), std::to_string(TIOCM_DTR | TIOCM_RTS));
  EXPECT_EQ(value(output, "lines_after_bic_dtr"), std::to_string(TIOCM_RTS));
  EXPECT_EQ(value(output, "lines_after_bis_dtr"), std::to_string(TIOCM_DTR | TIOCM_RTS));
  EXPECT_EQ(value(output, "TIOCMSET"), "0 errno=0");
  EXPECT_EQ(value(output, "lines_after_set_0"), "0");
}

TEST_F(DoppelRun, Rs485IsRefusedWithEnottyAsByTheFtdiDriver) {
  const auto [code, output] = run(kSerialProbe + " /dev/ttyUSB0 rs485");
  ASSERT_EQ(code, 0) << output;
  EXPECT_EQ(value(output, "TIOCGRS485"), "-1 errno=" + std::to_string(ENOTTY));
  EXPECT_EQ(value(output, "TIOCSRS485"), "-1 errno=" + std::to_string(ENOTTY));
}

TEST_F(DoppelRun, FlushesSucceedAndTheDeviceStatsAsACharacterDevice) {
  const auto [code, output] = run(kSerialProbe + " /dev/ttyUSB0 flushes stat");
  ASSERT_EQ(code, 0) << output;
  EXPECT_EQ(value(output, "TCOFLUSH"), "0 errno=0");
  EXPECT_EQ(value(output, "TCIOFLUSH"), "0 errno=0");
  EXPECT_EQ(value(output, "TCIFLUSH"), "0 errno=0");
  EXPECT_EQ(value(output, "stat_chr"), "1");
  EXPECT_EQ(value(output, "lstat_chr"), "1");
  EXPECT_EQ(value(output, "access"), "0");
}

TEST_F(DoppelRun, PyserialFlushingAfterEverySyncWriteLosesNone) {
  constexpr int kCount = 10000;
  const auto [code, output] = run("/usr/bin/python3 " + kSyncWriteFlush + " /dev/ttyUSB0 " + std::to_string(kCount));
  EXPECT_EQ(code, 0) << output;
  EXPECT_NE(output.find("sent 10000"), std::string::npos) << output;
  doppel_.stop(SIGTERM);
  // Every SYNC WRITE and the three READs reached doppel whole: none was flushed away.
  const std::string summary = doppel_.output();
  std::smatch match;
  ASSERT_TRUE(std::regex_search(summary, match, std::regex("packets (\\d+) \\(bad checksum (\\d+)"))) << summary;
  EXPECT_EQ(std::stoi(match[1].str()), kCount + 3) << summary;
  EXPECT_EQ(match[2].str(), "0");
}

TEST_F(DoppelRun, LatencyTimerFileRoundTripChangesTheBusAdapter) {
  const std::string sysfs = "/sys/bus/usb-serial/devices/ttyUSB0/latency_timer";
  auto [code, output] = run("sh -c 'cat " + sysfs + "; echo 1 > " + sysfs + "; cat " + sysfs + "'");
  ASSERT_EQ(code, 0) << output;
  EXPECT_EQ(output, "16\n1\n");
  EXPECT_NE(doppel_.wait_for_output("USB latency timer 16 -> 1 ms").find("ttyDXL0.latency_timer"), std::string::npos);
}

TEST_F(DoppelRun, BadLatencyTimerTextIsRefusedAndTheValueStays) {
  const std::string sysfs = "/sys/bus/usb-serial/devices/ttyUSB0/latency_timer";
  auto [code, output] = run("sh -c 'echo 300 > " + sysfs + "'");
  ASSERT_EQ(code, 0) << output;
  const std::string log = doppel_.wait_for_output("'300' is not a latency timer in 1..255 ms; it stays 16 ms");
  EXPECT_NE(log.find(doppel_.link() + ".latency_timer"), std::string::npos) << log;
  for (int i = 0; i < 100 && read_file(doppel_.link() + ".latency_timer") != "16\n"; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_EQ(read_file(doppel_.link() + ".latency_timer"), "16\n");
}

TEST_F(DoppelRun, AsyncLowLatencySetsTheAdapterTo1Ms) {
  auto [code, output] = run(kSerialProbe + " /dev/ttyUSB0 lowlatency");
  ASSERT_EQ(code, 0) << output;
  EXPECT_EQ(value(output, "TIOCSSERIAL_low_latency"), "0 errno=0");
  doppel_.wait_for_output("USB latency timer 16 -> 1 ms");
}

TEST_F(DoppelRun, AMissingLinkIsNamedAndTheProgramNeverRuns) {
  const std::string marker = doppel_.link_dir() + "/ran";
  const auto [code, output] =
      run_command(kDoppelRun + " --port /dev/ttyUSB0=/nonexistent/ttyDXL7 -- touch " + marker);
  EXPECT_NE(code, 0);
  EXPECT_NE(output.find("/nonexistent/ttyDXL7 does not exist"), std::string::npos) << output;
  EXPECT_FALSE(std::filesystem::exists(marker));
}

TEST_F(DoppelRun, ALinkThatIsNotAPtyIsRefused) {
  const std::string file = doppel_.link_dir() + "/plain";
  std::ofstream(file) << "x";
  const auto [code, output] = run_command(kDoppelRun + " --port /dev/ttyUSB0=" + file + " -- true");
  EXPECT_EQ(code, 1);
  EXPECT_NE(output.find(file + " is not a pseudo-terminal"), std::string::npos) << output;
}

// The command's arguments reach it as given, in order, options included, whatever doppel-run's own
// options before "--" were (a repeatable --port or --camera once took the command's words).
TEST_F(DoppelRun, TheCommandGetsItsArgumentsInOrderAfterRepeatableOptions) {
  for (const std::string& options :
       {"--port /dev/ttyUSB0=" + doppel_.link(), "--camera /dev/video0=HEAD --port /dev/ttyUSB0=" + doppel_.link(),
        "--link-dir " + doppel_.link_dir()}) {
    const auto [code, output] =
        run_command(kDoppelRun + " " + options + " -- /bin/echo /dev/ttyUSB0 --cycles 10 --margin-ms 500 -- x");
    EXPECT_EQ(code, 0) << options << ": " << output;
    EXPECT_NE(output.find("/dev/ttyUSB0 --cycles 10 --margin-ms 500 -- x\n"), std::string::npos) << options << ": " << output;
  }
}

TEST(DoppelRunAlone, WithoutDoppelItSaysSoAndRunsNothing) {
  const std::string dir = ::testing::TempDir() + "/doppel-run-empty";
  std::filesystem::create_directories(dir);
  const auto [code, output] = run_command(kDoppelRun + " --link-dir " + dir + " -- touch " + dir + "/ran");
  EXPECT_EQ(code, 1);
  EXPECT_NE(output.find("no port link ttyDXL<n> in " + dir + ": is doppel running"), std::string::npos) << output;
  EXPECT_FALSE(std::filesystem::exists(dir + "/ran"));
}

TEST(DoppelRunAlone, ACommandThatDoesNotExistIsNamed) {
  DoppelProcess doppel({"--robot", "mx-test", "--timing", "fast"});
  const auto [code, output] = run_command(kDoppelRun + " --link-dir " + doppel.link_dir() + " -- /no/such/program");
  EXPECT_EQ(code, 127);
  EXPECT_NE(output.find("cannot run '/no/such/program'"), std::string::npos) << output;
}

// A preloaded shim without (or with a bad) map passes everything through and says why once.
TEST(ShimAlone, WithoutItsVariableTheProgramRunsUntouched) {
  const auto [code, output] =
      run_command("env -u DOPPEL_SHIM_PORTS LD_PRELOAD=" + kShim + " sh -c 'echo hello > /dev/null && cat /dev/null; echo done'");
  EXPECT_EQ(code, 0);
  EXPECT_NE(output.find("DOPPEL_SHIM_PORTS is not set"), std::string::npos) << output;
  EXPECT_NE(output.find("done"), std::string::npos) << output;
}

TEST(ShimAlone, ABadMapIsNamedAndThePortOpensAsWithoutTheShim) {
  const auto [code, output] = run_command("DOPPEL_SHIM_PORTS=garbage LD_PRELOAD=" + kShim + " " + kSerialProbe + " /dev/null");
  EXPECT_EQ(code, 0) << output;
  EXPECT_NE(output.find("DOPPEL_SHIM_PORTS: entry 1 'garbage' is not DEVICE=LINK; passing everything through"),
            std::string::npos)
      << output;
}

TEST(ShimAlone, AMapToAStoppedDoppelNamesTheLinkAndTheDeviceFailsAsItWould) {
  const auto [code, output] = run_command("DOPPEL_SHIM_PORTS=/dev/ttyUSB0=/nonexistent/ttyDXL0 LD_PRELOAD=" + kShim +
                                          " " + kDarwinOpen + " /dev/ttyUSB0");
  EXPECT_NE(output.find("/nonexistent/ttyDXL0 (for /dev/ttyUSB0) does not exist: is doppel running?"),
            std::string::npos)
      << output;
  if (!std::filesystem::exists("/dev/ttyUSB0")) {
    EXPECT_EQ(code, 2);
    EXPECT_NE(output.find("open failed"), std::string::npos) << output;
  }
}

}  // namespace
}  // namespace doppel::testing
