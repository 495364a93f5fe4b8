#include "bus/latency_timer_files.h"

#include <fcntl.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/inotify.h>
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <stdexcept>

#include "base/latency_timer.h"

namespace doppel::bus {
namespace {

std::runtime_error system_error(const std::string& what, const std::string& path) {
  return std::runtime_error(what + " " + path + ": " + std::strerror(errno));
}

}  // namespace

LatencyTimerFiles::LatencyTimerFiles(std::ostream& messages) : messages_(messages) {
  inotify_fd_ = ::inotify_init1(IN_CLOEXEC | IN_NONBLOCK);
  if (inotify_fd_ < 0) throw std::runtime_error(std::string("latency-timer files: inotify: ") + std::strerror(errno));
  stop_fd_ = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  if (stop_fd_ < 0) {
    ::close(inotify_fd_);
    throw std::runtime_error(std::string("latency-timer files: eventfd: ") + std::strerror(errno));
  }
}

LatencyTimerFiles::~LatencyTimerFiles() {
  stop();
  for (const Watched& file : files_) {
    struct stat now {};
    if (::lstat(file.path.c_str(), &now) == 0 && now.st_dev == file.dev && now.st_ino == file.ino) {
      ::unlink(file.path.c_str());
    }
    ::close(file.pin_fd);
  }
  ::close(stop_fd_);
  ::close(inotify_fd_);
}

std::string LatencyTimerFiles::path_for_link(const std::string& link) { return link + ".latency_timer"; }

void LatencyTimerFiles::write_value(const std::string& path, uint32_t latency_ms) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_NOFOLLOW | O_CLOEXEC, 0600);
  if (fd < 0) throw system_error("cannot create the latency-timer file", path);
  const std::string text = std::to_string(latency_ms) + "\n";
  const ssize_t written = ::write(fd, text.data(), text.size());
  const int saved = errno;
  ::close(fd);
  errno = saved;
  if (written != static_cast<ssize_t>(text.size())) throw system_error("cannot write the latency-timer file", path);
}

void LatencyTimerFiles::add(const std::string& path, BusServer& server) {
  write_value(path, server.adapter_latency_ms());
  const int pin_fd = ::open(path.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC);
  struct stat created {};
  if (pin_fd < 0 || ::fstat(pin_fd, &created) != 0) {
    const int saved = errno;
    if (pin_fd >= 0) ::close(pin_fd);
    errno = saved;
    throw system_error("cannot open the latency-timer file", path);
  }
  const int watch = ::inotify_add_watch(inotify_fd_, path.c_str(), IN_CLOSE_WRITE | IN_DONT_FOLLOW);
  if (watch < 0) {
    const int saved = errno;
    ::close(pin_fd);
    errno = saved;
    throw system_error("cannot watch the latency-timer file", path);
  }
  files_.push_back(Watched{path, &server, watch, created.st_dev, created.st_ino, pin_fd});
}

void LatencyTimerFiles::start() {
  if (thread_.joinable()) return;
  thread_ = std::thread([this] { watch_loop(); });
}

void LatencyTimerFiles::stop() {
  if (!thread_.joinable()) return;
  const uint64_t one = 1;
  [[maybe_unused]] const ssize_t n = ::write(stop_fd_, &one, sizeof(one));
  thread_.join();
}

void LatencyTimerFiles::watch_loop() noexcept {
  alignas(struct inotify_event) std::array<char, 4096> events{};
  for (;;) {
    std::array<pollfd, 2> fds{pollfd{inotify_fd_, POLLIN, 0}, pollfd{stop_fd_, POLLIN, 0}};
    if (::poll(fds.data(), fds.size(), -1) < 0 && errno != EINTR) return;
    if (fds[1].revents != 0) return;
    const ssize_t n = ::read(inotify_fd_, events.data(), events.size());
    for (ssize_t offset = 0; offset < n;) {
      const auto* event = reinterpret_cast<const struct inotify_event*>(events.data() + offset);
      offset += static_cast<ssize_t>(sizeof(struct inotify_event) + event->len);
      for (const Watched& file : files_) {
        if (file.watch != event->wd || (event->mask & IN_CLOSE_WRITE) == 0) continue;
        try {
          on_written(file);
        } catch (const std::exception& e) {
          messages_ << "doppel: " << e.what() << "\n" << std::flush;
        }
      }
    }
  }
}

void LatencyTimerFiles::on_written(const Watched& file) {
  std::array<char, 64> text{};
  const int fd = ::open(file.path.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC);
  if (fd < 0) throw system_error("cannot read the latency-timer file", file.path);
  const ssize_t n = ::read(fd, text.data(), text.size());
  ::close(fd);
  if (n < 0) throw system_error("cannot read the latency-timer file", file.path);
  const std::string_view written(text.data(), static_cast<std::size_t>(n));
  const uint32_t current = file.server->adapter_latency_ms();
  const std::optional<uint32_t> latency_ms = parse_latency_timer_ms(written);
  if (!latency_ms) {
    std::string shown(written.substr(0, written.size() == text.size() ? 32 : written.size()));
    if (!shown.empty() && shown.back() == '\n') shown.pop_back();
    messages_ << "doppel: " << file.path << ": '" << shown << "' is not a latency timer in " << kMinLatencyTimerMs
              << ".." << kMaxLatencyTimerMs << " ms; it stays " << current << " ms\n"
              << std::flush;
    write_value(file.path, current);  // as sysfs, the file never holds a refused value
    return;
  }
  if (*latency_ms == current) return;
  file.server->set_adapter_latency_ms(*latency_ms);
  messages_ << "doppel: " << file.path << ": USB latency timer " << current << " -> "
            << file.server->adapter_latency_ms() << " ms\n"
            << std::flush;
}

}  // namespace doppel::bus
