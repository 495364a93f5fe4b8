// lockstep::Coordinator against the clock file as the preload library sees it: the test maps the
// file itself and plays the controller's threads by writing their slots, as lockstep_shim.cpp does.
#include "lockstep/coordinator.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <atomic>
#include <filesystem>
#include <sstream>
#include <string>
#include <thread>

namespace doppel::lockstep {
namespace {

class CoordinatorTest : public ::testing::Test {
 protected:
  CoordinatorTest()
      : dir_(std::filesystem::temp_directory_path() / ("doppel-coordinator-" + std::to_string(::getpid()))) {
    std::filesystem::create_directories(dir_);
    path_ = dir_ + "/" + kClockFileName;
  }
  ~CoordinatorTest() override {
    if (file_ != nullptr) ::munmap(file_, sizeof(ClockFile));
    std::filesystem::remove_all(dir_);
  }

  // The file as a controller maps it.
  ClockFile& map() {
    const int fd = ::open(path_.c_str(), O_RDWR | O_CLOEXEC);
    EXPECT_GE(fd, 0);
    void* memory = ::mmap(nullptr, sizeof(ClockFile), PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
    ::close(fd);
    EXPECT_NE(memory, MAP_FAILED);
    file_ = static_cast<ClockFile*>(memory);
    return *file_;
  }

  // Slot `i` as a thread of this process that waits with `flags` (as begin_wait does).
  static void wait(ClockFile& file, std::size_t i, uint32_t flags, int64_t wake_ns, pid_t pid = ::getpid(),
                   pid_t tid = static_cast<pid_t>(::syscall(SYS_gettid))) {
    ThreadSlot& slot = file.threads[i];
    slot.pid = pid;
    slot.tid = tid;
    slot.flags = flags;
    slot.wake_ns = wake_ns;
    slot.event_mark = file.events.load();
    slot.delivery_mark = file.deliveries.load();
    slot.state = kWaiting;
    if (file.slots_used.load() < i + 1) file.slots_used = static_cast<uint32_t>(i + 1);
  }

  std::string dir_;
  std::string path_;
  ClockFile* file_ = nullptr;
};

TEST_F(CoordinatorTest, PublishesTheFileWithItsBusesAndRemovesItAtTheEnd) {
  {
    CoordinatorOptions options;
    options.epoch_realtime_ns = 1'767'225'600'000'000'000;
    options.start_ns = 42;
    Coordinator coordinator(path_, {{"/d/ttyDXL0", "/dev/pts/7"}, {"/d/ttyDXL1", "/dev/pts/8"}}, options);
    ClockFile& file = map();
    EXPECT_EQ(file.magic, kMagic);
    EXPECT_EQ(file.version, kVersion);
    EXPECT_EQ(file.bus_count, 2u);
    EXPECT_STREQ(file.buses[1].slave, "/dev/pts/8");
    EXPECT_STREQ(file.buses[0].link, "/d/ttyDXL0");
    EXPECT_EQ(file.epoch_realtime_ns, 1'767'225'600'000'000'000);
    EXPECT_EQ(coordinator.now_ns(), 42);
    EXPECT_EQ(file.open.load(), 1u);
    EXPECT_FALSE(std::filesystem::exists(path_ + ".new"));
  }
  EXPECT_FALSE(std::filesystem::exists(path_));
  EXPECT_EQ(file_->open.load(), 0u);  // a controller still mapping it passes through from now on
}

TEST_F(CoordinatorTest, WakesTheEarliestDeadlineFirstAndOnlyWhenItsTimeHasCome) {
  Coordinator coordinator(path_, {});
  ClockFile& file = map();
  wait(file, 0, kUntilTime, 5'000'000);
  wait(file, 1, kUntilTime, 3'000'000);
  const std::atomic<bool> stop{false};
  EXPECT_TRUE(coordinator.settle(stop));
  EXPECT_EQ(coordinator.threads(), 2u);
  EXPECT_EQ(coordinator.earliest_wake_ns(), 3'000'000);
  EXPECT_FALSE(coordinator.wake_one());  // nobody's time has come at 0
  coordinator.advance_to(3'000'000);
  const uint32_t seq = file.threads[1].wake_seq.load();
  EXPECT_TRUE(coordinator.wake_one());
  EXPECT_EQ(file.threads[1].state.load(), kRunning);
  EXPECT_EQ(file.threads[1].wake_seq.load(), seq + 1);  // the futex word it sleeps on moved
  EXPECT_EQ(file.threads[0].state.load(), kWaiting);
  EXPECT_FALSE(coordinator.wake_one());
  EXPECT_EQ(file.sim_ns.load(), 3'000'000);
  coordinator.advance_to(1'000'000);  // never backwards
  EXPECT_EQ(coordinator.now_ns(), 3'000'000);
}

TEST_F(CoordinatorTest, NextEventAndDeliveryWaitsWakeOnTheirEventsOnly) {
  Coordinator coordinator(path_, {{"/d/ttyDXL0", "/dev/pts/7"}});
  ClockFile& file = map();
  wait(file, 0, kNextEvent, kNever);
  wait(file, 1, kDelivery, kNever);
  EXPECT_FALSE(coordinator.wake_one());
  coordinator.set_delivered(0, 0);  // nothing new: no event
  EXPECT_FALSE(coordinator.wake_one());
  coordinator.advance_to(1'000'000);  // time passes: the next-event waiter, not the delivery waiter
  EXPECT_TRUE(coordinator.wake_one());
  EXPECT_EQ(file.threads[0].state.load(), kRunning);
  EXPECT_FALSE(coordinator.wake_one());
  coordinator.set_delivered(0, 8);
  EXPECT_EQ(file.buses[0].delivered.load(), 8u);
  EXPECT_TRUE(coordinator.wake_one());
  EXPECT_EQ(file.threads[1].state.load(), kRunning);
}

TEST_F(CoordinatorTest, PeerWaitsAreNeverWokenByDoppel) {
  Coordinator coordinator(path_, {});
  ClockFile& file = map();
  wait(file, 0, kPeer, kNever);
  coordinator.advance_to(1'000'000'000);
  EXPECT_FALSE(coordinator.wake_one());
  EXPECT_EQ(coordinator.earliest_wake_ns(), kNever);
}

TEST_F(CoordinatorTest, ASlotOfAProcessThatIsGoneIsRemoved) {
  Coordinator coordinator(path_, {});
  ClockFile& file = map();
  const pid_t child = ::fork();
  if (child == 0) ::_exit(0);
  ::waitpid(child, nullptr, 0);
  wait(file, 0, 0, kNever, child, child);
  file.threads[0].state = kRunning;  // it was running when it died
  const std::atomic<bool> stop{false};
  EXPECT_TRUE(coordinator.settle(stop));  // returns once the dead thread is removed
  EXPECT_EQ(coordinator.threads_removed(), 1u);
  EXPECT_EQ(file.threads[0].state.load(), kFree);
}

TEST_F(CoordinatorTest, ASlotOfAProcessThatExitedButWasNotReapedIsRemoved) {
  Coordinator coordinator(path_, {});
  ClockFile& file = map();
  const pid_t child = ::fork();
  if (child == 0) ::_exit(0);
  wait(file, 0, 0, kNever, child, child);
  file.threads[0].state = kRunning;
  const std::atomic<bool> stop{false};
  EXPECT_TRUE(coordinator.settle(stop));  // a zombie answers kill(0): its /proc state says it is gone
  EXPECT_EQ(file.threads[0].state.load(), kFree);
  ::waitpid(child, nullptr, 0);
}

TEST_F(CoordinatorTest, TheWatchdogNamesAThreadThatRunsWithoutWaiting) {
  std::ostringstream report;
  CoordinatorOptions options;
  options.watchdog_ns = 100'000'000;
  options.report = &report;
  Coordinator coordinator(path_, {}, options);
  ClockFile& file = map();
  const pid_t tid = static_cast<pid_t>(::syscall(SYS_gettid));
  wait(file, 0, 0, kNever, ::getpid(), tid);
  file.threads[0].state = kRunning;
  file.threads[0].last_call = static_cast<uint32_t>(Call::kClockGettime);
  file.threads[0].clock_reads = 7;
  std::atomic<bool> stop{false};
  std::thread stopper([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(600));
    stop = true;
  });
  EXPECT_FALSE(coordinator.settle(stop));  // the thread never waits: only stop ends it
  stopper.join();
  EXPECT_GE(coordinator.watchdog_reports(), 1u);
  const std::string text = report.str();
  EXPECT_NE(text.find("lockstep watchdog: controller thread " + std::to_string(tid)), std::string::npos) << text;
  EXPECT_NE(text.find("its last intercepted call: clock_gettime (7 clock reads in a row)"), std::string::npos) << text;
  EXPECT_EQ(file.threads[0].state.load(), kRunning);  // reported, not removed: it is alive
}

TEST_F(CoordinatorTest, StoppingWakesEveryWaitingThread) {
  auto coordinator = std::make_unique<Coordinator>(path_, std::vector<LockstepBus>{});
  ClockFile& file = map();
  wait(file, 0, kUntilTime, 5'000'000);
  coordinator.reset();
  EXPECT_EQ(file.threads[0].state.load(), kRunning);
  EXPECT_EQ(file.open.load(), 0u);
}

TEST_F(CoordinatorTest, TooManyBusesOrTooLongPathsAreRefused) {
  EXPECT_THROW(Coordinator(path_, std::vector<LockstepBus>(kMaxBuses + 1)), std::invalid_argument);
  EXPECT_THROW(Coordinator(path_, {{std::string(kPathBytes, 'x'), "/dev/pts/1"}}), std::invalid_argument);
  EXPECT_THROW(Coordinator(dir_ + "/missing/" + kClockFileName, {}), std::runtime_error);
}

}  // namespace
}  // namespace doppel::lockstep
