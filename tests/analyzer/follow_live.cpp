// doppel-bus report --follow against a running doppel --record: the report appears while doppel
// records and shows the driver's control cycle, and once doppel is stopped (it closes the file) a
// final report ends the tool with 0. Also: a file that does not exist yet is waited for (said
// once), and Ctrl-C (SIGINT) ends the tool cleanly.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "analyzer/recording_reader.h"
#include "doppel_process.h"
#include "reference_client.h"

namespace doppel::analyzer {
namespace {

using testing::Bytes;
using testing::DoppelProcess;
using testing::p1_instruction;
using testing::SerialClient;
using Clock = std::chrono::steady_clock;

std::string read_file(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// doppel-bus as a child process, stdout and stderr into files of their own.
class DoppelBus {
 public:
  explicit DoppelBus(const std::vector<std::string>& args) {
    const std::string base = (std::filesystem::temp_directory_path() / ("doppel-bus-follow-" + std::to_string(getpid()) + "-" +
                                                                        std::to_string(++count_)))
                                 .string();
    out_ = base + ".out";
    err_ = base + ".err";
    pid_ = fork();
    if (pid_ == 0) {
      std::freopen(out_.c_str(), "w", stdout);
      std::freopen(err_.c_str(), "w", stderr);
      std::vector<std::string> all = {DOPPEL_BUS_TOOL, "report"};
      all.insert(all.end(), args.begin(), args.end());
      std::vector<char*> argv;
      for (std::string& a : all) argv.push_back(a.data());
      argv.push_back(nullptr);
      execv(argv[0], argv.data());
      _exit(127);
    }
  }
  ~DoppelBus() {
    if (pid_ > 0) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
    std::filesystem::remove(out_);
    std::filesystem::remove(err_);
  }
  std::string out() const { return read_file(out_); }
  std::string err() const { return read_file(err_); }
  // Waits up to `seconds` until `done(stdout)`; false when it did not come.
  template <typename F>
  bool wait_for(F done, double seconds) const {
    const auto until = Clock::now() + std::chrono::duration<double>(seconds);
    while (Clock::now() < until) {
      if (done(out())) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    return false;
  }
  // Waits up to `seconds` for the exit; the exit status, or -1 when it still runs.
  int wait_exit(double seconds) {
    const auto until = Clock::now() + std::chrono::duration<double>(seconds);
    while (Clock::now() < until) {
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return -1;
  }
  void signal(int number) const { kill(pid_, number); }

 private:
  static inline int count_ = 0;
  pid_t pid_ = -1;
  std::string out_, err_;
};

// The rates of the reports in `text` ("  rate 100.0 Hz (1 / mean period)"), in order.
std::vector<double> rates(const std::string& text) {
  std::vector<double> out;
  const std::regex rate(R"(\n  rate ([0-9.]+) Hz)");
  for (auto it = std::sregex_iterator(text.begin(), text.end(), rate); it != std::sregex_iterator(); ++it) {
    out.push_back(std::stod((*it)[1].str()));
  }
  return out;
}

// The recorded SYNC WRITEs (instruction 0x83, the driver's cycle opener) in `file`, read with the
// recording reader, counted here: when doppel read each, and the newest instruction of any kind.
struct Openers {
  std::vector<int64_t> first_seen_ns;
  int64_t newest_ns = 0;
};
Openers sync_writes(const std::string& file) {
  Openers out;
  for (const Transaction& t : read_recording(file).transactions) {
    out.newest_ns = std::max(out.newest_ns, t.first_seen_ns);
    if (t.instruction.size() > 4 && static_cast<uint8_t>(t.instruction[4]) == 0x83) out.first_seen_ns.push_back(t.first_seen_ns);
  }
  std::sort(out.first_seen_ns.begin(), out.first_seen_ns.end());
  return out;
}

std::string temp_file(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("follow_" + std::to_string(getpid()) + "_" + name)).string();
}

// A driver's loop at 100 Hz: every 10 ms a SYNC WRITE of 21 goal positions and READs of the
// Present Position of IDs 1 to 4, then a sleep until the next tick.
void loop_at_100_hz(SerialClient& client, const std::atomic<bool>& stop, std::atomic<int>& cycles) {
  Bytes sync = {30, 2};
  for (uint8_t id = 1; id <= 21; ++id) sync.insert(sync.end(), {id, 0x00, 0x02});
  const Bytes write = p1_instruction(0xFE, 0x83, sync);
  auto tick = Clock::now();
  while (!stop) {
    client.send(write);
    for (uint8_t id = 1; id <= 4; ++id) client.transact(p1_instruction(id, 0x02, {36, 2}), 8);
    cycles.fetch_add(1);
    tick += std::chrono::milliseconds(10);
    std::this_thread::sleep_until(tick);
  }
}

TEST(FollowLive, ReportsTheCycleWhileDoppelRecordsAndAFinalReportWhenItStops) {
  const std::string file = temp_file("live.mcap");
  std::filesystem::remove(file);
  // Started before doppel: it waits for the file.
  DoppelBus follow({"--follow", "0.5", file});
  {
    DoppelProcess doppel({"--record", file, "--timing", "wire"});
    doppel.wait_for_output("running until");
    SerialClient client(doppel.link(), 1'000'000);
    std::atomic<bool> stop{false};
    std::atomic<int> cycles{0};
    std::thread driver([&] { loop_at_100_hz(client, stop, cycles); });
    // A report with a found cycle while doppel still records (within 20 s: a loaded machine).
    const bool live = follow.wait_for(
        [](const std::string& out) {
          return out.find("still being written") != std::string::npos && !rates(out).empty();
        },
        20.0);
    // At least 150 cycles: they span 1.49 s or more (cycle k starts no earlier than tick k), so
    // --last 1 below normally sees only part of them.
    for (int guard = 0; live && cycles.load() < 150 && guard < 6000; ++guard) {
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    stop = true;
    driver.join();
    ASSERT_TRUE(live) << "stdout:\n" << follow.out() << "\nstderr:\n" << follow.err();
    const std::string during = follow.out();
    EXPECT_EQ(during.find("final report"), std::string::npos) << during;
    EXPECT_GT(rates(during).front(), 0.0) << during;  // how near 100 Hz: the driver's pace on this machine
    ASSERT_EQ(doppel.stop(15), 0);
  }
  // doppel closed the file: a final report, exit 0.
  ASSERT_EQ(follow.wait_exit(20.0), 0) << follow.out() << follow.err();
  const std::string out = follow.out();
  const std::string err = follow.err();
  EXPECT_NE(out.find("complete (doppel closed it): final report"), std::string::npos) << out;
  const std::vector<double> all = rates(out);
  ASSERT_GE(all.size(), 2u) << out;
  // The final report covers the whole file: its rate is the one of the recorded SYNC WRITEs' own
  // timestamps (not 100 Hz: how well the driver kept its pace depends on the machine's load).
  const Openers openers = sync_writes(file);
  ASSERT_GE(openers.first_seen_ns.size(), 3u);
  const double recorded_hz = 1e9 * static_cast<double>(openers.first_seen_ns.size() - 1) /
                             static_cast<double>(openers.first_seen_ns.back() - openers.first_seen_ns.front());
  EXPECT_NEAR(all.back(), recorded_hz, 0.051) << out;
  EXPECT_NE(out.find(": " + std::to_string(openers.first_seen_ns.size()) + " cycle starts"), std::string::npos) << out;
  EXPECT_NE(out.find("opener P1 SYNC WRITE on bus 0"), std::string::npos) << out;
  // Said once, not once per look.
  const std::size_t waiting = err.find("waiting for " + file);
  EXPECT_NE(waiting, std::string::npos) << err;
  EXPECT_EQ(err.find("waiting for " + file, waiting + 1), std::string::npos) << err;
  if (const char* keep = std::getenv("DOPPEL_FOLLOW_TEST_KEEP")) {  // to read what the tool printed
    std::ofstream(std::string(keep) + "/follow.out") << out;
    std::ofstream(std::string(keep) + "/follow.err") << err;
  }
  // Not a terminal: separator lines, no escape sequences.
  EXPECT_EQ(out.find('\x1b'), std::string::npos);

  // --last 1: the final second only (from the newest instruction back): the SYNC WRITEs in it.
  DoppelBus last({"--last", "1", file});
  ASSERT_EQ(last.wait_exit(30.0), 0) << last.err();
  const std::string last_out = last.out();
  std::smatch match;
  std::regex_search(last_out, match, std::regex(R"(: ([0-9]+) cycle starts)"));
  ASSERT_TRUE(match.size() == 2) << last.out();
  const auto in_last_second = std::count_if(openers.first_seen_ns.begin(), openers.first_seen_ns.end(),
                                            [&](int64_t t) { return t >= openers.newest_ns - 1'000'000'000; });
  EXPECT_EQ(std::stol(match[1].str()), in_last_second) << last.out();

  std::filesystem::remove(file);
}

TEST(FollowLive, WaitsForAFileThatDoesNotExistYetAndCtrlCEndsIt) {
  const std::string file = temp_file("never.mcap");
  std::filesystem::remove(file);
  DoppelBus follow({"--follow", "0.2", file});
  const auto until = Clock::now() + std::chrono::seconds(10);
  while (follow.err().find("waiting for") == std::string::npos && Clock::now() < until) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_NE(follow.err().find("waiting for " + file + " to appear"), std::string::npos) << follow.err();
  std::this_thread::sleep_for(std::chrono::milliseconds(600));
  follow.signal(SIGINT);
  EXPECT_EQ(follow.wait_exit(5.0), 0) << follow.err();
  EXPECT_EQ(follow.out(), "");
}

}  // namespace
}  // namespace doppel::analyzer
