#include "bus/link_directory.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "bus/pty_port.h"
#include "pty_test_support.h"

namespace doppel::bus {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;

mode_t mode_of(const std::string& path) {
  struct stat st {};
  EXPECT_EQ(::lstat(path.c_str(), &st), 0) << path;
  return st.st_mode & 07777;
}

// Runs `make` and returns the UnsafeLinkDirectory message ("" when nothing was thrown).
template <class Make>
std::string refusal(Make make) {
  try {
    make();
  } catch (const UnsafeLinkDirectory& e) {
    return e.what();
  }
  return "";
}

TEST(LinkDirectory, CreatesMissingDirectoriesPrivateAndRemovesThemWhenEmpty) {
  TempDir dir;
  const std::string path = dir.file("nested/links");
  std::ostringstream warnings;
  {
    LinkDirectory sut(path, false, warnings);
    EXPECT_EQ(sut.path(), path);
    EXPECT_TRUE(fs::is_directory(path));
    EXPECT_EQ(mode_of(dir.file("nested")), 0700u);
    EXPECT_EQ(mode_of(path), 0700u);
    EXPECT_EQ(sut.subdirectory("robot1"), path + "/robot1");
    EXPECT_EQ(mode_of(path + "/robot1"), 0700u);
    PtyPort port(path + "/robot1/ttyDXL0");
  }
  EXPECT_FALSE(fs::exists(dir.file("nested"))) << "created directories are removed at exit";
  EXPECT_EQ(warnings.str(), "");
}

TEST(LinkDirectory, KeepsDirectoriesItDidNotCreateOrThatAreNotEmpty) {
  TempDir dir;
  const std::string path = dir.file("links");
  fs::create_directory(path);
  fs::permissions(path, fs::perms::owner_all);
  std::ostringstream warnings;
  {
    LinkDirectory sut(path, false, warnings);
    sut.subdirectory("robot1");
    sut.subdirectory("robot2");
    std::ofstream(path + "/robot2/someone-elses-file") << "x";
  }
  EXPECT_TRUE(fs::is_directory(path));
  EXPECT_FALSE(fs::exists(path + "/robot1"));
  EXPECT_TRUE(fs::exists(path + "/robot2/someone-elses-file"));
}

// The attack: `ln -s /some/dir /tmp/doppel` beforehand made doppel put its links there.
TEST(LinkDirectory, RefusesASymlinkedDirectory) {
  TempDir dir;
  const std::string elsewhere = dir.file("elsewhere");
  fs::create_directory(elsewhere);
  fs::permissions(elsewhere, fs::perms::owner_all);
  const std::string path = dir.file("links");
  fs::create_directory_symlink(elsewhere, path);
  std::ostringstream warnings;

  const std::string said = refusal([&] { LinkDirectory sut(path, false, warnings); });

  EXPECT_NE(said.find("'" + path + "'"), std::string::npos) << said;
  EXPECT_NE(said.find("symbolic link"), std::string::npos) << said;
  EXPECT_NE(said.find(elsewhere), std::string::npos) << said;
  EXPECT_TRUE(fs::is_empty(elsewhere));
}

TEST(LinkDirectory, RefusesASymlinkedRobotSubdirectory) {
  TempDir dir;
  const std::string elsewhere = dir.file("elsewhere");
  fs::create_directory(elsewhere);
  std::ostringstream warnings;
  LinkDirectory sut(dir.file("links"), false, warnings);
  fs::create_directory_symlink(elsewhere, dir.file("links/robot1"));

  const std::string said = refusal([&] { sut.subdirectory("robot1"); });

  EXPECT_NE(said.find(dir.file("links/robot1")), std::string::npos) << said;
  EXPECT_NE(said.find("symbolic link"), std::string::npos) << said;
}

TEST(LinkDirectory, RefusesADirectoryWritableByOthers) {
  TempDir dir;
  const std::string path = dir.file("links");
  fs::create_directory(path);
  ASSERT_EQ(::chmod(path.c_str(), 0777), 0);
  std::ostringstream warnings;

  const std::string said = refusal([&] { LinkDirectory sut(path, false, warnings); });

  EXPECT_NE(said.find("'" + path + "'"), std::string::npos) << said;
  EXPECT_NE(said.find("writable by group or others (mode 0777)"), std::string::npos) << said;
  EXPECT_TRUE(fs::is_directory(path)) << "a directory it did not create stays";
}

TEST(LinkDirectory, RefusesAnotherUsersDirectory) {
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to give a directory to another user";
  TempDir dir;
  const std::string path = dir.file("links");
  fs::create_directory(path);
  ASSERT_EQ(::chmod(path.c_str(), 0755), 0);
  ASSERT_EQ(::chown(path.c_str(), 65534, 65534), 0);
  std::ostringstream warnings;

  const std::string said = refusal([&] { LinkDirectory sut(path, false, warnings); });

  EXPECT_NE(said.find("'" + path + "'"), std::string::npos) << said;
  EXPECT_NE(said.find("belongs to uid 65534"), std::string::npos) << said;
}

TEST(LinkDirectory, RefusesAParentThatAnotherUserCanReplace) {
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to give a directory to another user";
  TempDir dir;
  fs::create_directory(dir.file("theirs"));
  ASSERT_EQ(::chown(dir.file("theirs").c_str(), 65534, 65534), 0);
  std::ostringstream warnings;

  const std::string said = refusal([&] { LinkDirectory sut(dir.file("theirs/links"), false, warnings); });

  EXPECT_NE(said.find("parent directory belongs to uid 65534"), std::string::npos) << said;
}

TEST(LinkDirectory, AllowSharedAcceptsWithAWarning) {
  TempDir dir;
  const std::string path = dir.file("links");
  fs::create_directory(path);
  ASSERT_EQ(::chmod(path.c_str(), 0777), 0);
  std::ostringstream warnings;

  LinkDirectory sut(path, true, warnings);
  PtyPort port(path + "/ttyDXL0");

  EXPECT_NE(warnings.str().find("warning: link directory '" + path + "'"), std::string::npos) << warnings.str();
  EXPECT_NE(warnings.str().find("mode 0777"), std::string::npos) << warnings.str();
}

TEST(LinkDirectory, RefusesAFileInItsPlace) {
  TempDir dir;
  std::ofstream(dir.file("links")) << "x";
  std::ostringstream warnings;

  try {
    LinkDirectory sut(dir.file("links"), false, warnings);
    FAIL() << "expected std::runtime_error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("is not a directory"), std::string::npos) << e.what();
  }
}

class DefaultLinkDir : public ::testing::Test {
 protected:
  void SetUp() override {
    if (const char* runtime = std::getenv("XDG_RUNTIME_DIR")) saved_ = runtime;
  }
  void TearDown() override {
    if (saved_.empty()) {
      ::unsetenv("XDG_RUNTIME_DIR");
    } else {
      ::setenv("XDG_RUNTIME_DIR", saved_.c_str(), 1);
    }
  }
  std::string saved_;
};

TEST_F(DefaultLinkDir, IsUnderAPrivateRuntimeDirectory) {
  TempDir dir;
  ::setenv("XDG_RUNTIME_DIR", dir.path().c_str(), 1);
  EXPECT_EQ(default_link_dir(), dir.file("doppel"));
}

TEST_F(DefaultLinkDir, FallsBackToAPerUserDirectoryInTmp) {
  ::unsetenv("XDG_RUNTIME_DIR");
  const std::string fallback = default_link_dir();
  EXPECT_EQ(fallback.rfind("/tmp/doppel-", 0), 0u) << fallback;
  EXPECT_NE(fallback, "/tmp/doppel-");

  TempDir shared;
  ASSERT_EQ(::chmod(shared.path().c_str(), 0777), 0);
  ::setenv("XDG_RUNTIME_DIR", shared.path().c_str(), 1);
  EXPECT_EQ(default_link_dir(), fallback) << "a runtime directory others can write is not used";
  ::setenv("XDG_RUNTIME_DIR", "relative/dir", 1);
  EXPECT_EQ(default_link_dir(), fallback);
}

}  // namespace
}  // namespace doppel::bus
