// A writer killed with SIGKILL (fork): the Reader returns exactly the messages of the chunks that
// were finished (flush()ed or full) before the kill, says so in recovery_note(), and the
// independent Python reader reads the same prefix.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <thread>

#include "mcap/mcap.h"
#include "mcap_test_support.h"

namespace doppel::mcap {
namespace {

using test::read_all;
using test::Written;

Written message(uint32_t i) {
  Written w;
  w.channel_id = static_cast<uint16_t>(1 + i % 2);
  w.sequence = i;
  w.log_time_ns = 5'000'000 + uint64_t{i} * 1000;
  w.publish_time_ns = w.log_time_ns;
  w.data.assign(40 + i % 13, static_cast<uint8_t>(i * 7));
  w.order = i;
  return w;
}

void write_message(Writer& w, uint32_t i) {
  const Written m = message(i);
  w.write(m.channel_id, m.sequence, m.log_time_ns, m.publish_time_ns, m.data);
}

// Runs mcap_read.py on `path`; its JSON output.
nlohmann::json python_read(const std::string& path) {
  const std::string command = std::string(DOPPEL_PYTHON3) + " " + DOPPEL_MCAP_READ_PY + " " + path;
  FILE* pipe = ::popen(command.c_str(), "r");
  std::string out;
  char buffer[4096];
  std::size_t n;
  while ((n = std::fread(buffer, 1, sizeof buffer, pipe)) > 0) out.append(buffer, n);
  const int status = ::pclose(pipe);
  EXPECT_EQ(status, 0) << command;
  return nlohmann::json::parse(out);
}

pid_t start_writer(const std::string& path, int notify_fd, bool endless) {
  const pid_t pid = ::fork();
  if (pid != 0) return pid;
  // The child: only the writer, then wait for the kill. _exit on any error (no gtest here).
  try {
    WriterOptions options;
    options.compression = Compression::kZstd;
    options.chunk_size = endless ? 2000 : (std::size_t{1} << 30);
    Writer w(path, options);
    const uint16_t s = w.add_schema("S", "protobuf", "d");
    w.add_channel(s, "/even", "protobuf");
    w.add_channel(s, "/odd", "protobuf");
    uint32_t i = 0;
    if (endless) {
      for (;; ++i) {
        write_message(w, i);
        if (i == 500) (void)!::write(notify_fd, "k", 1);
      }
    }
    for (int flushes = 0; flushes < 3; ++flushes) {
      for (int k = 0; k < 100; ++k) write_message(w, i++);
      w.flush();
    }
    (void)!::write(notify_fd, "f", 1);  // 300 messages in 3 finished chunks
    for (int k = 0; k < 50; ++k) write_message(w, i++);  // in the open chunk: lost by the kill
    (void)!::write(notify_fd, "o", 1);
    for (;;) ::pause();
  } catch (...) {
    ::_exit(3);
  }
}

void kill_after(pid_t pid, int notify_fd, std::size_t notes) {
  char note;
  for (std::size_t i = 0; i < notes; ++i) ASSERT_EQ(::read(notify_fd, &note, 1), 1) << "the writer child died";
  ::kill(pid, SIGKILL);
  int status = 0;
  ::waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL) << status;
}

TEST(McapKill, ReaderReturnsExactlyTheFlushedChunks) {
  test::ScratchDir dir;
  const std::string path = dir.file("killed.mcap");
  int fds[2];
  ASSERT_EQ(::pipe(fds), 0);
  const pid_t pid = start_writer(path, fds[1], false);
  ASSERT_GT(pid, 0);
  kill_after(pid, fds[0], 2);
  ::close(fds[0]);
  ::close(fds[1]);

  Reader sut(path);
  EXPECT_FALSE(sut.complete());
  EXPECT_NE(sut.recovery_note().find("no footer"), std::string::npos) << sut.recovery_note();
  EXPECT_NE(sut.recovery_note().find("3 complete chunks"), std::string::npos) << sut.recovery_note();
  const std::vector<Written> got = read_all(sut);
  ASSERT_EQ(got.size(), 300u);
  for (uint32_t i = 0; i < 300; ++i) ASSERT_EQ(got[i], message(i)) << i;
  EXPECT_EQ(sut.statistics().message_count, 300u);
  EXPECT_EQ(sut.statistics().chunk_count, 3u);
  EXPECT_EQ(sut.channels().size(), 2u);
  EXPECT_EQ(sut.schemas().at(1).name, "S");

  const nlohmann::json py = python_read(path);
  EXPECT_FALSE(py["complete"].get<bool>());
  EXPECT_EQ(py["message_count"], 300);
  EXPECT_EQ(py["chunk_count"], 3);
  EXPECT_EQ(py["channels"]["1"]["count"], 150);
  EXPECT_EQ(py["channels"]["2"]["last_log_time"], message(299).log_time_ns);
}

TEST(McapKill, AKillWhileWritingLeavesAReadablePrefix) {
  test::ScratchDir dir;
  const std::string path = dir.file("killed_mid.mcap");
  int fds[2];
  ASSERT_EQ(::pipe(fds), 0);
  const pid_t pid = start_writer(path, fds[1], true);
  ASSERT_GT(pid, 0);
  kill_after(pid, fds[0], 1);  // somewhere after message 500, the child still writing
  ::close(fds[0]);
  ::close(fds[1]);

  Reader sut(path);
  EXPECT_FALSE(sut.complete());
  EXPECT_NE(sut.recovery_note(), "");
  const std::vector<Written> got = read_all(sut);
  ASSERT_GE(got.size(), 400u);  // chunks of 2000 bytes hold about 30 messages
  for (uint32_t i = 0; i < got.size(); ++i) ASSERT_EQ(got[i], message(i)) << i;
  EXPECT_EQ(sut.statistics().message_count, got.size());
  const nlohmann::json py = python_read(path);
  EXPECT_EQ(py["message_count"].get<std::size_t>(), got.size());
}

}  // namespace
}  // namespace doppel::mcap
