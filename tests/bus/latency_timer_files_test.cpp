#include "bus/latency_timer_files.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "served_bus.h"

namespace doppel::bus {
namespace {

using namespace testing;

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

void write_text(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

template <class Pred>
bool eventually(Pred done) {
  for (int i = 0; i < 200; ++i) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return false;
}

BusServerOptions wire_with_latency(uint32_t latency_ms) {
  BusServerOptions options;
  options.adapter_latency_ms = latency_ms;
  return options;
}

TEST(LatencyTimerFiles, HoldsTheBusLatencyAndAWrittenValueReachesTheServer) {
  ServedBus bus(wire_with_latency(16), {});
  const std::string path = LatencyTimerFiles::path_for_link(bus.path());
  std::ostringstream messages;
  {
    LatencyTimerFiles sut(messages);
    sut.add(path, bus.server());
    EXPECT_EQ(read_text(path), "16\n");
    sut.start();

    write_text(path, "1\n");

    EXPECT_TRUE(eventually([&] { return bus.server().adapter_latency_ms() == 1; }));
    sut.stop();
  }
  EXPECT_NE(messages.str().find(path + ": USB latency timer 16 -> 1 ms"), std::string::npos) << messages.str();
  EXPECT_FALSE(std::filesystem::exists(path));  // removed with the watcher
}

TEST(LatencyTimerFiles, BadTextIsRefusedNamedAndReplacedByTheValueInForce) {
  ServedBus bus(wire_with_latency(16), {});
  const std::string path = LatencyTimerFiles::path_for_link(bus.path());
  std::ostringstream messages;
  LatencyTimerFiles sut(messages);
  sut.add(path, bus.server());
  sut.start();

  write_text(path, "0\n");

  EXPECT_TRUE(eventually([&] { return read_text(path) == "16\n"; }));
  sut.stop();
  EXPECT_EQ(bus.server().adapter_latency_ms(), 16u);
  EXPECT_NE(messages.str().find(path + ": '0' is not a latency timer in 1..255 ms; it stays 16 ms"), std::string::npos)
      << messages.str();
}

TEST(LatencyTimerFiles, AFileSomeoneReplacedIsLeftAtExit) {
  ServedBus bus(wire_with_latency(16), {});
  const std::string path = LatencyTimerFiles::path_for_link(bus.path());
  std::ostringstream messages;
  {
    LatencyTimerFiles sut(messages);
    sut.add(path, bus.server());
    ASSERT_EQ(::unlink(path.c_str()), 0);
    write_text(path, "5\n");  // a new inode
  }
  EXPECT_EQ(read_text(path), "5\n");
}

TEST(LatencyTimerFiles, AStaleSymlinkIsNeverFollowed) {
  ServedBus bus(wire_with_latency(16), {});
  const std::string path = LatencyTimerFiles::path_for_link(bus.path());
  const std::string target = bus.path() + ".elsewhere";
  write_text(target, "keep\n");
  std::filesystem::create_symlink(target, path);
  std::ostringstream messages;
  LatencyTimerFiles sut(messages);
  EXPECT_THROW(sut.add(path, bus.server()), std::runtime_error);
  EXPECT_EQ(read_text(target), "keep\n");
}

}  // namespace
}  // namespace doppel::bus
