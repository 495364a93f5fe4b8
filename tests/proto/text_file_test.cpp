// Reading robot and session files defensively (issue 16): only regular files, a size cap, the
// reason when a file cannot be opened, and capped names and descriptions with their position.
#include "proto/text_file.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include "proto/robot_file.h"
#include "proto/session_file.h"

namespace doppel::proto {
namespace {

namespace fs = std::filesystem;

class TextFileRead : public ::testing::Test {
 protected:
  void SetUp() override {
    char dir_template[] = "/tmp/doppel-text-file-XXXXXX";
    ASSERT_NE(::mkdtemp(dir_template), nullptr);
    dir_ = dir_template;
  }
  void TearDown() override { fs::remove_all(dir_); }

  static std::string load_error(const std::string& path) {
    try {
      RobotFile::load(path);
    } catch (const std::exception& e) {
      return e.what();
    }
    return "no error";
  }

  std::string dir_;
};

TEST_F(TextFileRead, ADirectoryIsNamedAsSuch) {
  EXPECT_EQ(load_error(dir_), dir_ + ": cannot read robot description file: it is a directory");
}

TEST_F(TextFileRead, ADeviceIsRefusedAtOnce) {
  // Refused before any read: reading /dev/zero would never end (the test's timeout would catch
  // that hang), and the message names the kind of file, which only a stat before reading knows.
  EXPECT_EQ(load_error("/dev/zero"),
            "/dev/zero: cannot read robot description file: it is a character device, not a regular file");
}

TEST_F(TextFileRead, AFifoIsRefusedWithoutWaitingForAWriter) {
  const std::string fifo = dir_ + "/robot.textproto";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  EXPECT_EQ(load_error(fifo), fifo + ": cannot read robot description file: it is a FIFO, not a regular file");
}

TEST_F(TextFileRead, MissingFilesAndSymlinkLoopsSayWhy) {
  EXPECT_EQ(load_error(dir_ + "/none.textproto"),
            dir_ + "/none.textproto: cannot read robot description file: No such file or directory");
  fs::create_symlink(dir_ + "/b", dir_ + "/a");
  fs::create_symlink(dir_ + "/a", dir_ + "/b");
  EXPECT_EQ(load_error(dir_ + "/a"), dir_ + "/a: cannot read robot description file: Too many levels of symbolic links");
}

TEST_F(TextFileRead, AFileLargerThanTheLimitIsRefusedWithTheLimit) {
  const std::string big = dir_ + "/big.textproto";
  { std::ofstream(big) << "name: \"r\"\n"; }
  fs::resize_file(big, TextFile::kMaxBytes + 1);  // sparse: no 16 MiB written
  EXPECT_EQ(load_error(big), big + ": cannot read robot description file: it is larger than 16 MiB, the limit for text files");
}

TEST_F(TextFileRead, AFileAtTheLimitIsRead) {
  const std::string limit = dir_ + "/limit.textproto";
  {
    std::ofstream out(limit);
    out << "name: \"r\"\n#";
    out << std::string(TextFile::kMaxBytes - 12, 'x') << "\n";
  }
  ASSERT_EQ(fs::file_size(limit), TextFile::kMaxBytes);
  EXPECT_EQ(RobotFile::load(limit).description().name(), "r");
}

std::string parse_error(const std::string& text) {
  try {
    RobotFile::parse(text, "r.textproto");
  } catch (const std::exception& e) {
    return e.what();
  }
  return "no error";
}

TEST(TextFileStrings, NamesAreCappedWithTheirPosition) {
  const std::string longest(TextFile::kMaxNameChars, 'n');
  EXPECT_EQ(parse_error("name: \"" + longest + "\""), "no error");
  EXPECT_EQ(parse_error("\n  name: \"" + longest + "n\""),
            "r.textproto:2:3: RobotDescription.name: 65 characters, more than the 64 allowed");
  EXPECT_EQ(parse_error("name: \"r\"\nbus {\n  device { id: 1 model: \"" + longest + "m\" }\n}\n"),
            "r.textproto:3:18: Device.model: 65 characters, more than the 64 allowed");
}

TEST(TextFileStrings, AHugeNameIsNotEchoed) {
  const std::string error = parse_error("name: \"" + std::string(1'000'000, 'n') + "\"");
  EXPECT_LT(error.size(), 200u) << error.substr(0, 200);
  EXPECT_NE(error.find("RobotDescription.name: 1000000 characters"), std::string::npos) << error.substr(0, 200);
}

TEST(TextFileStrings, DescriptionsHaveARoomierCap) {
  const std::string longest(TextFile::kMaxDescriptionChars, 'd');
  EXPECT_EQ(parse_error("description: \"" + longest + "\""), "no error");
  EXPECT_EQ(parse_error("description: \"" + longest + "d\""),
            "r.textproto:1:1: RobotDescription.description: 1025 characters, more than the 1024 allowed");
}

TEST(TextFileStrings, SessionFilesAreCappedToo) {
  try {
    SessionFile::parse("camera {\n  name: \"" + std::string(65, 'c') + "\"\n}\n", "s.textproto");
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "s.textproto:2:3: WorldCamera.name: 65 characters, more than the 64 allowed");
  }
}

}  // namespace
}  // namespace doppel::proto
