#include "bus/pty_port.h"

#include <fcntl.h>
#include <poll.h>
#include <sys/inotify.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <new>
#include <stdexcept>

#include "base/pty_handover.h"
#include "line_speed.h"
#include "posix_call.h"

namespace doppel::bus {
namespace {

using detail::posix_call;
using detail::SysResult;

constexpr int64_t kFallbackPollNs = 1'000'000;  // client check period when inotify is unavailable

[[noreturn]] void fail(const std::string& what, int error) {
  throw std::runtime_error("PtyPort: " + what + ": " + std::strerror(error));
}

timespec to_timespec(int64_t ns) noexcept {
  ns = std::max<int64_t>(ns, 0);
  return timespec{static_cast<time_t>(ns / 1'000'000'000), static_cast<long>(ns % 1'000'000'000)};
}

// Checks the place of `link_path`: its directory must exist (LinkDirectory makes it safely, so
// nothing here creates a directory or follows a symlink to one) and anything already there must be
// a symlink (a stale link from an earlier run), never a file someone else put there.
void check_link_place(const std::string& link_path) {
  const std::string parent = std::filesystem::path(link_path).parent_path().string();
  struct stat parent_st {};
  if (!parent.empty() && (::stat(parent.c_str(), &parent_st) != 0 || !S_ISDIR(parent_st.st_mode))) {
    throw std::runtime_error("PtyPort: the directory '" + parent + "' of the port link '" + link_path +
                             "' does not exist");
  }
  struct stat st {};
  if (::lstat(link_path.c_str(), &st) == 0) {
    if (!S_ISLNK(st.st_mode)) {
      throw std::runtime_error("PtyPort: '" + link_path +
                               "' exists and is not a symbolic link; refusing to replace it");
    }
  } else if (errno != ENOENT) {
    fail("cannot inspect '" + link_path + "'", errno);
  }
}

// Points `link_path` at `target`, swapping an existing link atomically (symlink to a temporary
// name + rename), after check_link_place.
void install_symlink(const std::string& link_path, const std::string& target) {
  check_link_place(link_path);
  const std::string temporary = link_path + ".tmp." + std::to_string(::getpid());
  ::unlink(temporary.c_str());
  if (::symlink(target.c_str(), temporary.c_str()) != 0) {
    fail("cannot create symlink '" + temporary + "' -> '" + target + "'", errno);
  }
  if (::rename(temporary.c_str(), link_path.c_str()) != 0) {
    const int error = errno;
    ::unlink(temporary.c_str());
    fail("cannot move symlink into place at '" + link_path + "'", error);
  }
}

}  // namespace

PtyPort::PtyPort(std::string link_path, LinkTiming timing) : link_path_(std::move(link_path)) {
  if (link_path_.empty()) throw std::invalid_argument("PtyPort: empty link path");
  master_fd_ = ::posix_openpt(O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (master_fd_ < 0) fail("posix_openpt", errno);
  try {
    // Belt and braces: posix_openpt is only specified for O_RDWR | O_NOCTTY.
    if (::fcntl(master_fd_, F_SETFD, FD_CLOEXEC) != 0) fail("fcntl(FD_CLOEXEC)", errno);
    const int flags = ::fcntl(master_fd_, F_GETFL);
    if (flags < 0 || ::fcntl(master_fd_, F_SETFL, flags | O_NONBLOCK) != 0) fail("fcntl(O_NONBLOCK)", errno);
    if (::grantpt(master_fd_) != 0) fail("grantpt", errno);
    if (::unlockpt(master_fd_) != 0) fail("unlockpt", errno);
    std::array<char, 128> name{};
    if (const int error = ::ptsname_r(master_fd_, name.data(), name.size()); error != 0) fail("ptsname_r", error);
    slave_path_ = name.data();

    // Opening and closing the slave once puts the master in its "no client" state (POLLHUP/EIO),
    // the same state every later hang-up leaves it in, and sets raw mode for clients that do not.
    make_slave_raw_and_flush();

    inotify_fd_ = ::inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
    if (inotify_fd_ >= 0 && ::inotify_add_watch(inotify_fd_, slave_path_.c_str(), IN_OPEN) < 0) {
      ::close(inotify_fd_);
      inotify_fd_ = -1;
    }
    // The link's place is checked before anything is made beside it (the hand-over counter).
    check_link_place(link_path_);
    create_received_file();
    if (timing == LinkTiming::kNow) {
      publish_link();
    } else {
      // A stale link from an earlier run goes at once: nothing opens it while this port is set up.
      if (::unlink(link_path_.c_str()) != 0 && errno != ENOENT) fail("cannot remove the stale link '" + link_path_ + "'", errno);
    }
  } catch (...) {
    release_link();
    close_all();
    throw;
  }
}

std::string PtyPort::received_path_for_link(const std::string& link_path) { return link_path + kHandoverSuffix; }

void PtyPort::create_received_file() {
  // Never through a symlink, and never over something that is not a regular file; a stale one
  // (an earlier doppel that was killed) is started afresh.
  const std::string path = received_path_for_link(link_path_);
  struct stat st {};
  if (::lstat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode)) {
    throw std::runtime_error("PtyPort: '" + path + "' exists and is not a regular file; refusing to replace it");
  }
  const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_TRUNC | O_NOFOLLOW | O_CLOEXEC, 0644);
  if (fd < 0) fail("cannot create the hand-over counter '" + path + "'", errno);
  if (::ftruncate(fd, static_cast<off_t>(kHandoverFileBytes)) != 0 || ::fstat(fd, &st) != 0) {
    const int error = errno;
    ::close(fd);
    fail("cannot size the hand-over counter '" + path + "'", error);
  }
  void* p = ::mmap(nullptr, kHandoverFileBytes, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
  if (p == MAP_FAILED) {
    const int error = errno;
    ::close(fd);
    fail("cannot map the hand-over counter '" + path + "'", error);
  }
  received_ = new (p) std::atomic<uint64_t>(0);
  received_fd_ = fd;
  received_dev_ = st.st_dev;
  received_ino_ = st.st_ino;
}

void PtyPort::remove_received_file() noexcept {
  if (received_ != nullptr) ::munmap(received_, kHandoverFileBytes);
  received_ = nullptr;
  if (received_fd_ < 0) return;
  const std::string path = received_path_for_link(link_path_);
  struct stat st {};
  if (::lstat(path.c_str(), &st) == 0 && st.st_dev == received_dev_ && st.st_ino == received_ino_) ::unlink(path.c_str());
  ::close(received_fd_);
  received_fd_ = -1;
}

PtyPort::~PtyPort() {
  if (release_link() == LinkRelease::kReplaced) {
    std::fprintf(stderr,
                 "doppel: '%s' no longer points at this port's %s: someone replaced it while doppel ran; "
                 "leaving it alone\n",
                 link_path_.c_str(), slave_path_.c_str());
  }
  close_all();
}

void PtyPort::publish_link() {
  if (link_published_) return;
  install_symlink(link_path_, slave_path_);
  link_published_ = true;
}

PtyPort::LinkRelease PtyPort::release_link() noexcept {
  if (link_released_ || !link_published_) {
    link_released_ = true;
    return LinkRelease::kGone;
  }
  link_released_ = true;
  struct stat st {};
  if (::lstat(link_path_.c_str(), &st) != 0) return LinkRelease::kGone;
  std::array<char, 4096> target{};
  const ssize_t n = ::readlink(link_path_.c_str(), target.data(), target.size() - 1);
  const bool ours = S_ISLNK(st.st_mode) && st.st_uid == ::geteuid() && n > 0 &&
                    slave_path_ == std::string(target.data(), static_cast<std::size_t>(n));
  if (!ours) return LinkRelease::kReplaced;
  ::unlink(link_path_.c_str());
  return LinkRelease::kRemoved;
}

void PtyPort::close_all() noexcept {
  remove_received_file();
  if (inotify_fd_ >= 0) ::close(inotify_fd_);
  if (master_fd_ >= 0) ::close(master_fd_);
  inotify_fd_ = -1;
  master_fd_ = -1;
}

std::size_t PtyPort::read(uint8_t* dst, std::size_t capacity) noexcept {
  if (capacity == 0) return 0;
  const SysResult r = posix_call([&] { return ::read(master_fd_, dst, capacity); });
  if (r.ok()) {
    received_total_ += static_cast<uint64_t>(r.value);
    return static_cast<std::size_t>(r.value);
  }
  // Nothing left: this empty read waited for the kernel's hand-over work item to finish, so only
  // now may the client go on (see the header).
  if (received_ != nullptr) received_->store(received_total_, std::memory_order_release);
  if (!r.would_block()) hung_up_ = true;  // EIO: the last client closed the slave
  return 0;
}

std::size_t PtyPort::write(const uint8_t* src, std::size_t n) noexcept {
  if (!connected_ || n == 0) return 0;
  const SysResult r = posix_call([&] { return ::write(master_fd_, src, n); });
  if (r.ok()) return static_cast<std::size_t>(r.value);
  if (!r.would_block()) hung_up_ = true;
  return 0;
}

PortWait PtyPort::wait(int64_t timeout_ns, bool want_write) noexcept {
  PortWait result;
  if (!connected_) {
    result.readable = wait_for_client(timeout_ns);
    return result;
  }
  pollfd pfd{master_fd_, static_cast<short>(POLLIN | (want_write ? POLLOUT : 0)), 0};
  const timespec timeout = to_timespec(timeout_ns);
  const SysResult r = posix_call([&] { return ::ppoll(&pfd, 1, &timeout, nullptr); });
  if (!r.ok() || r.value == 0) return result;
  result.hung_up = (pfd.revents & POLLHUP) != 0;
  // Bytes a departing client wrote are still readable before the EIO, so a hang-up means "read".
  result.readable = (pfd.revents & (POLLIN | POLLHUP | POLLERR)) != 0;
  result.writable = (pfd.revents & POLLOUT) != 0;
  return result;
}

bool PtyPort::poll_client() noexcept {
  if (connected_) return true;
  pollfd pfd{master_fd_, POLLIN, 0};
  const timespec zero{0, 0};
  const SysResult r = posix_call([&] { return ::ppoll(&pfd, 1, &zero, nullptr); });
  if (!r.ok()) return false;
  // No POLLHUP: someone holds the slave open. POLLIN with POLLHUP: a client came, wrote and left
  // before we looked; its bytes still crossed the wire, so serve them as a short session.
  if (r.value == 0 || (pfd.revents & POLLHUP) == 0 || (pfd.revents & POLLIN) != 0) {
    connected_ = true;
    hung_up_ = false;
  }
  return connected_;
}

bool PtyPort::wait_for_client(int64_t timeout_ns) noexcept {
  if (poll_client()) return true;
  if (inotify_fd_ >= 0) {
    pollfd pfd{inotify_fd_, POLLIN, 0};
    const timespec timeout = to_timespec(timeout_ns);
    posix_call([&] { return ::ppoll(&pfd, 1, &timeout, nullptr); });
    // Drain before checking the line: an open after the check leaves a fresh event, so the next
    // wait wakes at once instead of missing it.
    drain_inotify();
  } else {
    const timespec pause = to_timespec(std::min(timeout_ns, kFallbackPollNs));
    ::nanosleep(&pause, nullptr);
  }
  return poll_client();
}

void PtyPort::drain_inotify() noexcept {
  if (inotify_fd_ < 0) return;
  alignas(inotify_event) std::array<char, 4096> events;
  while (posix_call([&] { return ::read(inotify_fd_, events.data(), events.size()); }).value > 0) {
  }
}

void PtyPort::disconnect() noexcept {
  // A client that opened since the hang-up holds the slave already: its termios are its own.
  pollfd pfd{master_fd_, POLLIN, 0};
  const timespec zero{0, 0};
  const SysResult r = posix_call([&] { return ::ppoll(&pfd, 1, &zero, nullptr); });
  const bool client_present = r.ok() && (pfd.revents & POLLHUP) == 0;
  // Its input queue may already hold our answers to it, so it is not flushed either.
  if (!client_present) make_slave_raw_and_flush();
  // Our own open of the slave raised an IN_OPEN event; it must not look like a new client.
  drain_inotify();
  connected_ = false;
  hung_up_ = false;
}

namespace {

// The termios flags that change the bytes themselves (translation, echo, line editing, signals,
// character size, parity). VMIN/VTIME and the speed only shape the client's own reads.
bool bytes_pass_unchanged(const termios& tio) noexcept {
  termios raw = tio;
  ::cfmakeraw(&raw);
  raw.c_cflag |= CLOCAL | CREAD;
  return raw.c_iflag == tio.c_iflag && raw.c_oflag == tio.c_oflag && raw.c_lflag == tio.c_lflag &&
         raw.c_cflag == tio.c_cflag;
}

}  // namespace

void PtyPort::make_slave_raw_and_flush() noexcept {
  // TIOCGPTPEER opens exactly our slave without a path lookup; the path is the fallback for
  // kernels before 4.13.
  SysResult r = posix_call(
      [&] { return ::ioctl(master_fd_, TIOCGPTPEER, O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC); });
  if (!r.ok()) {
    r = posix_call([&] { return ::open(slave_path_.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC); });
  }
  if (!r.ok()) return;
  const int slave = static_cast<int>(r.value);
  // Writing the termios is a read-modify-write of the whole set, speed included: a client that
  // opens and sets its rate in between would get the old rate back (tests/gateway
  // reopen_race_test.cpp). So they are written only when the last client left the bytes to be
  // changed, which no serial driver does (and disconnect() does not come here at all once a new
  // client holds the slave).
  termios tio{};
  if (::tcgetattr(slave, &tio) == 0 && !bytes_pass_unchanged(tio)) {
    ::cfmakeraw(&tio);  // keeps the line speed the last client set
    tio.c_cflag |= CLOCAL | CREAD;
    tio.c_cc[VMIN] = 0;
    tio.c_cc[VTIME] = 0;
    ::tcsetattr(slave, TCSANOW, &tio);
  }
  // The slave's input queue holds what the old client never read.
  ::tcflush(slave, TCIFLUSH);
  ::close(slave);
}

uint32_t PtyPort::line_baud_bps() const noexcept { return detail::line_speed_bps(master_fd_); }

}  // namespace doppel::bus
