#include "bus/pty_port.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <termios.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "pty_test_support.h"

namespace doppel::bus {
namespace {

using namespace std::chrono_literals;
using testing::ClientFd;
using testing::open_client;
using testing::read_available;
using testing::read_bytes;
using testing::TempDir;
using testing::write_all;

constexpr int64_t kSecondNs = 1'000'000'000;

std::string link_target(const std::string& link) {
  std::error_code ec;
  return std::filesystem::read_symlink(link, ec).string();
}

// Reads from the port until `n` bytes came, the client hung up, or one second passed.
std::vector<uint8_t> port_read(PtyPort& port, std::size_t n) {
  std::vector<uint8_t> out;
  const auto deadline = std::chrono::steady_clock::now() + 1s;
  while (out.size() < n && std::chrono::steady_clock::now() < deadline && !port.hung_up()) {
    port.wait(10'000'000, false);
    uint8_t buffer[64];
    const std::size_t got = port.read(buffer, sizeof(buffer));
    out.insert(out.end(), buffer, buffer + got);
  }
  return out;
}

// Reads until the port reports the hang-up (or one second passed); returns the bytes seen.
std::vector<uint8_t> port_read_until_hang_up(PtyPort& port) {
  return port_read(port, std::numeric_limits<std::size_t>::max());
}

TEST(PtyPort, PointsLinkAtSlave) {
  TempDir dir;
  const std::string link = dir.file("ttyDXL0");

  PtyPort sut(link);

  EXPECT_EQ(link_target(link), sut.slave_path());
  EXPECT_EQ(sut.slave_path().rfind("/dev/pts/", 0), 0u);
  EXPECT_EQ(sut.link_path(), link);
}

// Creating directories is LinkDirectory's job (tests/bus/link_directory_test.cpp): it does not
// follow symlinks, create_directories did.
TEST(PtyPort, RefusesAMissingDirectoryInsteadOfCreatingIt) {
  TempDir dir;
  const std::string link = dir.file("nested/dir/ttyDXL0");

  try {
    PtyPort sut(link);
    FAIL() << "expected std::runtime_error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(dir.file("nested/dir")), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("does not exist"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(dir.file("nested")));
}

TEST(PtyPort, ReplacesStaleLink) {
  TempDir dir;
  std::filesystem::create_directories(dir.path());
  const std::string link = dir.file("ttyDXL0");
  std::filesystem::create_symlink("/dev/pts/does-not-exist", link);

  PtyPort sut(link);

  EXPECT_EQ(link_target(link), sut.slave_path());
}

TEST(PtyPort, RefusesToReplaceARegularFile) {
  TempDir dir;
  std::filesystem::create_directories(dir.path());
  const std::string path = dir.file("ttyDXL0");
  std::ofstream(path) << "precious";

  try {
    PtyPort sut(path);
    FAIL() << "expected std::runtime_error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("not a symbolic link"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
  std::ifstream in(path);
  std::string content;
  in >> content;
  EXPECT_EQ(content, "precious");
}

// kOnPublish: the server publishes the link once its thread serves the port (gateway's
// BusRuntime::start); until then nothing at the link's name leads to this pty or to a stale one.
TEST(PtyPort, OnPublishTheLinkAppearsOnlyWhenPublishedAndAStaleOneGoesAtOnce) {
  TempDir dir;
  std::filesystem::create_directories(dir.path());
  const std::string link = dir.file("ttyDXL0");
  std::filesystem::create_symlink("/dev/pts/does-not-exist", link);
  {
    PtyPort sut(link, LinkTiming::kOnPublish);
    EXPECT_FALSE(std::filesystem::is_symlink(link)) << "the stale link is removed, no new one yet";
    EXPECT_FALSE(sut.link_published());

    sut.publish_link();
    EXPECT_TRUE(sut.link_published());
    EXPECT_EQ(link_target(link), sut.slave_path());
    sut.publish_link();  // a second call changes nothing
    EXPECT_EQ(link_target(link), sut.slave_path());
  }
  EXPECT_FALSE(std::filesystem::is_symlink(link)) << "removed on destruction like a kNow port's";
}

TEST(PtyPort, OnPublishRefusesARegularFileAtOnceAndAnUnpublishedPortLeavesOthersLinksAlone) {
  TempDir dir;
  std::filesystem::create_directories(dir.path());
  const std::string path = dir.file("ttyDXL0");
  std::ofstream(path) << "precious";
  EXPECT_THROW({ PtyPort refused(path, LinkTiming::kOnPublish); }, std::runtime_error);
  std::filesystem::remove(path);
  {
    PtyPort sut(path, LinkTiming::kOnPublish);
    std::filesystem::create_symlink("/dev/null", path);  // someone else's link appears meanwhile
    EXPECT_EQ(sut.release_link(), PtyPort::LinkRelease::kGone);
  }
  EXPECT_EQ(link_target(path), "/dev/null");
}

TEST(PtyPort, RemovesItsLinkOnDestruction) {
  TempDir dir;
  const std::string link = dir.file("ttyDXL0");

  { PtyPort sut(link); }

  EXPECT_FALSE(std::filesystem::is_symlink(link));
}

TEST(PtyPort, LeavesAReplacedLinkAloneAndSaysSo) {
  TempDir dir;
  const std::string link = dir.file("ttyDXL0");
  const std::string foreign = dir.file("attacker-device");
  std::ofstream(foreign) << "not a servo";
  auto sut = std::make_unique<PtyPort>(link);
  // What another user did in the issue: ln -sfn TARGET tmp; mv -T tmp ttyDXL0.
  std::filesystem::create_symlink(foreign, dir.file("tmp"));
  std::filesystem::rename(dir.file("tmp"), link);

  ::testing::internal::CaptureStderr();
  sut.reset();
  const std::string said = ::testing::internal::GetCapturedStderr();

  EXPECT_EQ(link_target(link), foreign);
  EXPECT_NE(said.find(link), std::string::npos) << said;
  EXPECT_NE(said.find("replaced"), std::string::npos) << said;
}

TEST(PtyPort, ReleaseLinkTellsRemovedFromReplaced) {
  TempDir dir;
  const std::string link = dir.file("ttyDXL0");
  PtyPort kept(link);
  EXPECT_EQ(kept.release_link(), PtyPort::LinkRelease::kRemoved);
  EXPECT_FALSE(std::filesystem::is_symlink(link));
  EXPECT_EQ(kept.release_link(), PtyPort::LinkRelease::kGone);

  PtyPort replaced(link);
  std::filesystem::remove(link);
  std::filesystem::create_symlink(replaced.slave_path() + "-not", link);
  EXPECT_EQ(replaced.release_link(), PtyPort::LinkRelease::kReplaced);
  EXPECT_TRUE(std::filesystem::is_symlink(link));
}

TEST(PtyPort, LeavesALinkOwnedByAnotherUserEvenIfItPointsAtTheSlave) {
  TempDir dir;
  const std::string link = dir.file("ttyDXL0");
  PtyPort sut(link);
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to give the link to another user";
  ASSERT_EQ(::lchown(link.c_str(), 65534, 65534), 0);

  EXPECT_EQ(sut.release_link(), PtyPort::LinkRelease::kReplaced);
  EXPECT_TRUE(std::filesystem::is_symlink(link));
}

TEST(PtyPort, LeavesALinkTakenOverByAnotherPort) {
  TempDir dir;
  const std::string link = dir.file("ttyDXL0");
  auto first = std::make_unique<PtyPort>(link);
  PtyPort second(link);

  first.reset();

  EXPECT_EQ(link_target(link), second.slave_path());
}

TEST(PtyPort, SlaveIsInRawMode) {
  TempDir dir;
  PtyPort sut(dir.file("ttyDXL0"));
  ClientFd client(open_client(sut.link_path()));
  ASSERT_GE(client, 0);

  termios tio{};
  ASSERT_EQ(::tcgetattr(client, &tio), 0);

  EXPECT_EQ(tio.c_lflag & (ECHO | ICANON | ISIG | IEXTEN), 0u);
  EXPECT_EQ(tio.c_iflag & (ICRNL | IXON | ISTRIP | INLCR | IGNCR), 0u);
  EXPECT_EQ(tio.c_oflag & OPOST, 0u);
  EXPECT_EQ(tio.c_cflag & CSIZE, static_cast<tcflag_t>(CS8));
}

TEST(PtyPort, BytesPassUnchangedBothWays) {
  TempDir dir;
  PtyPort sut(dir.file("ttyDXL0"));
  ClientFd client(open_client(sut.link_path()));
  ASSERT_GE(client, 0);
  ASSERT_TRUE(sut.wait_for_client(kSecondNs));
  // CR, LF, ^C, XON/XOFF, ^D, DEL and 0xFF: all special to a cooked terminal.
  const std::vector<uint8_t> awkward{0x0D, 0x0A, 0x03, 0x11, 0x13, 0x04, 0x7F, 0xFF, 0x00};

  ASSERT_TRUE(write_all(client, awkward));
  const auto at_doppel = port_read(sut, awkward.size());
  ASSERT_EQ(sut.write(awkward.data(), awkward.size()), awkward.size());
  const auto at_client = read_bytes(client, awkward.size(), 1s);

  EXPECT_EQ(at_doppel, awkward);
  EXPECT_EQ(at_client, awkward);
}

// What doppel-run's preload library reads (base/pty_handover.h): the file mapped as another process maps it.
uint64_t received_in_file(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return std::numeric_limits<uint64_t>::max();
  void* p = ::mmap(nullptr, sizeof(uint64_t), PROT_READ, MAP_SHARED, fd, 0);
  ::close(fd);
  if (p == MAP_FAILED) return std::numeric_limits<uint64_t>::max();
  const uint64_t value = static_cast<const std::atomic<uint64_t>*>(p)->load(std::memory_order_acquire);
  ::munmap(p, sizeof(uint64_t));
  return value;
}

TEST(PtyPort, CountsTheBytesItReadInTheHandOverFileBesideTheLink) {
  TempDir dir;
  PtyPort sut(dir.file("ttyDXL0"));
  const std::string counter = dir.file("ttyDXL0.received");
  EXPECT_EQ(PtyPort::received_path_for_link(sut.link_path()), counter);
  EXPECT_EQ(std::filesystem::file_size(counter), 8u);
  EXPECT_EQ(received_in_file(counter), 0u);
  {
    ClientFd client(open_client(sut.link_path()));
    ASSERT_TRUE(sut.wait_for_client(kSecondNs));
    ASSERT_TRUE(write_all(client, {0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB}));
    ASSERT_EQ(port_read(sut, 6).size(), 6u);
    // The client is let go only once a read found nothing left: that read waited for the
    // kernel's hand-over to finish (see pty_port.h), as BusServer reads until then.
    EXPECT_EQ(received_in_file(counter), 0u);
    uint8_t none[8];
    EXPECT_EQ(sut.read(none, sizeof(none)), 0u);
    EXPECT_EQ(received_in_file(counter), 6u);
  }
  port_read_until_hang_up(sut);
  sut.disconnect();
  // A later client's bytes add to it: it never goes back, across sessions.
  ClientFd client(open_client(sut.link_path()));
  ASSERT_TRUE(sut.wait_for_client(kSecondNs));
  ASSERT_TRUE(write_all(client, {0xFF, 0xFF, 0x01, 0x02}));
  ASSERT_EQ(port_read(sut, 4).size(), 4u);
  uint8_t none[8];
  EXPECT_EQ(sut.read(none, sizeof(none)), 0u);
  EXPECT_EQ(received_in_file(counter), 10u);
  EXPECT_EQ(sut.received(), 10u);
}

TEST(PtyPort, StartsAStaleHandOverFileAfreshAndRemovesItOnDestruction) {
  TempDir dir;
  std::filesystem::create_directories(dir.path());
  const std::string counter = dir.file("ttyDXL0.received");
  std::ofstream(counter) << "left by a doppel that was killed";
  {
    PtyPort sut(dir.file("ttyDXL0"));
    EXPECT_EQ(std::filesystem::file_size(counter), 8u);
    EXPECT_EQ(received_in_file(counter), 0u);
  }
  EXPECT_FALSE(std::filesystem::exists(counter));
}

TEST(PtyPort, RefusesAHandOverPathThatIsNotARegularFileAndLeavesNoLink) {
  TempDir dir;
  std::filesystem::create_directories(dir.path());
  const std::string counter = dir.file("ttyDXL0.received");
  std::filesystem::create_directories(counter);  // a directory where the counter goes
  try {
    PtyPort sut(dir.file("ttyDXL0"));
    FAIL() << "expected std::runtime_error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(counter), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("not a regular file"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::is_symlink(dir.file("ttyDXL0")));
  EXPECT_TRUE(std::filesystem::is_directory(counter));
}

TEST(PtyPort, LeavesAReplacedHandOverFileAlone) {
  TempDir dir;
  const std::string counter = dir.file("ttyDXL0.received");
  {
    PtyPort sut(dir.file("ttyDXL0"));
    std::filesystem::remove(counter);
    std::ofstream(counter) << "someone else's";
  }
  std::ifstream in(counter);
  std::string first;
  in >> first;
  EXPECT_EQ(first, "someone");
}

TEST(PtyPort, ReadsBackStandardBaudRateSetByClient) {
  TempDir dir;
  PtyPort sut(dir.file("ttyDXL0"));
  ClientFd client(open_client(sut.link_path()));
  ASSERT_GE(client, 0);
  termios tio{};
  ASSERT_EQ(::tcgetattr(client, &tio), 0);

  ASSERT_EQ(::cfsetspeed(&tio, B1000000), 0);
  ASSERT_EQ(::tcsetattr(client, TCSANOW, &tio), 0);
  const uint32_t at_1m = sut.line_baud_bps();
  ASSERT_EQ(::cfsetspeed(&tio, B57600), 0);
  ASSERT_EQ(::tcsetattr(client, TCSANOW, &tio), 0);
  const uint32_t at_57k = sut.line_baud_bps();

  EXPECT_EQ(at_1m, 1'000'000u);
  EXPECT_EQ(at_57k, 57'600u);
}

TEST(PtyPort, NotConnectedUntilAClientOpens) {
  TempDir dir;
  PtyPort sut(dir.file("ttyDXL0"));

  const bool before = sut.poll_client();
  const bool timed_out = sut.wait_for_client(10'000'000);
  ClientFd client(open_client(sut.link_path()));
  ASSERT_GE(client, 0);
  const bool after = sut.wait_for_client(kSecondNs);

  EXPECT_FALSE(before);
  EXPECT_FALSE(timed_out);
  EXPECT_TRUE(after);
  EXPECT_TRUE(sut.connected());
}

TEST(PtyPort, WritesNothingWhileNoClientIsConnected) {
  TempDir dir;
  PtyPort sut(dir.file("ttyDXL0"));
  const uint8_t bytes[] = {1, 2, 3};

  EXPECT_EQ(sut.write(bytes, 3), 0u);
  ClientFd client(open_client(sut.link_path()));
  ASSERT_GE(client, 0);
  EXPECT_TRUE(read_available(client).empty());
}

TEST(PtyPort, BytesWrittenBeforeCloseAreReadBeforeTheHangUp) {
  TempDir dir;
  PtyPort sut(dir.file("ttyDXL0"));
  ClientFd client(open_client(sut.link_path()));
  ASSERT_GE(client, 0);
  ASSERT_TRUE(sut.wait_for_client(kSecondNs));
  const std::vector<uint8_t> ping{0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB};

  ASSERT_TRUE(write_all(client, ping));
  client.close();
  const auto seen = port_read_until_hang_up(sut);

  EXPECT_EQ(seen, ping);
  EXPECT_TRUE(sut.hung_up());
}

TEST(PtyPort, ClientThatCameAndWentBeforeWeLookedIsStillServed) {
  TempDir dir;
  PtyPort sut(dir.file("ttyDXL0"));
  const std::vector<uint8_t> broadcast_write{0xFF, 0xFF, 0xFE, 0x04, 0x03, 0x03, 0x01, 0xF6};
  ClientFd client(open_client(sut.link_path()));
  ASSERT_GE(client, 0);
  ASSERT_TRUE(write_all(client, broadcast_write));
  client.close();

  const bool connected = sut.wait_for_client(kSecondNs);
  const auto seen = port_read_until_hang_up(sut);

  EXPECT_TRUE(connected);
  EXPECT_EQ(seen, broadcast_write);
}

// The next open starts clean: nothing written for the previous client, read or not, reaches it,
// and nothing the previous client wrote is read again.
TEST(PtyPort, NextClientSeesNoStaleBytesAfterReconnect) {
  TempDir dir;
  PtyPort sut(dir.file("ttyDXL0"));
  ClientFd first(open_client(sut.link_path()));
  ASSERT_GE(first, 0);
  ASSERT_TRUE(sut.wait_for_client(kSecondNs));
  const std::vector<uint8_t> unread_reply{0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC};
  ASSERT_EQ(sut.write(unread_reply.data(), unread_reply.size()), unread_reply.size());
  ASSERT_TRUE(write_all(first, {0xFF, 0xFF, 0x01, 0x04}));  // half a READ
  first.close();
  port_read_until_hang_up(sut);
  ASSERT_TRUE(sut.hung_up());

  sut.disconnect();
  ClientFd second(open_client(sut.link_path()));
  ASSERT_GE(second, 0);
  const bool connected = sut.wait_for_client(kSecondNs);
  const auto stale_at_client = read_available(second);
  uint8_t buffer[16];
  const std::size_t stale_at_doppel = sut.read(buffer, sizeof(buffer));
  const std::vector<uint8_t> fresh{0xAA, 0x55};
  ASSERT_EQ(sut.write(fresh.data(), fresh.size()), fresh.size());
  const auto fresh_at_client = read_bytes(second, 2, 1s);

  EXPECT_TRUE(connected);
  EXPECT_FALSE(sut.hung_up());
  EXPECT_TRUE(stale_at_client.empty());
  EXPECT_EQ(stale_at_doppel, 0u);
  EXPECT_EQ(fresh_at_client, fresh);
}

TEST(PtyPort, ClientKilledMidPacketLeavesNoStaleBytes) {
  TempDir dir;
  PtyPort sut(dir.file("ttyDXL0"));
  const std::vector<uint8_t> partial{0xFF, 0xFF, 0x01, 0x04, 0x02};
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    const int fd = open_client(sut.link_path());
    if (fd < 0 || !write_all(fd, partial)) ::_exit(1);
    ::pause();  // killed here, port still open, packet unfinished
    ::_exit(0);
  }
  ASSERT_TRUE(sut.wait_for_client(kSecondNs));
  const auto seen = port_read(sut, partial.size());
  const std::vector<uint8_t> reply_nobody_reads{0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC};
  ASSERT_EQ(sut.write(reply_nobody_reads.data(), reply_nobody_reads.size()), reply_nobody_reads.size());
  ::kill(child, SIGKILL);
  int status = 0;
  ::waitpid(child, &status, 0);
  port_read_until_hang_up(sut);
  const bool hung_up = sut.hung_up();

  sut.disconnect();
  ClientFd next(open_client(sut.link_path()));
  ASSERT_GE(next, 0);
  ASSERT_TRUE(sut.wait_for_client(kSecondNs));
  const auto stale = read_available(next);

  EXPECT_EQ(seen, partial);
  EXPECT_TRUE(WIFSIGNALED(status));
  EXPECT_TRUE(hung_up);
  EXPECT_TRUE(stale.empty());
}

TEST(PtyPort, RestoresRawModeForTheNextClient) {
  TempDir dir;
  PtyPort sut(dir.file("ttyDXL0"));
  ClientFd first(open_client(sut.link_path()));
  ASSERT_GE(first, 0);
  termios cooked{};
  ASSERT_EQ(::tcgetattr(first, &cooked), 0);
  cooked.c_lflag |= ECHO | ICANON;
  ASSERT_EQ(::tcsetattr(first, TCSANOW, &cooked), 0);
  ASSERT_TRUE(sut.wait_for_client(kSecondNs));
  first.close();
  port_read_until_hang_up(sut);

  sut.disconnect();
  ClientFd next(open_client(sut.link_path()));
  ASSERT_GE(next, 0);
  termios tio{};
  ASSERT_EQ(::tcgetattr(next, &tio), 0);

  EXPECT_EQ(tio.c_lflag & (ECHO | ICANON), 0u);
}

}  // namespace
}  // namespace doppel::bus
