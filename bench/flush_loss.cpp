// flush_loss: how many SYNC WRITEs a pty loses to a client that flushes its output queue, against
// the real `doppel`. On a USB adapter the bytes of a finished write() have left, so tcflush
// (TCOFLUSH) loses nothing; on a pty the slave's TCOFLUSH discards what the kernel has not yet moved
// to the master (drivers/tty/pty.c, pty_flush_buffer). Two client patterns, written from termios(3)
// as pyserial's flushInput()/flushOutput() do them, each with the next packet at once:
//   before: tcflush(TCIFLUSH), tcflush(TCOFLUSH), write(SYNC WRITE)   (pypot, every packet)
//   after:  write(SYNC WRITE), tcflush(TCOFLUSH)
// A SYNC WRITE is lost when doppel did not frame it with a good checksum (doppel's own counters,
// printed at exit); a final PING proves the line is still in step. Doppel itself is the only
// program that can see the loss, so this tool reads its summary.
//
//   flush_loss [--packets N] [--timing wire|fast|both]
#include <fcntl.h>
#include <poll.h>
#include <sys/wait.h>
#include <termios.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <regex>
#include <stdexcept>
#include <string>
#include <vector>

#include "doppel_process.h"
#include "reference_client.h"
#include "tool_command_line.h"

namespace {

using doppel::testing::Bytes;
using doppel::testing::DoppelProcess;

int open_port(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK);
  if (fd < 0) throw std::runtime_error("open " + path + ": " + std::strerror(errno));
  termios tio{};
  ::tcgetattr(fd, &tio);
  ::cfmakeraw(&tio);
  tio.c_cflag |= CLOCAL | CREAD;
  tio.c_cc[VMIN] = 0;
  tio.c_cc[VTIME] = 0;
  ::cfsetspeed(&tio, B1000000);
  ::tcsetattr(fd, TCSANOW, &tio);
  return fd;
}

void write_all(int fd, const Bytes& bytes) {
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n > 0) {
      done += static_cast<std::size_t>(n);
    } else {
      pollfd p{fd, POLLOUT, 0};
      ::poll(&p, 1, 10);
    }
  }
}

// SYNC WRITE of Goal Position (30) to the mx-test robot's servos 1..5 (reference §1.7 layout).
Bytes sync_write(uint16_t goal) {
  Bytes params{30, 2};
  for (uint8_t id = 1; id <= 5; ++id) {
    params.insert(params.end(), {id, static_cast<uint8_t>(goal & 0xFF), static_cast<uint8_t>(goal >> 8)});
  }
  return doppel::testing::p1_instruction(0xFE, 0x83, params);
}

struct Counts {
  unsigned long long packets = 0, bad = 0, garbage = 0, timeouts = 0;
};

Counts parse_summary(const std::string& output) {
  static const std::regex line(
      R"(packets (\d+) \(bad checksum (\d+), [^)]*\), garbage bytes skipped (\d+), inter-byte timeouts (\d+))");
  std::smatch m;
  if (!std::regex_search(output, m, line)) throw std::runtime_error("no bus summary in doppel's output:\n" + output);
  return {std::stoull(m[1]), std::stoull(m[2]), std::stoull(m[3]), std::stoull(m[4])};
}

struct Row {
  int sent = 0;
  unsigned long long lost = 0;
  Counts counts;
  bool ping_ok = false;
};

Row run(const std::string& timing, bool flush_before, int packets) {
  DoppelProcess doppel({"--robot", "mx-test", "--timing", timing});
  doppel.wait_for_output("running until");
  const int fd = open_port(doppel.link());
  Row row;
  for (int i = 0; i < packets; ++i) {
    const Bytes packet = sync_write(static_cast<uint16_t>(412 + (i % 200)));
    if (flush_before) {
      ::tcflush(fd, TCIFLUSH);
      ::tcflush(fd, TCOFLUSH);
      write_all(fd, packet);
    } else {
      write_all(fd, packet);
      ::tcflush(fd, TCOFLUSH);
    }
    ++row.sent;
  }
  ::close(fd);
  // A fresh session: its PING must be answered, whatever the flushes left behind.
  doppel::testing::SerialClient client(doppel.link(), 1000000);
  row.ping_ok = client.transact(doppel::testing::p1_instruction(1, 0x01), 6, 500).size() == 6;
  doppel.stop();
  row.counts = parse_summary(doppel.output());
  const unsigned long long good = row.counts.packets - row.counts.bad - (row.ping_ok ? 1 : 0);
  row.lost = static_cast<unsigned long long>(row.sent) > good ? row.sent - good : 0;
  return row;
}

}  // namespace

int main(int argc, char** argv) {
  int packets = 10000;
  std::string timing = "both";
  CLI::App app("SYNC WRITEs lost to client-side output flushes on a pty", "flush_loss");
  app.add_option("--packets", packets)->check(CLI::PositiveNumber);
  app.add_option("--timing", timing)->check(CLI::IsMember({"fast", "wire", "both"}));
  if (auto exit_code = doppel::bench::parse_command_line(
          app, argc, argv, "usage: flush_loss [--packets N] [--timing wire|fast|both]\n")) {
    return *exit_code;
  }
  std::printf("%d SYNC WRITEs (23 bytes, 5 servos) per row, the next at once\n\n", packets);
  std::printf("| client | timing | lost / sent | lost %% | bad checksums | garbage bytes | timeouts | PING after |\n");
  std::printf("|---|---|---|---|---|---|---|---|\n");
  for (const std::string mode : {"wire", "fast"}) {
    if (timing != "both" && timing != mode) continue;
    for (bool before : {true, false}) {
      const Row row = run(mode, before, packets);
      std::printf("| %s | %s | %llu / %d | %.2f %% | %llu | %llu | %llu | %s |\n",
                  before ? "flush in+out before each" : "flush out after each", mode.c_str(), row.lost, row.sent,
                  100.0 * static_cast<double>(row.lost) / row.sent, row.counts.bad, row.counts.garbage,
                  row.counts.timeouts, row.ping_ok ? "answered" : "LOST");
      std::fflush(stdout);
    }
  }
  return 0;
}
