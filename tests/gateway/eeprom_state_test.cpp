// The state file: its name, its refusal of foreign files, and atomic replacement under SIGKILL.
#include "eeprom_state.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <thread>

namespace doppel::gateway {
namespace {

RobotConfig robot(const std::string& model) {
  return parse_robot("name: \"r/1\"\nbus { baud_bps: 1000000 protocol: PROTOCOL_1 device { id: 3 model: \"" + model +
                         "\" name: \"S\" } }\n",
                     "robots/r.textproto");
}

std::string temp_dir() {
  char tmpl[] = "/tmp/doppel-eeprom-state-XXXXXX";
  return ::mkdtemp(tmpl);
}

std::string read_file(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(EepromState, FileNamesAreSafeAndPerRobotIndex) {
  const RobotConfig sut = robot("RX-64");
  EXPECT_EQ(state_file_path("/s", sut, 0), "/s/r_1.json");
  EXPECT_EQ(state_file_path("/s", sut, 2), "/s/r_1.robot2.json");
}

TEST(EepromState, WrittenStateReadsBackAndAnotherLayoutIsRefused) {
  const std::string dir = temp_dir();
  const RobotConfig rx64 = robot("RX-64");
  const RobotEeprom eeprom{{{0x40, 0x00, 0x18, 0x05, 0x01}}};
  write_file_atomically(dir + "/r.json", state_json(rx64, eeprom, {{64}}));
  const std::optional<RobotEeprom> back = read_state(dir + "/r.json", rx64);
  ASSERT_TRUE(back);
  EXPECT_EQ(*back, eeprom);
  EXPECT_FALSE(read_state(dir + "/none.json", rx64));
  try {
    read_state(dir + "/r.json", robot("RX-28"));
    ADD_FAILURE() << "another layout was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("state file " + dir + "/r.json: written for another bus/device layout"),
              std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("--fresh"), std::string::npos) << e.what();
  }
  std::ofstream(dir + "/bad.json") << "[1, 2";
  EXPECT_THROW(read_state(dir + "/bad.json", rx64), std::runtime_error);
  std::filesystem::remove_all(dir);
}

TEST(EepromState, UnwritableDirectoryIsNamed) {
  const std::string dir = temp_dir();
  std::ofstream(dir + "/file") << "x";
  try {
    prepare_state_dir(dir + "/file/state");
    ADD_FAILURE() << "a directory below a file was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("state directory " + dir + "/file/state"), std::string::npos) << e.what();
  }
  std::filesystem::remove_all(dir);
}

// A writer killed with SIGKILL at random moments while it replaces the file over and over: the
// file is always one of the two complete versions, never a mix or a truncated one.
TEST(EepromState, AKillLeavesTheOldFileOrTheNewOneNeverATornOne) {
  const std::string dir = temp_dir();
  const std::string path = dir + "/state.json";
  const std::string a(200000, 'a');
  const std::string b(150000, 'b');
  write_file_atomically(path, a);
  std::mt19937 random(7);
  for (int round = 0; round < 30; ++round) {
    const pid_t child = fork();
    if (child == 0) {
      for (int i = 0;; ++i) {
        write_file_atomically(path, i % 2 == 0 ? b : a);
      }
    }
    std::this_thread::sleep_for(std::chrono::microseconds(std::uniform_int_distribution<int>(500, 20000)(random)));
    ::kill(child, SIGKILL);
    ::waitpid(child, nullptr, 0);
    const std::string now = read_file(path);
    ASSERT_TRUE(now == a || now == b) << "round " << round << ": " << now.size() << " bytes";
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace doppel::gateway
